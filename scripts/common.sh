# Shared set-up of scripts/test and scripts/demo (sourced, not run).
# - installs the Debian packages the package needs (idempotent: apt runs only if one is missing);
# - works around the pyenv pitfall: ROS's CMake helpers need /usr/bin/python3 (with the ROS Python
#   modules), not a pyenv shim that comes first on PATH;
# - configures and builds the catkin package with plain CMake, with the tests, benchmarks and
#   evaluation programs (the repository root is the package; the devel space is BUILD_DIR/devel).

HTR_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
export PATH=/usr/bin:$PATH

# Everything the package builds, runs and tests with, on a bare Debian 12.
HTR_DEBIAN_PACKAGES=(
  build-essential cmake pkg-config git
  catkin catkin-lint rosbash
  libroscpp-dev librosbag-dev python3-rosbag python3-nav-msgs librostest-dev python3-rostest
  libactionlib-dev libactionlib-msgs-dev ros-actionlib-msgs python3-actionlib
  libdynamic-reconfigure-config-init-mutex-dev python3-dynamic-reconfigure
  libnodeletlib-dev libnodelet-dev libnodeletlib-tools pluginlib-dev
  libcv-bridge-dev libimage-transport-dev libdiagnostic-updater-dev
  libnav-msgs-dev libvisualization-msgs-dev libtf2-ros-dev libtf2-eigen-dev libstd-srvs-dev
  ros-std-msgs ros-sensor-msgs ros-geometry-msgs ros-nav-msgs ros-diagnostic-msgs
  libopencv-dev libeigen3-dev libyaml-cpp-dev nlohmann-json3-dev
  libgtest-dev googletest libbenchmark-dev
  clang clang-tidy libclang-rt-14-dev
  opencv-doc python3-matplotlib
  rviz xvfb xauth imagemagick
)

htr_log() { printf '\n==> %s\n' "$*"; }

htr_install_dependencies() {
  local missing=()
  local package
  for package in "${HTR_DEBIAN_PACKAGES[@]}"; do
    if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q 'install ok installed'; then
      missing+=("$package")
    fi
  done
  if [ ${#missing[@]} -eq 0 ]; then
    htr_log "all ${#HTR_DEBIAN_PACKAGES[@]} Debian packages present"
    return 0
  fi
  htr_log "installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  local sudo=()
  if [ "$(id -u)" -ne 0 ]; then
    if command -v sudo >/dev/null; then
      sudo=(sudo)
    else
      echo "error: not root and no sudo; install as root: apt-get install ${missing[*]}" >&2
      return 1
    fi
  fi
  "${sudo[@]}" apt-get update -q
  DEBIAN_FRONTEND=noninteractive "${sudo[@]}" apt-get install -y -q --no-install-recommends \
    "${missing[@]}"
}

# htr_configure BUILD_DIR [extra cmake arguments...]
htr_configure() {
  local build_dir=$1
  shift
  cmake -S "$HTR_ROOT" -B "$build_dir" \
    -DPYTHON_EXECUTABLE=/usr/bin/python3 -DPython3_EXECUTABLE=/usr/bin/python3 \
    -DCATKIN_ENABLE_TESTING=ON -DHTR_BUILD_EVALUATION=ON "$@"
}

# htr_build BUILD_DIR [targets...]
htr_build() {
  local build_dir=$1
  shift
  local jobs
  jobs=$(nproc)
  if [ $# -eq 0 ]; then
    cmake --build "$build_dir" -- -j"$jobs"
  else
    local target
    for target in "$@"; do cmake --build "$build_dir" --target "$target" -- -j"$jobs"; done
  fi
}
