#!/usr/bin/env bash
# Architecture rule (docs/design.md): the robot-facing programs link neither the simulator nor the
# evaluation library. Reads each binary's dynamic dependencies (ldd: the whole transitive closure).
# Usage: check_product_links.sh PRODUCT_BINARY... -- SIMULATOR_BINARY
# The simulator binary after "--" must link the simulator library: the check that the pattern
# below still names the libraries it guards.
set -u
forbidden='lib[a-z_]*_(sim|sim_nodes|eval)\.so'
products=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do products+=("$1"); shift; done
shift || true
control=${1:?usage: check_product_links.sh PRODUCT_BINARY... -- SIMULATOR_BINARY}
if ! ldd "$control" | grep -qE "$forbidden"; then
  echo "check broken: $control does not link a library matching '$forbidden'"
  exit 1
fi
status=0
for binary in "${products[@]}"; do
  hits=$(ldd "$binary" | grep -E "$forbidden")
  if [ -n "$hits" ]; then
    echo "$(basename "$binary") links what the robot does not run:"
    echo "$hits"
    status=1
  else
    echo "$(basename "$binary"): $(ldd "$binary" | grep -c homography_teach_repeat) package libraries, none of sim/eval"
  fi
done
exit $status
