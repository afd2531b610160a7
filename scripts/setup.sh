# Sourced by scripts/demo.sh and scripts/test.sh: installs what is missing
# (Debian 12 packages only), sets up the environment and builds the package
# incrementally in _build/ (git-ignored). A second run with nothing changed
# installs nothing and rebuilds nothing.
# Knobs: IMT_BUILD_DIR (default _build), IMT_BUILD_TYPE (default RelWithDebInfo),
# IMT_CMAKE_ARGS (more cmake arguments at the first configure), IMT_SANITIZE=1
# (the ASan/UBSan build of scripts/sanitize.sh and scripts/fuzz.sh: in
# IMT_SANITIZE_DIR, default _build_sanitize, with -DIMT_SANITIZE=ON), IMT_TSAN=1
# (the ThreadSanitizer build of scripts/tsan.sh: in IMT_TSAN_DIR, default
# _build_tsan, with -DIMT_TSAN=ON).

IMT_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
if [ "${IMT_SANITIZE:-0}" = 1 ]; then
  IMT_BUILD_DIR=${IMT_SANITIZE_DIR:-$IMT_ROOT/_build_sanitize}
  IMT_CMAKE_ARGS="-DIMT_SANITIZE=ON ${IMT_CMAKE_ARGS:-}"
elif [ "${IMT_TSAN:-0}" = 1 ]; then
  IMT_BUILD_DIR=${IMT_TSAN_DIR:-$IMT_ROOT/_build_tsan}
  IMT_CMAKE_ARGS="-DIMT_TSAN=ON ${IMT_CMAKE_ARGS:-}"
fi
IMT_BUILD_DIR=${IMT_BUILD_DIR:-$IMT_ROOT/_build}
IMT_BUILD_TYPE=${IMT_BUILD_TYPE:-RelWithDebInfo}

IMT_PACKAGES=(
  build-essential cmake
  ros-base-dev ros-core-python-dev python3-rostest rosbash
  libimage-transport-dev libcv-bridge-dev libtf2-ros-dev libmessage-filters-dev libtf2-geometry-msgs-dev libtf2-eigen-dev
  libceres-dev libopencv-dev libopencv-contrib-dev libeigen3-dev
  libyaml-cpp-dev nlohmann-json3-dev libgtest-dev libbenchmark-dev
  libdiagnostic-updater-dev python3-tf2-msgs python3-opencv python3-rosbag python3-yaml
)

imt_log() { printf '[imt] %s\n' "$*" >&2; }

# imt_run_checked BINARY FILTER LOG WHAT REPORTS: one run of this build's gtest
# BINARY under a sanitizer, its output in LOG; on failure the lines matching
# the extended regex REPORTS (and failed tests) go to stderr. WHAT names the
# sanitizers in the verdict logged. Returns the run's success.
imt_run_checked() {
  local t=$1 filter=$2 log=$3 what=$4 reports=$5
  if ! "$IMT_BUILD_DIR/devel/lib/instant_motion_tracking/$t" --gtest_filter="$filter" >"$log" 2>&1; then
    imt_log "$t failed under $what (${log##*/}):"
    grep -E -A40 "$reports|\[  FAILED  \]" "$log" | head -120 >&2 || tail -40 "$log" >&2
    return 1
  fi
  imt_log "$t clean under $what (${log##*/}): $(grep -E '^\[  PASSED  \]' "$log" || echo '?')"
}

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
    # RelWithDebInfo with line tables only (-g1, not -g): backtraces keep
    # functions, files and lines, and the build takes about 40% less time.
    # The code generated is the same.
    # shellcheck disable=SC2086
    cmake -S "$IMT_ROOT" -B "$IMT_BUILD_DIR" -DCMAKE_BUILD_TYPE="$IMT_BUILD_TYPE" \
      -DCMAKE_CXX_FLAGS_RELWITHDEBINFO="-O2 -g1 -DNDEBUG" \
      -DPYTHON_EXECUTABLE=/usr/bin/python3 ${IMT_CMAKE_ARGS:-} >"$IMT_BUILD_DIR/cmake.log" 2>&1 ||
      { cat "$IMT_BUILD_DIR/cmake.log" >&2; return 1; }
  fi
  imt_log "building: $*"
  # gcc 12 once hit a sporadic internal compiler error on a large ROS .cpp: retry once.
  make -C "$IMT_BUILD_DIR" -j"$(nproc)" --no-print-directory "$@" >"$IMT_BUILD_DIR/build.log" 2>&1 ||
    make -C "$IMT_BUILD_DIR" -j1 --no-print-directory "$@" >"$IMT_BUILD_DIR/build.log" 2>&1 ||
    { tail -n 60 "$IMT_BUILD_DIR/build.log" >&2; imt_log "build failed (full log: $IMT_BUILD_DIR/build.log)"; return 1; }
  imt_source_workspace
}

