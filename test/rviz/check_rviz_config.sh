#!/usr/bin/env bash
# Opens an rviz configuration headless (Xvfb, Mesa llvmpipe) with its own ROS master and fails
# when rviz exits early or reports an error (unknown display class, bad property, plugin that does
# not load, robot description that does not parse). Optionally saves a screenshot.
#   check_rviz_config.sh CONFIG.rviz URDF [SCREENSHOT.png]
set -euo pipefail
config=$1
urdf=$2
screenshot=${3:-}
seconds=${HTR_RVIZ_SECONDS:-12}

for tool in xvfb-run rviz rosmaster rosparam; do
  command -v "$tool" >/dev/null || { echo "check_rviz_config: '$tool' not found (install rviz xvfb xauth)" >&2; exit 1; }
done
[ -f "$config" ] || { echo "check_rviz_config: no config '$config'" >&2; exit 1; }

port=$((20000 + RANDOM % 20000))
export ROS_MASTER_URI=http://127.0.0.1:$port
ROS_HOME=$(mktemp -d)
export ROS_HOME
log=$ROS_HOME/rviz.log
rosmaster --core -p "$port" >"$ROS_HOME/master.log" 2>&1 &
master=$!
trap 'kill $master 2>/dev/null || true; wait $master 2>/dev/null || true; rm -rf "$ROS_HOME"' EXIT
for _ in $(seq 50); do rosparam list >/dev/null 2>&1 && break; sleep 0.2; done
# (rosparam set would parse the URDF as YAML)
/usr/bin/python3 -c 'import sys, rosgraph; rosgraph.Master("/check_rviz_config").setParam("/robot_description", open(sys.argv[1]).read())' "$urdf"

# rviz runs for `seconds`; still alive then = it loaded. The screenshot is of the whole screen.
status=0
xvfb-run -a -s '-screen 0 1600x1000x24' bash -c '
  rviz -d "$1" >"$2" 2>&1 &
  rviz=$!
  sleep "$3"
  if ! kill -0 $rviz 2>/dev/null; then echo "rviz exited early" >>"$2"; exit 3; fi
  if [ -n "$4" ]; then import -window root "$4" || echo "screenshot failed" >&2; fi
  kill $rviz; wait $rviz 2>/dev/null || true
' check "$config" "$log" "$seconds" "$screenshot" || status=$?

errors=$(grep -E '\[ *ERROR\]|\[ *FATAL\]|exited early|Segmentation fault|terminate called' "$log" || true)
if [ $status -ne 0 ] || [ -n "$errors" ]; then
  echo "check_rviz_config: FAILED ($config, exit status $status)"
  cat "$log"
  exit 1
fi
echo "check_rviz_config: '$config' loaded headless for ${seconds} s without errors"
grep -E 'OpenGl version|OpenGL' "$log" || true
