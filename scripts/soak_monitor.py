#!/usr/bin/env python3
"""Watches the live graph during scripts/soak.sh and judges it.

While a looped bag plays into launch/tracking.launch, this node:
- adds the scene's items (scripts/demo_live.py's plan: INIT.yaml's regions, a
  planar target and an anchor) through the services, again after each loop
  (a loop's jump back in time resets every tracker);
- counts, per minute of wall time, the frames in (the motion analysis's
  processed and dropped frames, from /diagnostics) and the messages out on
  motion_data, regions, planar_targets and anchors;
- reads the manager's resident memory (/proc/<pid>/status VmRSS) every
  second, and reports each minute's peak and median;
- reads each nodelet's processing time (mean and max) and resets from
  /diagnostics, and graph_watchdog's verdicts.

It prints one line per minute and exits non-zero (with the reasons) when an
output got no message in a minute, the manager's memory grew more than 20%
after the second minute (median to median: a stall of a second or two on a
loaded machine fills the queues and lifts a minute's peak by as much, a leak
lifts the whole minute), or graph_watchdog reported a nodelet that is not
loaded (or the manager died).

A minute over that bound is not the end of the run: it goes on a minute more
(twice at most), and fails when the last minute is still over and still
rising: more than 5% of minute 2's median above the first minute of that
run over the bound. A graph that
fell behind its input has its queues full (50 frames a subscriber, ~0.9 MB
each at 640x480) and its memory up by tens of MB for as long as it stays
behind: CI met +28% in a minute of a loaded machine whose processing took 2.5
times as long (2026-12-01), and a run at 5 times the bag's rate stays 10-20%
over one at twice. A leak does not go away in the minutes after; a stall does.
Nor does it stand still: CI once met three minutes over the bound with the
graph keeping pace and no frame dropped (258.3 / 258.0 / 217.8 MB against
minute 2's 195.4, 2026-12-02), the allocator holding what the queues of a
stall had taken. A leak that crossed 20% within a minute or two goes on
rising by tens of MB a minute.

  soak_monitor.py --minutes M --truth T.json --init INIT.yaml --manager-pid PID
"""
import argparse
import json
import os
import sys
import threading
import time

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from demo_live import ADD_LAG_S, call_add, make_plan  # noqa: E402

OUTPUTS = ["motion_data", "regions", "planar_targets", "anchors"]
NODELETS = ["motion_analysis", "region_tracker", "planar_targets", "anchor_tracker"]
RSS_GROWTH = 0.20  # allowed growth of the manager's memory after the second minute
EXTRA_MINUTES = 2  # how many more minutes a run over that bound goes on for, to see it persist
RSS_RISE = 0.05  # the rise (of minute 2's median) over those minutes that tells a leak from a plateau


def rss_mb(pid):
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


class Minute:
    def __init__(self):
        self.out = {o: 0 for o in OUTPUTS}
        self.proc = {n: [0.0, 0, 0.0] for n in NODELETS}  # sum of means, reports, max
        self.watchdog_errors = {}  # nodelet -> last reason


class Monitor:
    def __init__(self, plan):
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray
        self.lock = threading.Lock()
        self.minute = Minute()
        self.counters = {}  # (nodelet, key) -> latest cumulative value
        self.latest_stamp = None
        self.plan = plan
        self.pending = list(plan)
        self.subs = [rospy.Subscriber(o, rospy.AnyMsg, self.on_output, o, queue_size=50) for o in OUTPUTS[1:]]
        from instant_motion_tracking.msg import MotionData
        self.subs.append(rospy.Subscriber("motion_data", MotionData, self.on_motion, queue_size=50))
        self.subs.append(rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=100))

    def on_output(self, _msg, name):
        with self.lock:
            self.minute.out[name] += 1

    def on_motion(self, msg):
        stamp = msg.header.stamp.to_sec()
        with self.lock:
            self.minute.out["motion_data"] += 1
            if self.latest_stamp is not None and stamp < self.latest_stamp - 1.0:
                self.pending = list(self.plan)  # a loop: the graph reset; add the items again
            self.latest_stamp = stamp

    def on_diagnostics(self, msg):
        with self.lock:
            for s in msg.status:
                name, _, task = s.name.partition(": ")
                values = {kv.key: kv.value for kv in s.values}
                if name == "graph_watchdog" and s.level >= 2:
                    self.minute.watchdog_errors[task] = s.message
                if name not in NODELETS:
                    continue
                if task == "input":
                    for key in ("frames", "dropped", "resets"):
                        if key in values:
                            self.counters[(name, key)] = int(values[key])
                elif task == "processing" and "processing mean (ms)" in values:
                    p = self.minute.proc[name]
                    if s.message != "no frames in the period":
                        p[0] += float(values["processing mean (ms)"])
                        p[1] += 1
                        p[2] = max(p[2], float(values["processing max (ms)"]))

    def add_due_items(self):
        import rospy
        with self.lock:
            latest = self.latest_stamp
            due = [i for i in self.pending if latest is not None and i["stamp"] + ADD_LAG_S <= latest]
            for i in due:
                self.pending.remove(i)
        for item in due:
            ok, msg = call_add(item, rospy.Time.from_sec(item["stamp"]))
            if not ok and "already" not in msg:
                print("soak_monitor: %s id %d refused: %s" % (item["service"], item["id"], msg), flush=True)

    def take_minute(self):
        with self.lock:
            m, self.minute = self.minute, Minute()
            return m, dict(self.counters)


