#!/usr/bin/python3
"""The whole real-video table of region tracking in one command: this
package's success AUC on every box sequence in ../shared/data in each of the
six ways docs/benchmarks.md reports it (the first frame's box; the middle
frame's, its halves backward and forward; every 2nd frame; every 3rd), as
means over nudged starts, and from the first frame's box perturbed as OTB's
spatial robustness evaluation does (`--sre`: shifted by a tenth of its sides,
scaled by 0.8-1.2; 12 runs), with a mean row. Two benchmark processes at a
time, each on a core of its own (taskset), so the six take about a minute on
two cores. A tracking change is judged on this table before and
after, whole.

usage: region_table.py [--bench PATH] [--starts N] [--save FILE] [--against FILE]
                       [-- benchmark arguments, e.g. --set appearance_budget=4]

  --bench PATH     benchmark_region_real (default: _build/benchmark/ beside scripts/,
                   or $IMT_BUILD_DIR/benchmark/)
  --starts N       runs from the given box and N - 1 nudged copies (default 8)
  --save FILE      also writes the table's figures to FILE (JSON)
  --against FILE   prints each figure as "before -> after", the before from a
                   --save of an earlier run
Arguments after "--" go to every benchmark run (--set, --no-appearance, ...).
Exits 1 when a run fails or prints no row of ours.
"""
import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile

MODES = ["first", "mid back", "mid fwd", "every 2nd", "every 3rd", "sre"]
OURS = "instant_motion_tracking"
MEAN = "mean"


def parse(text, sre=False):
    """{(sequence, mode): success AUC} of our rows in one run's output; the
    mode from the run's own row names (", backward" / ", forward" for the
    middle frame's halves, "/N" for every Nth frame), or "sre" for a run
    with --sre. The benchmark's own mean row is left out: the table's mean is
    taken over each mode's own sequences (mean())."""
    out = {}
    for line in text.splitlines():
        cells = [c.strip() for c in line.split("|")]
        if len(cells) < 6 or not cells[2].startswith(OURS):
            continue
        name = cells[1].replace("*", "")
        if name == MEAN:
            continue
        try:
            auc = float(cells[4])
        except ValueError:
            continue
        stride = 1
        if "/" in name:
            name, n = name.rsplit("/", 1)
            stride = int(n)
        tracker = cells[2]
        if tracker.endswith(", backward"):
            mode = "mid back"
        elif tracker.endswith(", forward"):
            mode = "mid fwd"
        elif stride == 2:
            mode = "every 2nd"
        elif stride == 3:
            mode = "every 3rd"
        elif stride == 1:
            mode = "sre" if sre else "first"
        else:
            continue
        out[(name, mode)] = auc
    return out


def mean(figures):
    """Adds each mode's mean over its sequences (sequence MEAN)."""
    out = dict(figures)
    for mode in MODES:
        values = [v for (s, m), v in figures.items() if m == mode and s != MEAN]
        if values:
            out[(MEAN, mode)] = sum(values) / len(values)
    return out


def table(after, before=None):
    """The markdown table: a row per sequence (in first-seen order), MEAN last."""
    sequences = []
    for s, _ in after:
        if s != MEAN and s not in sequences:
            sequences.append(s)
    sequences.append(MEAN)
    lines = ["| sequence | " + " | ".join(MODES) + " |", "|---" * (len(MODES) + 1) + "|"]
    for s in sequences:
        cells = []
        for m in MODES:
            a = after.get((s, m))
            text = "-" if a is None else "%.3f" % a
            if before is not None:
                b = before.get((s, m))
                text = ("-" if b is None else "%.3f" % b) + " -> " + text
            cells.append(text)
        name = "**mean**" if s == MEAN else s
        lines.append("| %s | %s |" % (name, " | ".join(cells)))
    return "\n".join(lines)


def to_json(figures):
    return {"%s|%s" % k: v for k, v in figures.items()}


def from_json(d):
    return {tuple(k.split("|", 1)): v for k, v in d.items()}


def default_bench():
    build = os.environ.get("IMT_BUILD_DIR") or os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "_build")
    return os.path.join(build, "benchmark", "benchmark_region_real")


def main(argv):
    extra = []
    if "--" in argv:
        extra = argv[argv.index("--") + 1:]
        argv = argv[:argv.index("--")]
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bench", default=default_bench())
    p.add_argument("--starts", type=int, default=8)
    p.add_argument("--save")
    p.add_argument("--against")
    a = p.parse_args(argv)
    if not os.access(a.bench, os.X_OK):
        print("no benchmark at %s: build it (scripts/setup.sh's imt_build benchmarks) or give --bench" % a.bench,
              file=sys.stderr)
        return 1
    before = None
    if a.against:
        with open(a.against) as f:
            before = from_json(json.load(f))
    base = [a.bench, "--ours-only"] + extra
    starts = ["--starts", str(a.starts)]
    # Two queues, one per core: the middle frame's runs (the longest) and
    # every 3rd frame's beside the first frame's, every 2nd frame's and OTB's
    # perturbed starts (--sre, which takes the place of --starts).
    queues = [[starts, starts + ["--stride", "2"], ["--sre"]], [starts + ["--mid"], starts + ["--stride", "3"]]]
    cores = os.cpu_count() or 1
    figures = {}
    with tempfile.TemporaryDirectory() as tmp:
        procs, outputs, sre = [], [], []
        for q, runs in enumerate(queues):
            commands = []
            for i, run in enumerate(runs):
                outputs.append(os.path.join(tmp, "%d_%d" % (q, i)))
                sre.append("--sre" in run)
                commands.append("%s > %s 2>&1" % (shlex.join(["taskset", "-c", str(q % cores)] + base + run),
                                                  shlex.quote(outputs[-1])))
            procs.append(subprocess.Popen(["/bin/sh", "-c", " && ".join(commands)]))
        failed = [proc.wait() for proc in procs] != [0] * len(procs)
        for path, is_sre in zip(outputs, sre):
            if os.path.exists(path):
                with open(path) as f:
                    figures.update(parse(f.read(), is_sre))
    if failed or not figures:
        print("a benchmark run failed or printed no row of ours (%s)" % " ".join(base), file=sys.stderr)
        return 1
    figures = mean(figures)
    print("Success AUC, this package, means of %d starts (sre: of OTB's 12)%s:" %
          (a.starts, (" (" + " ".join(extra) + ")") if extra else ""))
    print(table(figures, before))
    if a.save:
        with open(a.save, "w") as f:
            json.dump(to_json(figures), f, indent=1, sort_keys=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
