#!/usr/bin/env bash
# The core and sim libraries built with ThreadSanitizer (CMake option
# IMT_TSAN, in _build_tsan/, git-ignored) and the test_core tests that step
# regions side by side run on them, OpenCV's parallel loops on plain
# std::threads (test/core/std_thread_backend.h: Debian's OpenCV runs them on
# TBB, which TSan does not see). Any TSan report, or a failing test, fails
# the run. Not part of scripts/test.sh (a third build of the libraries:
# about 2.5 min on 2 cores, and the tests 2.5 min; docs/benchmarks.md): run it
# after changing what runs in parallel.
#   scripts/tsan.sh [gtest filter]
set -euo pipefail
filter="StdThreadBackend.*:RegionManager.*:TrackingSession.*:RegionAppearance.*"
case "${1:-}" in
  -h|--help) sed -n '2,10p' "$0"; exit 0 ;;
  -*) echo "tsan.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  ?*) filter=$1 ;;
esac

IMT_TSAN=1 source "$(dirname "$0")/setup.sh"
imt_install
imt_env
imt_build test_core

# Any report ends the binary with an error; scripts/tsan.supp leaves out
# reports inside other packages' libraries.
export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$IMT_ROOT/scripts/tsan.supp}
export IMT_TEST_STD_THREADS=3
bin="$IMT_BUILD_DIR/devel/lib/instant_motion_tracking"
log="$IMT_BUILD_DIR/test_core.tsan.log"
imt_log "running test_core under ThreadSanitizer, OpenCV's loops on std::threads (filter: $filter)"
if ! "$bin/test_core" --gtest_filter="$filter" >"$log" 2>&1; then
  imt_log "test_core failed under ThreadSanitizer (${log##*/}):"
  grep -E -A40 "WARNING: ThreadSanitizer|\[  FAILED  \]" "$log" | head -120 >&2 || tail -40 "$log" >&2
  exit 1
fi
imt_log "test_core clean under ThreadSanitizer: $(grep -E '^\[  PASSED  \]' "$log" || echo '?')"