# imt_tool NAME: the path of this build's tool NAME (make_scene, track_bag).
# Not `rosrun`: it searches the whole package folder and asks which one when
# another build folder inside it (a second _build*) has its own.
imt_tool() { printf '%s/devel/lib/instant_motion_tracking/%s' "$IMT_BUILD_DIR" "$1"; }

# Sources the build's devel/setup.bash. The catkin setup scripts read unset
# variables (ROS_DISTRO): not under set -u.
imt_source_workspace() {
  local had_u=0
  [[ $- == *u* ]] && had_u=1
  set +u
  # shellcheck disable=SC1091
  source "$IMT_BUILD_DIR/devel/setup.bash"
  [ "$had_u" = 1 ] && set -u
  return 0
}

# --- a private ROS master for a live run (demo.sh, soak.sh) -------------------
# imt_start_roscore LOGDIR PIDS_ARRAY: roscore on a free port in its own
# process group (its pid appended to the array named PIDS_ARRAY), logs in
# LOGDIR; sets IMT_CHILD_ENV (an env command line with ROS_MASTER_URI and
# ROS_LOG_DIR for the children) and IMT_MASTER_PORT. Fails when the master
# is not up within 20 s. The port is free when picked, but another socket
# may take it before roscore binds it (the kernel hands ports of the same
# range to outgoing connections; seen once in scripts/test.sh's soak): a
# roscore that exits is started again on another port, three times at most.
imt_start_roscore() {
  local logs=$1
  local -n imt_pids_ref=$2
  local try _ pid
  for try in 1 2 3; do
    IMT_MASTER_PORT=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("localhost", 0)); print(s.getsockname()[1])')
    IMT_CHILD_ENV=(env ROS_MASTER_URI="http://localhost:$IMT_MASTER_PORT" ROS_LOG_DIR="$logs")
    imt_log "roscore on port $IMT_MASTER_PORT (logs: $logs)"
    setsid "${IMT_CHILD_ENV[@]}" roscore -p "$IMT_MASTER_PORT" >>"$logs/roscore.out" 2>&1 &
    pid=$!
    imt_pids_ref+=("$pid")
    for _ in $(seq 100); do
      "${IMT_CHILD_ENV[@]}" /usr/bin/python3 -c 'import rosgraph, sys; sys.exit(not rosgraph.is_master_online())' \
        2>/dev/null && return 0
      if ! kill -0 "$pid" 2>/dev/null; then
        imt_log "roscore exited (try $try of 3): $(tail -n 3 "$logs/roscore.out")"
        continue 2
      fi
      sleep 0.2
    done
    imt_log "roscore did not come up on port $IMT_MASTER_PORT within 20 s (see $logs/roscore.out)"
    return 1
  done
  return 1
}

# imt_stop_group PID: stops a process group: SIGINT (roslaunch and roscore
# shut their nodes down), then SIGTERM, then SIGKILL.
imt_stop_group() {
  local pid=$1 i
  kill -0 "$pid" 2>/dev/null || return 0
  kill -INT -- "-$pid" 2>/dev/null || true
  for i in $(seq 50); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
  kill -TERM -- "-$pid" 2>/dev/null || true
  for i in $(seq 25); do kill -0 "$pid" 2>/dev/null || break; sleep 0.2; done
  kill -KILL -- "-$pid" 2>/dev/null || true
  wait "$pid" 2>/dev/null || true
}

# imt_stop_groups PIDS_ARRAY: stops each group, the last started first, and
# empties the array.
imt_stop_groups() {
  local -n imt_groups_ref=$1
  local i
  for ((i = ${#imt_groups_ref[@]} - 1; i >= 0; i--)); do imt_stop_group "${imt_groups_ref[i]}"; done
  imt_groups_ref=()
}

# imt_prepare true|false CALLER: with true, installs what is missing and
# builds (imt_build all); with false (a --no-build run), uses the build in
# IMT_BUILD_DIR as it is and fails, naming CALLER, when there is none. Either
# way the workspace is sourced.
imt_prepare() {
  local build=$1 caller=$2
  imt_env
  if [ "$build" = true ]; then
    imt_install
    imt_build all
    return
  fi
  [ -f "$IMT_BUILD_DIR/devel/setup.bash" ] ||
    { echo "$caller: --no-build: no build in $IMT_BUILD_DIR (set IMT_BUILD_DIR)" >&2; return 2; }
  imt_source_workspace
}
