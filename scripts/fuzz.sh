#!/usr/bin/env bash
# track_bag on mutated bags and INIT files, built with AddressSanitizer and
# UBSan (the build of scripts/sanitize.sh, _build_sanitize/): issue 16's
# fuzzing. Any sanitizer report, crash or hang (over the timeout per case)
# fails the run; exit status 0 (done), 1 (bad input, named in one line) and 2
# (bad options) are track_bag's answers and count as handled.
#   scripts/fuzz.sh [CASES] [--seed N] [--timeout S]
# CASES (default 500) mutants of three seed scenes (make_scene: raw mono8
# with IMU and anchors; bgr8 with regions; JPEG with a planar target), made
# by scripts/fuzz_mutate.py (seeded: the same arguments give the same
# mutants). Prints a count per outcome and per mutation kind; cases that
# failed are kept in _build_sanitize/fuzz/failed/ with their output and the
# line of manifest.tsv that says what was mutated.
set -euo pipefail
cases=500 seed=1 timeout_s=60
while [ $# -gt 0 ]; do
  case "$1" in
    --seed) seed=$2; shift 2 ;;
    --timeout) timeout_s=$2; shift 2 ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    -*) echo "fuzz.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) cases=$1; shift ;;
  esac
done

IMT_SANITIZE=1 source "$(dirname "$0")/setup.sh"
imt_install
imt_env
imt_build track_bag make_scene

bin="$IMT_BUILD_DIR/devel/lib/instant_motion_tracking"
# A track_bag without the sanitizers would pass every case unseen. (The
# sanitizer build names its tools *_sanitized: see CMakeLists.txt.)
# (ldd's whole output first: under pipefail, 'ldd | grep -q' fails whenever
# grep stops reading before ldd has written its last line, SIGPIPE.)
libs=$(ldd "$bin/track_bag_sanitized")
grep -q libasan <<<"$libs" || { imt_log "$bin/track_bag_sanitized is not built with ASan"; exit 1; }
work="$IMT_BUILD_DIR/fuzz"
rm -rf "$work"
mkdir -p "$work/seeds" "$work/failed"
# ASan's and UBSan's own exit status (86), distinct from track_bag's 0-2; leaks
# are not looked for here (ROS's own singletons would be reported at exit).
export ASAN_OPTIONS=detect_leaks=0:halt_on_error=1:exitcode=86
export UBSAN_OPTIONS=halt_on_error=1:print_stacktrace=1:exitcode=86

imt_log "making the seeds"
scene() { "$bin/make_scene_sanitized" --duration 1 --fps 10 --width 160 --height 120 --quiet "$@"; }
scene --preset floor_walk --out "$work/seeds/mono8.bag" --init "$work/seeds/mono8.yaml"
scene --preset cards --encoding bgr8 --out "$work/seeds/bgr8.bag" --init "$work/seeds/bgr8.yaml"
scene --preset poster_orbit --compressed jpeg --out "$work/seeds/jpeg.bag" --init "$work/seeds/jpeg.yaml"

imt_log "making $cases mutants (seed $seed)"
/usr/bin/python3 "$IMT_ROOT/scripts/fuzz_mutate.py" --seeds "$work/seeds" --out "$work/cases" --cases "$cases" \
  --seed "$seed"

# One case: its outcome on stdout ("ok <status>" or "FAILED <why>"); its
# files are removed when it passed.
run_case() {
  local base=$1 status=0
  timeout -k 5 "$timeout_s" "$bin/track_bag_sanitized" --bag "$base.bag" --init "$base.yaml" --out-dir "$base.out" \
    --config "$IMT_ROOT/config/default.yaml" --quiet >"$base.log" 2>&1 || status=$?
  local why=""
  if grep -qE "ERROR: AddressSanitizer|runtime error:|ERROR: LeakSanitizer" "$base.log"; then why="sanitizer report"
  elif [ "$status" -eq 124 ] || [ "$status" -eq 137 ]; then why="hang (over ${timeout_s} s)"
  elif [ "$status" -gt 2 ]; then why="crash (exit $status)"
  fi
  if [ -n "$why" ]; then
    echo "FAILED $(basename "$base") $why"
  else
    echo "ok $status"
    rm -rf "$base.bag" "$base.yaml" "$base.out" "$base.log"
  fi
}
export -f run_case
export bin timeout_s IMT_ROOT

imt_log "running track_bag on each ($(nproc) at a time, ${timeout_s} s each at most)"
start=$(date +%s)
find "$work/cases" -name 'case_*.bag' | sort | sed 's/\.bag$//' |
  xargs -P "$(nproc)" -I{} bash -c 'run_case {}' >"$work/outcomes.txt"
elapsed=$(( $(date +%s) - start ))

failed=$(grep -c '^FAILED' "$work/outcomes.txt" || true)
{ grep '^FAILED' "$work/outcomes.txt" || true; } | while read -r _ name why; do
  mv "$work/cases/$name".* "$work/failed/" 2>/dev/null || true
  grep "^$name	" "$work/cases/manifest.tsv" >>"$work/failed/manifest.tsv" || true
  imt_log "FAILED $name: $why ($(grep "^$name	" "$work/cases/manifest.tsv" | cut -f2-))"
done
/usr/bin/python3 - "$work/outcomes.txt" "$work/cases/manifest.tsv" <<'PY'
import collections, sys
outcomes = [l.split() for l in open(sys.argv[1]) if l.strip()]
by = collections.Counter("exit %s" % o[1] if o[0] == "ok" else "FAILED" for o in outcomes)
print("outcomes:", ", ".join(f"{k}: {v}" for k, v in sorted(by.items())))
kinds = collections.Counter(line.split("\t")[2] for line in open(sys.argv[2]) if line.strip())
print("mutated:", ", ".join(f"{k}: {v}" for k, v in sorted(kinds.items())))
PY
imt_log "$(wc -l <"$work/outcomes.txt") cases in ${elapsed} s, $failed failed"
[ "$failed" -eq 0 ]
