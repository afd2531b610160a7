# Sourced by scripts/demo.sh and scripts/test.sh: installs what is missing
# (Debian 12 packages only), sets up the environment and builds the package
# incrementally in _build/ (git-ignored). A second run with nothing changed
# installs nothing and rebuilds nothing.
# Knobs: IMT_BUILD_DIR (default _build), IMT_BUILD_TYPE (default RelWithDebInfo).

IMT_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
IMT_BUILD_DIR=${IMT_BUILD_DIR:-$IMT_ROOT/_build}
IMT_BUILD_TYPE=${IMT_BUILD_TYPE:-RelWithDebInfo}

IMT_PACKAGES=(
  build-essential cmake
  ros-base-dev ros-core-python-dev python3-rostest rosbash
  libimage-transport-dev libcv-bridge-dev libtf2-ros-dev libmessage-filters-dev libtf2-geometry-msgs-dev libtf2-eigen-dev
  libceres-dev libopencv-dev libopencv-contrib-dev libeigen3-dev
  libyaml-cpp-dev nlohmann-json3-dev libgtest-dev libbenchmark-dev
  libdiagnostic-updater-dev python3-tf2-msgs python3-opencv
)

imt_log() { printf '[imt] %s\n' "$*" >&2; }

imt_install() {
  local missing=() p
  for p in "${IMT_PACKAGES[@]}"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  [ ${#missing[@]} -eq 0 ] && return 0
  imt_log "installing ${#missing[@]} missing Debian packages: ${missing[*]}"
  local sudo=""
  [ "$(id -u)" -ne 0 ] && sudo="sudo"
  export DEBIAN_FRONTEND=noninteractive
  $sudo apt-get update -qq
  $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
}

imt_env() {
  # A pyenv python first in PATH breaks catkin (no catkin_pkg) and rospy nodes.
  export PATH=/usr/bin:/bin:/usr/sbin:/sbin:$PATH
  export ROS_HOME=${ROS_HOME:-$IMT_BUILD_DIR/ros_home}
  export ROS_LOG_DIR=${ROS_LOG_DIR:-$ROS_HOME/log}
  export ROS_HOSTNAME=${ROS_HOSTNAME:-localhost}
  mkdir -p "$ROS_LOG_DIR"
}

imt_build() {
  # targets: "all" (default) or e.g. "all tests"
  # A configure that failed (e.g. before the packages were installed) leaves a
  # CMakeCache.txt but no Makefile: configure again then.
  if [ ! -f "$IMT_BUILD_DIR/Makefile" ]; then
    imt_log "configuring in $IMT_BUILD_DIR"
    mkdir -p "$IMT_BUILD_DIR"
    cmake -S "$IMT_ROOT" -B "$IMT_BUILD_DIR" -DCMAKE_BUILD_TYPE="$IMT_BUILD_TYPE" \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 >"$IMT_BUILD_DIR/cmake.log" 2>&1 ||
      { cat "$IMT_BUILD_DIR/cmake.log" >&2; return 1; }
  fi
  imt_log "building: $*"
  # gcc 12 once hit a sporadic internal compiler error on a large ROS .cpp: retry once.
  make -C "$IMT_BUILD_DIR" -j"$(nproc)" --no-print-directory "$@" >"$IMT_BUILD_DIR/build.log" 2>&1 ||
    make -C "$IMT_BUILD_DIR" -j1 --no-print-directory "$@" >"$IMT_BUILD_DIR/build.log" 2>&1 ||
    { tail -n 60 "$IMT_BUILD_DIR/build.log" >&2; imt_log "build failed (full log: $IMT_BUILD_DIR/build.log)"; return 1; }
  # The catkin setup scripts read unset variables (ROS_DISTRO): not under set -u.
  local had_u=0
  [[ $- == *u* ]] && had_u=1
  set +u
  # shellcheck disable=SC1091
  source "$IMT_BUILD_DIR/devel/setup.bash"
  [ "$had_u" = 1 ] && set -u
  return 0
}
