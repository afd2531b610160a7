#!/usr/bin/env bash
# Sets up (apt-get what is missing, build in _build/) and runs every test:
# core/io/ROS gtests and the rostests. Prints a closing count line
# "N passed, N failed, N skipped" and exits non-zero on any failure.
# Extra arguments go to ctest (e.g. -R rostest, --output-on-failure is always on);
# without them, the quick core/io tests under ASan and UBSan run next
# (scripts/sanitize.sh; IMT_SANITIZE_TESTS=0 to skip), then track_bag under
# them on 300 mutated bags and INIT files (scripts/fuzz.sh; IMT_FUZZ_CASES=N
# to change, 0 to skip), with a 3-minute soak of the live graph under load
# beside them (scripts/soak.sh; IMT_SOAK_MINUTES=N to change, 0 to skip; last,
# under busy loops, when the sanitizer stage is skipped).
set -euo pipefail
source "$(dirname "$0")/setup.sh"
# Each stage's wall time, to see where the ~30 minutes go.
stage_start=$SECONDS
stage_done() { echo "[imt] $1: $((SECONDS - stage_start)) s"; stage_start=$SECONDS; }
imt_install
imt_env
stage_done "set-up"
imt_build all tests
stage_done "build"

results="$IMT_BUILD_DIR/test_results"
rm -rf "$results"
status=0
(cd "$IMT_BUILD_DIR" && ctest --output-on-failure -j"$(nproc)" "$@") || status=$?
stage_done "ctest"

# One more test case in the JUnit results: junit_case SUITE NAME STATUS MESSAGE
# (STATUS 0 passes; else MESSAGE is the failure's).
junit_case() {
  mkdir -p "$results/$1"
  /usr/bin/python3 - "$results/$1/$1.xml" "$@" <<'PY'
import sys
from xml.sax.saxutils import escape, quoteattr
path, suite, name, status, message = sys.argv[1:6]
failure = "" if status == "0" else "<failure message=%s/>" % quoteattr(message)
with open(path, "w") as f:
    f.write('<testsuite name="%s" tests="1"><testcase classname="%s" name="%s">%s</testcase></testsuite>\n'
            % (escape(suite), escape(suite), escape(name), failure))
PY
}

# The live graph under load for 3 minutes (scripts/soak.sh); its verdict is
# one more test case. IMT_SOAK_MINUTES=0 skips it (as do extra ctest
# arguments: a partial run). It runs after the ctest tests (its load would
# slow the rostests), beside the sanitizer stage when that runs: the
# sanitizer build and tests keep both cores busy, and are the soak's load in
# place of its busy loops (1.8 min less than one after the other, 2026-12-07).
soak_minutes=${IMT_SOAK_MINUTES:-3}
soak_pid=""
soak_status=0
run_soak() {  # run_soak BUSY_LOOPS: the soak, its log in soak.log
  "$IMT_ROOT/scripts/soak.sh" "$soak_minutes" --no-build --load "$1" --out "$IMT_BUILD_DIR/soak" \
    >"$IMT_BUILD_DIR/soak.log" 2>&1
}
soak_done() {
  cat "$IMT_BUILD_DIR/soak.log"
  junit_case soak "LiveGraphUnderLoad${soak_minutes}Minutes" "$soak_status" \
    "scripts/soak.sh $soak_minutes failed (exit $soak_status); see soak.log"
  [ "$soak_status" -eq 0 ] || status=1
}
soak_wanted=false
[ $# -eq 0 ] && [ "$soak_minutes" -gt 0 ] && soak_wanted=true

# The core and io tests under AddressSanitizer and UBSan (scripts/sanitize.sh,
# the quick ones; a build of its own in _build_sanitize/), then track_bag in
# that build on mutated bags and INIT files (scripts/fuzz.sh), a test case
# each. IMT_SANITIZE_TESTS=0 skips both, IMT_FUZZ_CASES=0 the second (as do
# extra ctest arguments).
if [ $# -eq 0 ] && [ "${IMT_SANITIZE_TESTS:-1}" != 0 ]; then
  if $soak_wanted; then
    soak_start=$SECONDS
    run_soak 0 &
    soak_pid=$!
  fi
  # 300 cases: all four kinds of mutation about 75 times each, in a ~30-minute
  # budget for the whole of test.sh on 2 cores (scripts/fuzz.sh alone: 500).
  fuzz_cases=${IMT_FUZZ_CASES:-300}
  sanitize_status=0
  # --with-tools: fuzz.sh's track_bag and make_scene built in the same goal
  # (when it runs).
  with_tools=()
  [ "$fuzz_cases" -gt 0 ] && with_tools=(--with-tools)
  "$IMT_ROOT/scripts/sanitize.sh" "${with_tools[@]}" >"$IMT_BUILD_DIR/sanitize.log" 2>&1 || sanitize_status=$?
  cat "$IMT_BUILD_DIR/sanitize.log"
  stage_done "sanitizers (build and tests)"
  junit_case sanitize CoreAndIoTestsUnderAsanAndUbsan "$sanitize_status" \
    "scripts/sanitize.sh failed (exit $sanitize_status); see sanitize.log"
  [ "$sanitize_status" -eq 0 ] || status=1
  if [ "$fuzz_cases" -gt 0 ]; then
    fuzz_status=0
    "$IMT_ROOT/scripts/fuzz.sh" "$fuzz_cases" >"$IMT_BUILD_DIR/fuzz.log" 2>&1 || fuzz_status=$?
    cat "$IMT_BUILD_DIR/fuzz.log"
    stage_done "fuzz"
    junit_case fuzz "TrackBagOn${fuzz_cases}MutatedBagsAndInitFiles" "$fuzz_status" \
      "scripts/fuzz.sh $fuzz_cases failed (exit $fuzz_status); see fuzz.log"
    [ "$fuzz_status" -eq 0 ] || status=1
  fi
fi

if [ -n "$soak_pid" ]; then
  # Beside the sanitizer stage: it has most likely ended by now.
  wait "$soak_pid" || soak_status=$?
  echo "[imt] soak (beside the sanitizer stage, which was its load): $((SECONDS - soak_start)) s, of which $((SECONDS - stage_start)) s after it"
  stage_start=$SECONDS
  soak_done
elif $soak_wanted; then
  # Alone: one busy loop per core is its load.
  run_soak "$(nproc)" || soak_status=$?
  stage_done "soak"
  soak_done
fi

# Count test cases from the JUnit XML that gtest and rostest write (ctest
# counts whole binaries). A binary that crashed before writing XML still
# fails through ctest's status.
/usr/bin/python3 - "$results" "$status" <<'PY'
import glob, os, sys
import xml.etree.ElementTree as ET
root, status = sys.argv[1], int(sys.argv[2])
passed = failed = skipped = 0
for path in glob.glob(os.path.join(root, "**", "*.xml"), recursive=True):
    try:
        tree = ET.parse(path)
    except ET.ParseError:
        failed += 1
        print(f"unreadable result file: {path}")
        continue
    for case in tree.iter("testcase"):
        if case.find("failure") is not None or case.find("error") is not None:
            failed += 1
        elif case.find("skipped") is not None or case.get("status") == "notrun" or case.get("result") == "skipped":
            skipped += 1
        else:
            passed += 1
if status != 0 and failed == 0:
    failed = 1  # ctest failed without a failing case in the XML (a crash, a timeout)
print(f"{passed} passed, {failed} failed, {skipped} skipped")
PY
exit $status
