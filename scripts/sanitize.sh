#!/usr/bin/env bash
# The core, io and sim libraries built with AddressSanitizer and UBSan (CMake
# option IMT_SANITIZE, in _build_sanitize/, git-ignored) and their tests run
# on them (the tests' own code is not instrumented: CMake's imt_unsanitized):
# any sanitizer report, or a failing test, fails the run.
#   scripts/sanitize.sh [--all] [--with-tools] [gtest filter]
# By default the quick tests: every test_io test, and the test_core tests
# that take under about 2 s in the normal build (the rendered walks, the
# failure-class scenes and the real sequences run 4x slower here and are left
# out: --all runs them too, about 15 min on 2 cores). A gtest filter given
# replaces the default one. --with-tools also builds track_bag and make_scene
# in the same make goal (for scripts/fuzz.sh next: scripts/test.sh; about
# 1.4 min less on 2 cores than building them after). Exits 0 when clean.
set -euo pipefail
all=false filter="" targets="test_core test_io"
while [ $# -gt 0 ]; do
  case "$1" in
    --all) all=true; shift ;;
    --with-tools) targets=imt_sanitized_tests_and_tools; shift ;;
    -h|--help) sed -n '2,13p' "$0"; exit 0 ;;
    -*) echo "sanitize.sh: unknown option '$1' (see --help)" >&2; exit 2 ;;
    *) filter=$1; shift ;;
  esac
done
# The slow ones (each over ~2 s in the normal build, 2026-11-24).
slow="AnchorManager.FloorWalk*:AnchorManager.TfTheVideo*:AnchorManager.OutOfView*:AnchorManager.AnchorOnAMovingCard*"
slow+=":AnchorManager.AnchorOnTheWall*"
slow+=":RegionFailureClass.*:CameraModelScenes.*:PosterOccluded.*:PosterOutOfView.*:PosterOrbit.*"
slow+=":CardsSceneFewFeatures.*:TrackingSession.LiveAndOfflineAgreeOnCards:*RegionReal*"
if [ -z "$filter" ]; then
  if $all; then filter="*"; else filter="-$slow"; fi
fi

IMT_SANITIZE=1 source "$(dirname "$0")/setup.sh"
imt_install
imt_env
# (imt_sanitized_tests_and_tools: CMakeLists.txt, one goal for all four.)
# shellcheck disable=SC2086
imt_build $targets

# Any report ends the binary with an error (UBSan only prints by default).
export ASAN_OPTIONS=${ASAN_OPTIONS:-detect_leaks=1:abort_on_error=0:halt_on_error=1}
export UBSAN_OPTIONS=${UBSAN_OPTIONS:-halt_on_error=1:print_stacktrace=1}
status=0
# run_sanitized BINARY LOG [gtest shard index]: one run, its verdict logged.
# test_core's tests run in two shards at once (one per core: they are
# single-threaded, and this stage is on the critical path of scripts/test.sh).
run_sanitized() {
  if [ $# -gt 2 ]; then export GTEST_TOTAL_SHARDS=2 GTEST_SHARD_INDEX=$3; fi
  imt_run_checked "$1" "$filter" "$2" "ASan/UBSan" "ERROR: AddressSanitizer|ERROR: LeakSanitizer|runtime error"
}
imt_log "running test_io, then test_core in two shards, under ASan/UBSan (filter: $filter)"
run_sanitized test_io "$IMT_BUILD_DIR/test_io.log" || status=1
run_sanitized test_core "$IMT_BUILD_DIR/test_core.0.log" 0 &
shard0=$!
run_sanitized test_core "$IMT_BUILD_DIR/test_core.1.log" 1 || status=1
wait "$shard0" || status=1
exit $status
