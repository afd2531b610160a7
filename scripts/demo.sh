#!/usr/bin/env bash
# Sets up (apt-get what is missing, build in _build/) and runs the demo on a
# bundled default: a seeded synthetic scene ("cards": a textured wall, moving
# cards, a static textured patch, a featureless patch; camera motion; IMU) is
# rendered into a rosbag with make_scene, then
#  1. track_bag runs the whole pipeline on it offline and the CSVs are scored
#     against the scene's ground truth (scripts/evaluate.py);
#  2. the live graph runs on it: roscore on a free port, launch/replay.launch
#     (every nodelet, rosbag play on sim time), regions, a planar target and an
#     anchor added through the services, the outputs recorded and scored by
#     scripts/demo_live.py into OUT/live/ (report.txt, strip.png, debug_image.mp4).
# Options: --preset NAME (default cards), --duration S (default 10), --out DIR (default demo_output),
#   --rate R (playback rate, default 1), --rviz (also open rviz; needs a display),
#   --live-only / --offline-only (one part only), --no-build (use the build in IMT_BUILD_DIR as is).
# Exits non-zero with a message naming the failed step; every process it started is stopped on exit.
set -euo pipefail
preset=cards duration=10 out="" rate=1.0 rviz=false live=true offline=true build=true
while [ $# -gt 0 ]; do
  case "$1" in
    --preset) preset=$2; shift 2 ;;
    --duration) duration=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --rate) rate=$2; shift 2 ;;
    --rviz) rviz=true; shift ;;
    --live-only) offline=false; shift ;;
    --offline-only) live=false; shift ;;
    --no-build) build=false; shift ;;
    -h|--help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "demo.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
if [ "$rviz" = true ] && [ -z "${DISPLAY:-}" ]; then
  echo "demo.sh: --rviz needs a display (DISPLAY is not set); run without --rviz, or under xvfb-run" >&2
  exit 2
fi
source "$(dirname "$0")/setup.sh"
imt_prepare "$build" demo.sh || exit 2
out=${out:-$IMT_ROOT/demo_output}
mkdir -p "$out"
out=$(cd "$out" && pwd)  # roslaunch needs an absolute bag path

fail() { echo "demo.sh: $*" >&2; exit 1; }

imt_log "rendering the '$preset' scene ($duration s) into $out/$preset.bag"
"$(imt_tool make_scene)" --preset "$preset" --duration "$duration" --seed 1 --quiet \
  --out "$out/$preset.bag" --truth "$out/${preset}_truth.json" --init "$out/${preset}_init.yaml" ||
  fail "make_scene failed"

if [ "$offline" = true ]; then
  imt_log "running track_bag on it (offline, scored)"
  "$(imt_tool track_bag)" --bag "$out/$preset.bag" --init "$out/${preset}_init.yaml" \
    --out-dir "$out/tracks" --out-bag "$out/${preset}_tracked.bag" --quiet || fail "track_bag failed"
  echo
  echo "Offline (track_bag) accuracy against the scene's ground truth (scripts/evaluate.py):"
  /usr/bin/python3 "$IMT_ROOT/scripts/evaluate.py" "$out/${preset}_truth.json" "$out/tracks" | sed 's/^/  /'
  echo
fi

# --- the live graph ------------------------------------------------------------
# The master and the launch run in their own process groups (setsid), with
# ROS_MASTER_URI set for them only; cleanup stops each group: SIGINT (roslaunch
# and roscore shut their nodes down), then SIGTERM, then SIGKILL.
pids=() live_pid=""
cleanup() {
  local i
  if [ -n "$live_pid" ] && kill -0 "$live_pid" 2>/dev/null; then
    kill -TERM "$live_pid" 2>/dev/null || true
    wait "$live_pid" 2>/dev/null || true
  fi
  live_pid=""
  imt_stop_groups pids
}
trap cleanup EXIT
trap 'exit 130' INT
trap 'exit 143' TERM

if [ "$live" = true ]; then
  live_dir=$out/live
  rm -rf "$live_dir"
  mkdir -p "$live_dir/logs"
  imt_start_roscore "$live_dir/logs" pids || fail "the live graph's roscore did not start"
  child_env=("${IMT_CHILD_ENV[@]}")

  imt_log "live graph: roslaunch replay.launch (paused; rviz:=$rviz, rate $rate)"
  setsid "${child_env[@]}" roslaunch instant_motion_tracking replay.launch bag:="$out/$preset.bag" \
    rviz:="$rviz" paused:=true delay:=0 rate:="$rate" >"$live_dir/logs/roslaunch.out" 2>&1 &
  pids+=($!)

  imt_log "live graph: adding the items through the services and recording the outputs"
  # In the background so that a signal to this script is handled at once (wait is interruptible).
  "${child_env[@]}" /usr/bin/python3 "$IMT_ROOT/scripts/demo_live.py" --truth "$out/${preset}_truth.json" \
    --init "$out/${preset}_init.yaml" --out "$live_dir" --rate "$rate" &
  live_pid=$!
  status=0
  wait "$live_pid" || status=$?
  live_pid=""
  if [ "$status" -ne 0 ]; then
    kill -0 "${pids[1]}" 2>/dev/null || echo "demo.sh: roslaunch exited early:" >&2
    tail -n 15 "$live_dir/logs/roslaunch.out" | sed 's/^/  roslaunch: /' >&2
    fail "the live part failed (exit $status; logs in $live_dir/logs)"
  fi
  if [ "$rviz" = true ] && [ -t 0 ]; then
    read -r -p "rviz is open on the last frame; press Enter to stop the graph " _ || true
  fi
  cleanup
fi

echo
echo "Results in $out:"
echo "  input bag:        $out/$preset.bag (ground truth: $out/${preset}_truth.json)"
echo "  what was tracked: $out/${preset}_init.yaml"
if [ "$offline" = true ]; then
  echo "  offline CSVs:     $out/tracks/ ($(ls "$out/tracks" | tr '\n' ' '))"
  echo "  offline outputs:  $out/${preset}_tracked.bag"
fi
if [ "$live" = true ]; then
  echo "  live graph:       $out/live/report.txt, strip.png, $(cd "$out/live" && ls debug_image.* 2>/dev/null | head -1), CSVs"
fi
