#!/usr/bin/python3
"""Smoke test of the live demo: scripts/demo.sh --live-only on a 4 s cards
scene through the real graph (roscore, launch/replay.launch, the services),
then checks what it wrote and that it left no master running.

usage: check_demo_live.py REPO_ROOT OUT_DIR
The build must be in IMT_BUILD_DIR (ctest sets it). Prints one line per
problem and exits 1 on any; JUnit XML goes to $IMT_TEST_RESULTS if set.
"""
import json
import os
import re
import socket
import subprocess
import sys
import time

import cv2
import numpy as np

from junit_xml import write_suite

FRAMES = 120  # --duration 4 at the cards preset's 30 fps


def check(root, out):
    problems = []
    started = time.monotonic()
    demo = subprocess.run([os.path.join(root, "scripts", "demo.sh"), "--no-build", "--live-only",
                           "--duration", "4", "--out", out],
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, timeout=110)
    print(demo.stdout)
    print("demo.sh took %.1f s" % (time.monotonic() - started))
    if demo.returncode != 0:
        return ["demo.sh exited %d" % demo.returncode]

    # Every process it started is gone: nothing answers on the master's port.
    port = re.search(r"roscore on port (\d+)", demo.stdout)
    if not port:
        problems.append("demo.sh did not say which port roscore used")
    else:
        with socket.socket() as s:
            if s.connect_ex(("localhost", int(port.group(1)))) == 0:
                problems.append("roscore still answers on port %s after demo.sh exited" % port.group(1))

    live = os.path.join(out, "live")
    for name in ("report.txt", "report.json", "strip.png", "regions.csv", "planar_targets.csv", "anchors.csv"):
        if not os.path.isfile(os.path.join(live, name)) or os.path.getsize(os.path.join(live, name)) == 0:
            problems.append("%s missing or empty" % name)
    if problems:
        return problems
    r = json.load(open(os.path.join(live, "report.json")))

    # All seven items (5 regions, the patch as a planar target, an anchor) were accepted.
    added = r["added"]
    if len(added) != 7 or not all(a["success"] for a in added):
        problems.append("items added: %s" % [(a["service"], a["id"], a["message"]) for a in added])
    # Every output came for (nearly) every frame: the graph keeps up at rate 1
    # on one core (the replay rostests see no dropped frame); 80% leaves room
    # for a loaded machine without hiding a broken topic.
    # debug_image is a viewer's stream: a slow subscriber (this recorder,
    # encoding video on a loaded machine) loses frames at the publisher's
    # queue by design, never holding the trackers back. How many it loses
    # follows the machine: 67 of 120 and 45 of 120 under the CI's ctest -j2
    # on 2026-11-29, a day its build took 9 min instead of 5; 56-95 of 120
    # with four busy loops on this 2-core machine on 2026-12-01. A quarter
    # still shows the stream flowing; the strip (below) shows it from the
    # adds to the end.
    for topic, n in r["frames_received"].items():
        share = 0.25 if topic == "debug_image" else 0.8
        if n < share * FRAMES:
            problems.append("%s: %d of %d frames" % (topic, n, FRAMES))
    if r["tf_messages"] == 0:
        problems.append("no /tf message (planar_target_1 / anchor_1)")
    # Accuracy against the scene's truth, with margins well above the measured
    # figures (mean IoU 0.91-0.92, planar corners 0.14-0.39 px median, anchor
    # 0.12-0.25 px median over several runs): these only catch a broken chain.
    acc = r["accuracy"]
    if not acc["regions_mean_iou"] or acc["regions_mean_iou"] < 0.75:
        problems.append("regions mean IoU %s < 0.75" % acc["regions_mean_iou"])
    if len(acc["regions"]) != 5:
        problems.append("scored regions: %s" % sorted(acc["regions"]))
    t = acc["planar_targets"].get("1")
    if not t or t["frames"] < 30 or t["corner_error_median_px"] > 2.0:
        problems.append("planar target 1: %s" % t)
    a = acc["anchors"].get("1")
    if not a or a["frames"] < 30 or a["pixel_error_median_px"] > 2.0:
        problems.append("anchor 1: %s" % a)
    if "regions" not in r["latency_ms"]:
        problems.append("no latency measured")

    # The strip: six 640x480 debug images, 3 x 2, with the overlay drawn by the
    # live MotionAnalysisNodelet: region boxes (yellow, BGR 0,220,255) in every
    # tile that arrived and the planar-target quad (magenta) in all but one.
    # The strip's frames are chosen from 0.2 s after the graph's stamp at the
    # last add, which demo_live.py makes with the player paused, so every
    # tile's frame is tracked after the adds. A tile takes the first debug
    # image of its span of about 15 frames (the last tile: the bag's last
    # frame alone); under load the publisher's queue may drop a whole span
    # (tiles 1 and 2 stayed black with four busy loops on this machine on
    # 2026-12-01), so only three tiles must arrive. A frame whose target state
    # comes later than the overlay waits goes out without the quad. Every
    # region the regions topic has at a tile's stamp is checked to be drawn
    # there (overlay_check, below).
    strip = cv2.imread(os.path.join(live, "strip.png"))
    if strip is None or strip.shape != (960, 1920, 3):
        problems.append("strip.png: shape %s, expected 960x1920x3" % (None if strip is None else strip.shape,))
    else:
        arrived, with_quad, without_boxes = [], 0, []
        for i in range(6):
            tile = strip[(i // 3) * 480:(i // 3 + 1) * 480, (i % 3) * 640:(i % 3 + 1) * 640]
            if not tile.any():
                continue  # never arrived: left black
            arrived.append(i)
            if np.all(tile == (0, 220, 255), axis=2).sum() < 500:
                without_boxes.append(i)
            with_quad += np.all(tile == (255, 0, 255), axis=2).sum() >= 100
        if len(arrived) < 3:
            problems.append("strip tiles arrived: %s of 0-5 (the debug_image stream stalled?)" % arrived)
        if without_boxes:
            problems.append("no region boxes drawn in strip tiles %s of those arrived, %s (no overlay?)"
                            % (without_boxes, arrived))
        if arrived and with_quad < len(arrived) - 1:
            problems.append("the planar target's quad is drawn in %d of the %d strip tiles that arrived"
                            % (with_quad, len(arrived)))
    # ... and each tracked region's box drawn at the place the regions topic
    # gives for the debug image's own stamp (the nodelet waits for the
    # trackers' states of each frame); one frame late would miss moving cards.
    o = r.get("overlay_check", {})
    if o.get("regions_checked", 0) < 10 or o["drawn_at_their_stamp"] < 0.9 * o["regions_checked"]:
        problems.append("overlay at the frame's stamp: %s" % o)
    video = [f for f in os.listdir(live) if f.startswith("debug_image.")]
    if not video or os.path.getsize(os.path.join(live, video[0])) < 10000:
        problems.append("no debug_image video")
    return problems


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    try:
        problems = check(sys.argv[1], sys.argv[2])
    except subprocess.TimeoutExpired:
        problems = ["demo.sh did not finish within 110 s"]
    for p in problems:
        print("FAIL: %s" % p)
    if os.environ.get("IMT_TEST_RESULTS"):
        write_suite(os.environ["IMT_TEST_RESULTS"], "demo_live",
                    [("live_graph_smoke", "; ".join(problems) or None)])
    print("demo live smoke test: %s" % ("FAILED" if problems else "passed"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())
