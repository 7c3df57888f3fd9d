// Compiled with the settings of the ROS-free modules by the ctest core_cannot_include_ros_headers,
// which passes only when this fails to compile with the ROS header guard's message
// (cmake/htr_modules.cmake): proof that a core source cannot include a ROS header.
#include <ros/ros.h>

int probeRosFreeRule() { return 0; }
