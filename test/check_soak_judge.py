#!/usr/bin/python3
"""The soak's memory verdict (scripts/soak_monitor.py's MemoryJudge) on the
minutes' medians of runs met in CI and of made-up leaks: a plateau and a
stall pass, a leak fails. No master, no graph.

usage: check_soak_judge.py REPO_ROOT
Prints one line per problem and exits 1 on any; JUnit XML (a case per run)
goes to $IMT_TEST_RESULTS if set.
"""
import os
import sys

from junit_xml import write_suite

sys.path.insert(0, os.path.join(sys.argv[1], "scripts"))
from soak_monitor import MemoryJudge  # noqa: E402


def run(minutes, medians):
    """Feeds the medians as the monitor does (a minute more when asked, while
    there are medians); returns (minutes run, failure, remark)."""
    judge, run_for = MemoryJudge(minutes), 0
    for minute, rss in enumerate(medians, start=1):
        if minute > judge.planned:
            break
        run_for = minute
        judge.add(minute, rss)
    failure, remark = judge.verdict()
    return run_for, failure, remark


CASES = [
    # (name, minutes asked, medians, minutes it should run, fails)
    ("steady", 3, [190.0, 195.0, 200.0], 3, False),
    # CI, 3a7c32a (2026-12-02): three minutes over minute 2's median, flat,
    # the graph keeping pace; back under in the fifth.
    ("CI plateau, back under", 3, [189.5, 195.4, 258.3, 258.0, 217.8], 5, False),
    # The same plateau lasting all three minutes: not rising, not a leak.
    ("plateau kept", 3, [189.5, 195.4, 258.3, 258.0, 259.0], 5, False),
    # A stall in the last minute, its queues empty in the next.
    ("stall", 3, [200.0, 201.6, 257.8, 210.0], 4, False),
    # A leak of 40 MB a minute: over at minute 3 and rising after.
    ("leak", 3, [190.0, 195.0, 240.0, 280.0, 320.0], 5, True),
    # A leak that stops after two minutes: it rose from the first minute
    # over, which a plateau does not.
    ("leak, then flat", 3, [190.0, 195.0, 240.0, 280.0, 281.0], 5, True),
    # Over, then rising by more than RSS_RISE allows a plateau.
    ("slower leak", 3, [190.0, 195.0, 240.0, 255.0, 270.0], 5, True),
    # Over once in a longer run, then back under: only the end is judged.
    ("over mid-run", 6, [190.0, 195.0, 200.0, 240.0, 210.0, 205.0], 6, False),
]


def main():
    problems, cases = [], []
    for name, minutes, medians, want_minutes, want_fail in CASES:
        ran, failure, remark = run(minutes, medians)
        print("%s: ran %d minutes; failure: %s; remark: %s" % (name, ran, failure, remark))
        wrong = []
        if ran != want_minutes:
            wrong.append("%s: ran %d minutes, expected %d" % (name, ran, want_minutes))
        if bool(failure) != want_fail:
            wrong.append("%s: %s, expected it to %s" % (name, "failed" if failure else "passed",
                                                       "fail" if want_fail else "pass"))
        problems += wrong
        cases.append((name, "; ".join(wrong) or None))
    for p in problems:
        print("check_soak_judge: " + p)
    if os.environ.get("IMT_TEST_RESULTS"):
        write_suite(os.environ["IMT_TEST_RESULTS"], "soak_judge", cases)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