class MemoryJudge:
    """Tells a leak in the manager's memory from a stall or a plateau, from
    each minute's median RSS (see the module's comment).

    add(minute, rss) after each minute says whether the run should go on a
    minute more to see an excess persist (`planned` is then one more);
    `over` is that minute's excess as a sentence (None within the bound).
    verdict() at the end gives the failure (None: passed) and a remark to
    print (or None).
    """

    def __init__(self, minutes):
        self.minutes = minutes  # the minutes asked for
        self.rss2 = None
        self.over = None
        self.over_from = None  # (minute, median) of the first minute of the run of minutes over the bound
        self.plateau = False  # that run has lasted more than a minute without rising
        self.extra = 0  # minutes run beyond those asked for

    @property
    def planned(self):
        """The minutes the run is to last: those asked for and the extra ones."""
        return self.minutes + self.extra

    def add(self, minute, rss):
        """True when the run should go on a minute more than planned."""
        if minute == 2:
            self.rss2 = rss
        self.over = None
        if minute <= 2 or rss <= (1 + RSS_GROWTH) * self.rss2:
            self.over_from, self.plateau = None, False
            return False
        self.over = "minute %d: manager RSS median %.1f MB, more than %d%% over minute 2's %.1f MB" % (
            minute, rss, RSS_GROWTH * 100, self.rss2)
        if self.over_from is None:
            self.over_from = (minute, rss)
        else:
            self.plateau = rss - self.over_from[1] <= RSS_RISE * self.rss2
            self.over += " (%s %.1f MB at minute %d)" % ("not rising from" if self.plateau else "rising from",
                                                         self.over_from[1], self.over_from[0])
        if minute == self.planned and self.extra < EXTRA_MINUTES:
            self.extra += 1
            return True
        return False

    def verdict(self):
        """(failure or None, remark or None)."""
        if not self.over:
            return None, None
        said = self.over + (" (still over after %d minutes more)" % self.extra if self.extra else "")
        if self.plateau:
            return None, said + ": the allocator's plateau, not a leak"
        return said, None


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--minutes", type=float, required=True)
    ap.add_argument("--truth", required=True)
    ap.add_argument("--init", required=True)
    ap.add_argument("--manager-pid", type=int, required=True)
    args = ap.parse_args()
    import rospy
    with open(args.truth) as f:
        truth = json.load(f)
    with open(args.init) as f:
        init = yaml.safe_load(f)
    plan = make_plan(truth, init)
    rospy.init_node("imt_soak_monitor", anonymous=True, disable_signals=True)
    mon = Monitor(plan)
    failures = []
    judge = MemoryJudge(args.minutes)
    last = {}
    t0 = time.monotonic()
    minute = 0
    print("| minute | frames in (dropped) | motion_data | regions | planar_targets | anchors | manager RSS peak / median (MB) "
          "| processing mean/max (ms): motion, regions, planar, anchors | resets | watchdog |", flush=True)
    print("|---|---|---|---|---|---|---|---|---|---|", flush=True)
    while minute < judge.planned:
        next_at = t0 + 60.0 * (minute + 1)
        # The RSS sampled each second: the caches fill and empty with each
        # loop of the bag, so one sample is as much phase as growth.
        samples, gone, sampled_at = [], False, 0.0
        while time.monotonic() < next_at:
            mon.add_due_items()
            if time.monotonic() - sampled_at >= 1.0:
                sampled_at = time.monotonic()
                now = rss_mb(args.manager_pid)
                if now is None:
                    gone = True
                    break
                samples.append(now)
            time.sleep(0.05)
        rss = None if gone or not samples else sorted(samples)[len(samples) // 2]  # the median
        peak = max(samples) if samples else None
        minute += 1
        m, counters = mon.take_minute()

        def delta(nodelet, key):
            v = counters.get((nodelet, key))
            return None if v is None else v - last.get((nodelet, key), 0)
        frames, dropped = delta("motion_analysis", "frames"), delta("motion_analysis", "dropped")
        resets = delta("motion_analysis", "resets")
        last = counters
        proc = ", ".join("%.1f/%.0f" % (p[0] / p[1], p[2]) if p[1] else "-" for p in
                         (m.proc[n] for n in NODELETS))
        wd = "; ".join("%s: %s" % kv for kv in sorted(m.watchdog_errors.items())) or "OK"
        print("| %d | %s (%s) | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            minute, frames, dropped, *(m.out[o] for o in OUTPUTS),
            "gone" if rss is None else "%.1f / %.1f" % (peak, rss), proc, resets, wd), flush=True)
        if rss is None:
            failures.append("minute %d: the manager (pid %d) is gone" % (minute, args.manager_pid))
            break
        for o in OUTPUTS:
            if m.out[o] == 0:
                failures.append("minute %d: no message on %s" % (minute, o))
        if any("not loaded" in r or "has not answered" in r for r in m.watchdog_errors.values()):
            failures.append("minute %d: graph_watchdog: %s" % (minute, wd))
        if judge.add(minute, rss):
            print("soak_monitor: %s; one minute more, to see whether it stays" % judge.over, flush=True)
        if failures:
            break
    if not failures:
        failure, remark = judge.verdict()
        if failure:
            failures.append(failure)
        if remark:
            print("soak_monitor: " + remark, flush=True)
    for f in failures:
        print("soak: FAILED: " + f, flush=True)
    if not failures:
        print("soak: passed (%d minutes)" % minute, flush=True)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())
