#!/usr/bin/env bash
# Soak test of the live graph: a rendered cards bag (15 s) plays in a loop
# into launch/replay.launch (every nodelet in one manager, graph_watchdog)
# at twice its rate, while busy loops keep every core loaded, for MINUTES
# minutes. scripts/soak_monitor.py adds the scene's items (again after each
# loop), prints a line per minute (frames in, messages out per output, the
# manager's RSS, processing time mean/max, resets, graph_watchdog's verdict)
# and fails the run when an output stops, the manager's RSS (each minute's
# median) is more than 20% over the second minute's at the end and still
# rising (a minute over it runs on a minute more, twice at most: a stall's
# queues empty, an allocator's plateau stays flat, a leak goes on rising),
# or a nodelet is unloaded.
#   scripts/soak.sh MINUTES [--rate R] [--load N] [--out DIR] [--no-build] [--launch-arg NAME:=VALUE ...]
# --load N: busy loops (default: one per core; 0 = none). --launch-arg goes to
# replay.launch (e.g. bond_heartbeat_disabled:=false, ROS's bond default).
# Exits non-zero on a failed run, naming the reason; logs in OUT/logs.
set -euo pipefail
minutes="" rate=2.0 load="" out="" build=true launch_args=()
while [ $# -gt 0 ]; do
  case "$1" in
    --rate) rate=$2; shift 2 ;;
    --load) load=$2; shift 2 ;;
    --out) out=$2; shift 2 ;;
    --no-build) build=false; shift ;;
    --launch-arg) launch_args+=("$2"); shift 2 ;;
    -h|--help) sed -n '2,15p' "$0"; exit 0 ;;
    -*) echo "soak.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) [ -z "$minutes" ] || { echo "soak.sh: one MINUTES only" >&2; exit 2; }; minutes=$1; shift ;;
  esac
done
[[ "$minutes" =~ ^[0-9]+$ ]] && [ "$minutes" -ge 1 ] ||
  { echo "soak.sh: give the minutes to run, a whole number >= 1 (see --help)" >&2; exit 2; }
source "$(dirname "$0")/setup.sh"
imt_prepare "$build" soak.sh || exit 2
load=${load:-$(nproc)}
out=${out:-$IMT_BUILD_DIR/soak}
rm -rf "$out"
mkdir -p "$out/logs"
out=$(cd "$out" && pwd)
fail() { echo "soak.sh: $*" >&2; exit 1; }

imt_log "rendering the cards scene (15 s) into $out/cards.bag"
"$(imt_tool make_scene)" --preset cards --duration 15 --seed 1 --quiet \
  --out "$out/cards.bag" --truth "$out/cards_truth.json" --init "$out/cards_init.yaml" ||
  fail "make_scene failed"

pids=() busy=()
trap 'imt_stop_all' EXIT
trap 'exit 130' INT
trap 'exit 143' TERM
imt_stop_all() {
  local p
  for p in "${busy[@]}"; do kill "$p" 2>/dev/null || true; done
  busy=()
  imt_stop_groups pids
}

imt_start_roscore "$out/logs" pids || fail "roscore did not start (see $out/logs/roscore.out)"
imt_log "roslaunch replay.launch (loop, rate $rate) ${launch_args[*]:-}"
setsid "${IMT_CHILD_ENV[@]}" roslaunch instant_motion_tracking replay.launch bag:="$out/cards.bag" \
  rviz:=false loop:=true rate:="$rate" "${launch_args[@]}" >"$out/logs/roslaunch.out" 2>&1 &
pids+=($!)
# This run's manager: the one talking to this run's master, not another graph's.
own_manager() {
  local p
  for p in $(pgrep -f "__name:=imt_manager" || true); do
    tr '\0' '\n' <"/proc/$p/environ" 2>/dev/null |
      grep -qx "ROS_MASTER_URI=http://localhost:$IMT_MASTER_PORT" && { echo "$p"; return 0; }
  done
  return 0
}
manager_pid=""
for _ in $(seq 150); do
  manager_pid=$(own_manager)
  [ -n "$manager_pid" ] && break
  sleep 0.2
done
[ -n "$manager_pid" ] || fail "the nodelet manager did not start (see $out/logs/roslaunch.out)"

imt_log "$load busy loops on $(nproc) cores; monitoring for $minutes minutes"
for _ in $(seq "$load"); do
  (trap - EXIT; while :; do :; done) &
  busy+=($!)
done
status=0
"${IMT_CHILD_ENV[@]}" /usr/bin/python3 "$IMT_ROOT/scripts/soak_monitor.py" --minutes "$minutes" \
  --truth "$out/cards_truth.json" --init "$out/cards_init.yaml" --manager-pid "$manager_pid" || status=$?
if grep -q "Bond broken" "$out/logs/roslaunch.out"; then
  echo "soak.sh: roslaunch logged 'Bond broken': a nodelet was unloaded" >&2
  grep -m 5 "Bond broken\|process has died\|process has finished" "$out/logs/roslaunch.out" >&2 || true
  status=1
fi
[ "$status" -eq 0 ] || fail "the soak failed (logs in $out/logs)"
