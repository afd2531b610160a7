#!/usr/bin/python3
"""scripts/region_table.py, the whole real-video table in one command, on
rows as benchmark_region_real prints them and, end to end, on a stand-in
benchmark (no video, no build): each of the six ways read from its own run
(OTB's perturbed starts, --sre, from a run without --starts),
the benchmark's own mean row ignored, a mean over each way's sequences, the
arguments after "--" passed to every run, "before -> after" against a saved
table, and a failing run reported as a failure.

usage: check_region_table.py REPO_ROOT
Prints one line per problem and exits 1 on any; JUnit XML (a case per check)
goes to $IMT_TEST_RESULTS if set.
"""
import contextlib
import io
import json
import os
import stat
import sys
import tempfile

from junit_xml import write_suite

sys.path.insert(0, os.path.join(sys.argv[1], "scripts"))
import region_table  # noqa: E402

# Rows as the benchmark prints them (2026-12-06), one run per way.
FIRST = """| vot2015_car1 | instant_motion_tracking | 252 | 0.757 | 0.723..0.777 | 0.770 | 0.995 | 180.4 |
| vot2015_car1 | OpenCV CSRT | 252 | 0.740 | 0.740..0.740 | 0.752 | 1.000 | 21.4 |
| pot210_V25_2 | instant_motion_tracking | 50 | 0.949 | 0.949..0.950 | 0.973 | 1.000 | 331.8 |
| **mean** | instant_motion_tracking | | 0.853 | 0.836..0.864 | 0.871 | 0.997 | 256.1 |
"""
MID = """| vot2015_car1 | instant_motion_tracking, backward | 125 | 0.828 | 0.795..0.859 | 0.845 | 1.000 | 169.5 |
| vot2015_car1 | instant_motion_tracking, forward | 126 | 0.868 | 0.859..0.881 | 0.888 | 1.000 | 169.5 |
"""
EVERY2 = "| vot2015_car1/2 | instant_motion_tracking | 126 | 0.725 | 0.719..0.742 | 0.736 | 0.990 | 142.2 |\n"
EVERY3 = """| vot2015_car1/3 | instant_motion_tracking | 84 | 0.710 | 0.686..0.726 | 0.720 | 0.976 | 132.9 |
| pot210_V25_2/3 | instant_motion_tracking | 17 | 0.945 | 0.940..0.946 | 0.969 | 1.000 | 261.7 |
"""

# A stand-in for benchmark_region_real: our rows for two sequences in the
# way its arguments ask, AUC 0.5 (0.6 with "--set x=1"; 0.1 less with
# "--sre"); exits 3 with "--fail", and 2 with both "--sre" and "--starts"
# (as the benchmark refuses them).
FAKE = r"""#!/usr/bin/python3
import sys
a = sys.argv[1:]
if "--fail" in a:
    sys.exit(3)
if "--sre" in a and "--starts" in a:
    sys.exit(2)
auc = (0.6 if "x=1" in a else 0.5) - (0.1 if "--sre" in a else 0)
stride = a[a.index("--stride") + 1] if "--stride" in a else None
for seq in ["seq_a", "seq_b"]:
    name = seq + ("/" + stride if stride else "")
    if "--mid" in a:
        for half in ("backward", "forward"):
            print("| %s | instant_motion_tracking, %s | 10 | %.3f | x | x | x | x |" % (name, half, auc))
    else:
        print("| %s | instant_motion_tracking | 10 | %.3f | x | x | x | x |" % (name, auc))
print("| **mean** | instant_motion_tracking | | 0.999 | x | x | x | x |")
"""


def checks():
    """(name, problem or None) for each check."""
    out = []

    def check(name, ok, problem):
        out.append((name, None if ok else problem))

    figures = {}
    for text in (FIRST, MID, EVERY2, EVERY3):
        figures.update(region_table.parse(text))
    want = {
        ("vot2015_car1", "first"): 0.757, ("pot210_V25_2", "first"): 0.949,
        ("vot2015_car1", "mid back"): 0.828, ("vot2015_car1", "mid fwd"): 0.868,
        ("vot2015_car1", "every 2nd"): 0.725, ("vot2015_car1", "every 3rd"): 0.710,
        ("pot210_V25_2", "every 3rd"): 0.945,
    }
    check("parse: our rows by way, peers and the benchmark's mean left out", figures == want,
          "parsed %r, expected %r" % (sorted(figures.items()), sorted(want.items())))
    sre = region_table.parse(FIRST, sre=True)
    check("parse: a --sre run's rows are the sre way's",
          sre == {("vot2015_car1", "sre"): 0.757, ("pot210_V25_2", "sre"): 0.949}, "parsed %r" % sorted(sre.items()))
    with_mean = region_table.mean(figures)
    check("mean: over each way's own sequences",
          abs(with_mean[("mean", "first")] - (0.757 + 0.949) / 2) < 1e-9 and
          abs(with_mean[("mean", "every 2nd")] - 0.725) < 1e-9,
          "means %r" % {k: v for k, v in with_mean.items() if k[0] == "mean"})
    before = dict(with_mean)
    before[("vot2015_car1", "first")] = 0.700
    text = region_table.table(with_mean, before)
    check("table: before -> after, a dash where a way has no run",
          "| vot2015_car1 | 0.700 -> 0.757 |" in text and "| pot210_V25_2 | 0.949 -> 0.949 | - -> - |" in text,
          "table:\n" + text)
    check("JSON: the figures round-trip",
          region_table.from_json(json.loads(json.dumps(region_table.to_json(with_mean)))) == with_mean,
          "not the same after a round trip")

    with tempfile.TemporaryDirectory() as tmp:
        fake = os.path.join(tmp, "bench")
        with open(fake, "w") as f:
            f.write(FAKE)
        os.chmod(fake, os.stat(fake).st_mode | stat.S_IXUSR)
        saved = os.path.join(tmp, "before.json")

        def run(args):
            printed = io.StringIO()
            with contextlib.redirect_stdout(printed), contextlib.redirect_stderr(io.StringIO()):
                status = region_table.main(["--bench", fake, "--starts", "2"] + args)
            return status, printed.getvalue()

        status, printed = run(["--save", saved])
        rows = [line for line in printed.splitlines() if line.startswith("| seq_a")]
        check("end to end: every way from its own run",
              status == 0 and rows == ["| seq_a | 0.500 | 0.500 | 0.500 | 0.500 | 0.500 | 0.400 |"],
              "status %d, printed:\n%s" % (status, printed))
        status, printed = run(["--against", saved, "--", "--set", "x=1"])
        check("end to end: arguments after -- reach every run; before -> after",
              status == 0 and "| **mean** | " + " | ".join(["0.500 -> 0.600"] * 5) + " | 0.400 -> 0.500 |" in printed,
              "status %d, printed:\n%s" % (status, printed))
        status, _ = run(["--", "--fail"])
        check("end to end: a failing run fails", status == 1, "status %d, expected 1" % status)
    return out


def main():
    cases = checks()
    problems = [p for _, p in cases if p]
    for name, p in cases:
        print("%s: %s" % (name, "ok" if p is None else p))
    if os.environ.get("IMT_TEST_RESULTS"):
        write_suite(os.environ["IMT_TEST_RESULTS"], "region_table", cases)
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
