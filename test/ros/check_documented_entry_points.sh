#!/usr/bin/env bash
# ctest documented_entry_points: every `rosrun homography_teach_repeat PROGRAM` and every
# `roslaunch homography_teach_repeat FILE.launch` that README.md and docs/ show is started as a user
# would, after sourcing SETUP (the setup.bash the README names): `rosrun ... PROGRAM --help` must exit
# 0, and roslaunch must find and resolve each launch file (`roslaunch --files`, its required
# arguments given). The list comes from the documents themselves, so a new command is checked too.
# Usage: check_documented_entry_points.sh SETUP_BASH PACKAGE_SOURCE_DIR
setup=${1:?usage: check_documented_entry_points.sh SETUP_BASH PACKAGE_SOURCE_DIR}
root=${2:?usage: check_documented_entry_points.sh SETUP_BASH PACKAGE_SOURCE_DIR}
package=homography_teach_repeat
# As a user's shell does (ROS's profile scripts read unset variables).
# shellcheck disable=SC1090
source "$setup" || { echo "FAILED: cannot source $setup"; exit 1; }
set -uo pipefail
documents=("$root/README.md" "$root/docs")
programs=$(grep -rhoE "rosrun $package [A-Za-z0-9_]+" "${documents[@]}" | awk '{print $3}' | sort -u)
launch_files=$(grep -rhoE "roslaunch $package [A-Za-z0-9_]+\.launch" "${documents[@]}" | awk '{print $3}' | sort -u)
if [ "$(echo "$programs" | grep -c .)" -lt 3 ] || [ "$(echo "$launch_files" | grep -c .)" -lt 2 ]; then
  echo "FAILED: found too few documented commands (programs: $programs; launch files: $launch_files)"
  exit 1
fi
failed=0
checked=0
for program in $programs; do
  checked=$((checked + 1))
  if output=$(timeout 60 rosrun "$package" "$program" --help </dev/null 2>&1); then
    echo "ok: rosrun $package $program --help"
  else
    echo "FAILED (exit $?): rosrun $package $program --help"
    echo "$output" | tail -n 8
    failed=$((failed + 1))
  fi
done
for launch_file in $launch_files; do
  checked=$((checked + 1))
  # Arguments without a default (`<arg name="x" doc="..."/>`) are given a placeholder.
  required=()
  if path=$(rospack find "$package" 2>/dev/null)/launch/$launch_file && [ -f "$path" ]; then
    while read -r name; do required+=("$name:=placeholder"); done < <(
      grep -oE '<arg +name="[^"]+"( +doc="[^"]*")? */>' "$path" | sed -E 's/<arg +name="([^"]+)".*/\1/')
  fi
  if output=$(timeout 60 roslaunch --files "$package" "$launch_file" "${required[@]}" </dev/null 2>&1); then
    echo "ok: roslaunch $package $launch_file (resolves $(echo "$output" | grep -c .) files)"
  else
    echo "FAILED (exit $?): roslaunch --files $package $launch_file ${required[*]}"
    echo "$output" | tail -n 8
    failed=$((failed + 1))
  fi
done
echo "documented entry points: $((checked - failed)) of $checked start"
[ "$failed" -eq 0 ]
