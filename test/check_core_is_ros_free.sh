#!/usr/bin/env bash
# Architecture rule (DEVELOPERS.md): the core library never includes a ROS header.
# Usage: check_core_is_ros_free.sh PACKAGE_SOURCE_DIR
set -u
root=${1:?package source directory}
pattern='#include[[:space:]]*[<"](ros|tf2_ros|tf2_geometry_msgs|image_transport|cv_bridge|nodelet|actionlib|pluginlib|dynamic_reconfigure|diagnostic_updater|rosbag|[a-z_]+_msgs|homography_teach_repeat/ros|homography_teach_repeat/[A-Z][A-Za-z]*\.h)'
files=$(ls "$root"/include/homography_teach_repeat/*.h "$root"/src/core/* 2>/dev/null)
[ -n "$files" ] || { echo "no core files found under $root"; exit 1; }
hits=$(grep -nE "$pattern" $files)
if [ -n "$hits" ]; then
  echo "The ROS-free core includes ROS headers:"
  echo "$hits"
  exit 1
fi
echo "core is ROS-free: $(echo "$files" | wc -l) files checked"
