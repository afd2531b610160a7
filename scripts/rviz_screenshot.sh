#!/usr/bin/env bash
# Renders a screenshot of rviz (rviz/instant_motion_tracking.rviz) on the live
# graph, headless under Xvfb: a generated `cards` bag is replayed
# (launch/replay.launch, sim time), regions, a planar target and an anchor are added
# through the services, and the screen is saved (default doc/rviz.png).
# Needs the Debian packages rviz, xvfb, xauth and imagemagick (installed if
# missing; not needed by the tests or CI).
# Options: --out FILE (default doc/rviz.png), --width PX of the saved image (default 1024).
set -euo pipefail
out="" width=1024
while [ $# -gt 0 ]; do
  case "$1" in
    --out) out=$2; shift 2 ;;
    --width) width=$2; shift 2 ;;
    --inside-xvfb) inside=1; shift ;;
    -h|--help) sed -n '2,8p' "$0"; exit 0 ;;
    *) echo "rviz_screenshot.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  esac
done
source "$(dirname "$0")/setup.sh"

if [ -z "${inside:-}" ]; then
  IMT_PACKAGES+=(rviz xvfb xauth imagemagick)
  imt_install
  imt_env
  imt_build all
  out=${out:-$IMT_ROOT/doc/rviz.png}
  mkdir -p "$(dirname "$out")"
  IMT_SHOT_WORK=$(mktemp -d /tmp/imt_rviz_XXXXXX)
  export IMT_SHOT_WORK
  trap 'rm -rf "$IMT_SHOT_WORK"' EXIT
  imt_log "rendering the cards scene"
  "$(imt_tool make_scene)" --preset cards --duration 20 --seed 1 --quiet \
    --out "$IMT_SHOT_WORK/cards.bag" --truth "$IMT_SHOT_WORK/truth.json"
  imt_log "rviz under Xvfb (1280x800)"
  xvfb-run -a -s "-screen 0 1280x800x24" "$0" --inside-xvfb --out "$IMT_SHOT_WORK/screen.png"
  convert "$IMT_SHOT_WORK/screen.png" -resize "${width}x" -colors 256 -strip "PNG8:$out"
  imt_log "wrote $out ($(du -h "$out" | cut -f1))"
  exit 0
fi

# --- inside Xvfb: a master on a free port, the graph, rviz, services, the shot
imt_env
set +u
# shellcheck disable=SC1091
source "$IMT_BUILD_DIR/devel/setup.bash"
set -u
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')
export ROS_MASTER_URI=http://localhost:$port
roslaunch -p "$port" instant_motion_tracking replay.launch bag:="$IMT_SHOT_WORK/cards.bag" rviz:=true \
  paused:=true delay:=0 >"$IMT_SHOT_WORK/roslaunch.log" 2>&1 &
launch_pid=$!
trap 'kill -INT $launch_pid 2>/dev/null; wait $launch_pid 2>/dev/null || true' EXIT
for _ in $(seq 60); do
  rosservice list 2>/dev/null | grep -q /player/pause_playback && rosservice list | grep -q /add_planar_target && break
  sleep 1
done
sleep 8  # rviz starts (llvmpipe) and subscribes
rosservice call /player/pause_playback false >/dev/null
sleep 1.5
# Cards 2 and 3 as regions, the static patch 4 as a planar target and a wall
# point as an anchor, given at frame 10.
/usr/bin/python3 - "$IMT_SHOT_WORK/truth.json" >"$IMT_SHOT_WORK/calls.txt" <<'PY'
import json, sys
f = json.load(open(sys.argv[1]))["frames"][10]
secs, nsecs = int(f["stamp"]), round((f["stamp"] % 1) * 1e9)
stamp = "stamp: {secs: %d, nsecs: %d}" % (secs, nsecs)
boxes = {r["id"]: r["box"] for r in f["regions"]}
for rid in (2, 3):
    x, y, w, h = boxes[rid]
    print("/add_region {%s, id: %d, x: %.2f, y: %.2f, width: %.2f, height: %.2f}" % (stamp, rid, x, y, w, h))
x, y, w, h = boxes[4]
corners = ", ".join("{x: %.2f, y: %.2f}" % c for c in [(x, y), (x + w, y), (x + w, y + h), (x, y + h)])
print("/add_planar_target {%s, id: 1, corners: [%s], width_m: 0.5, height_m: 0.4}" % (stamp, corners))
# An anchor on the wall: the grid point farthest from every card at frame 10.
def clearance(u, v):
    return min(max(bx - u, 0, u - bx - bw, by - v, 0, v - by - bh) for bx, by, bw, bh in boxes.values())
u, v = max(((u, v) for u in range(80, 561, 20) for v in range(80, 401, 20)), key=lambda p: clearance(*p))
print("/add_anchor {%s, id: 1, u: %d, v: %d, depth: 2.0}" % (stamp, u, v))
PY
while read -r service args; do
  rosservice call "$service" "$args" | tr '\n' ' ' >&2
  echo >&2
done <"$IMT_SHOT_WORK/calls.txt"
sleep 3
import -window root "$out"
