#!/usr/bin/env bash
# The package's libraries built with ThreadSanitizer (CMake option IMT_TSAN,
# in _build_tsan/, git-ignored), and the tests of what runs on several
# threads run on them: the test_core tests that step regions side by side,
# OpenCV's parallel loops on plain std::threads (test/core/std_thread_backend.h:
# Debian's OpenCV runs them on TBB, which TSan does not see), and test_ros's
# SessionHub tests (the nodelets' shared session, used from several threads).
# Any TSan report, or a failing test, fails the run. Not part of
# scripts/test.sh (a third build of the libraries: 5.5 min in all from
# nothing on 2 cores, 2.2 min again; docs/benchmarks.md): run it after
# changing what runs in parallel.
#   scripts/tsan.sh [test_core's gtest filter]
set -euo pipefail
filter="StdThreadBackend.*:RegionManager.*:TrackingSession.*:RegionAppearance.*"
# (A gtest filter may start with one '-': the tests it leaves out.)
case "${1:-}" in
  -h|--help) sed -n '2,11p' "$0"; exit 0 ;;
  --*) echo "tsan.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
  ?*) filter=$1 ;;
esac

IMT_TSAN=1 source "$(dirname "$0")/setup.sh"
imt_install
imt_env
imt_build test_core test_ros

# Any report ends the binary with an error; scripts/tsan.supp leaves out
# reports inside other packages' libraries.
export TSAN_OPTIONS=${TSAN_OPTIONS:-halt_on_error=1:second_deadlock_stack=1:suppressions=$IMT_ROOT/scripts/tsan.supp}
status=0
# run_tsan BINARY FILTER: one run, its verdict logged.
run_tsan() { imt_run_checked "$1" "$2" "$IMT_BUILD_DIR/$1.tsan.log" ThreadSanitizer "WARNING: ThreadSanitizer"; }
imt_log "running test_core under ThreadSanitizer, OpenCV's loops on std::threads (filter: $filter)"
IMT_TEST_STD_THREADS=3 run_tsan test_core "$filter" || status=1
# Not the tests that run track_bag: its OpenCV loops run on TBB.
imt_log "running test_ros's SessionHub tests under ThreadSanitizer"
run_tsan test_ros "SessionHub.*" || status=1
exit $status
