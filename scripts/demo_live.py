#!/usr/bin/python3
"""Drives and records the live graph for scripts/demo.sh, then scores it.

usage: demo_live.py --truth TRUTH.json --init INIT.yaml --out DIR [--timeout S] [--hold]

Expects a master (ROS_MASTER_URI) running launch/replay.launch with
paused:=true on make_scene's bag. It
  1. waits for the services and for the lazy graph to subscribe to the images,
     then resumes the player (/player/pause_playback);
  2. adds, through add_region / add_planar_target / add_anchor, the INIT.yaml
     regions, a planar target and an anchor, each at its stamp once the
     player's /clock is half a second past it (the trackers catch up from
     their cache). The player is paused for the adds until the graph has
     worked off what it was given, so the items land at the same frames
     however loaded the machine is;
  3. records regions, planar_targets, anchors, debug_image, /tf and /diagnostics
     until the bag's last frame has come through;
  4. writes to DIR: debug_image.mp4 (or .avi), strip.png (6 debug_image frames
     tiled), regions.csv / planar_targets.csv / anchors.csv (track_bag's
     columns), report.txt and report.json.
For the cards scene, whose INIT.yaml has regions only, the planar target is the
static textured patch (region 4) and the anchor a wall point clear of the
cards; their ground truth is the wall's exact homographies from the scene
truth, chained from the placement frame (the patch lies 1 mm off the wall).
The anchor is scored where its point is in view and no card is near it.
Exits 1 with a one-line message naming the problem on failure.
"""
import argparse
import bisect
import json
import math
import os
import sys
import threading
import time

import numpy as np
import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from evaluate import clip, iou  # noqa: E402  (the offline scorer's box metrics)

STRIP_FRAMES = 6
ADD_LAG_S = 0.5           # items are added this far in the past: the trackers catch up
CARDS_PATCH_ID = 4        # cards preset: the static textured patch ...
CARDS_PATCH_SIZE = (0.5, 0.4)  # ... and its size (m), as laid out in sim/scene_presets.cpp
ANCHOR_CLEARANCE_PX = 30  # the chosen anchor point stays this far from every card


class DemoError(Exception):
    pass


# --- ground truth and the plan (no ROS) --------------------------------------

def apply_h(H, p):
    x, y = p
    d = H[6] * x + H[7] * y + H[8]
    return ((H[0] * x + H[1] * y + H[2]) / d, (H[3] * x + H[4] * y + H[5]) / d)


def chain(truth, k0, points):
    """Wall points given at frame k0, moved by the truth's background
    homographies: {frame index: [points]} for k0 and every later frame (until a
    frame without a homography)."""
    out = {k0: list(points)}
    cur = list(points)
    for k in range(k0 + 1, len(truth["frames"])):
        H = truth["frames"][k]["background_homography"]
        if H is None:
            break
        cur = [apply_h(H, p) for p in cur]
        out[k] = cur
    return out


def frame_index(truth, stamp):
    stamps = [f["stamp"] for f in truth["frames"]]
    k = min(range(len(stamps)), key=lambda i: abs(stamps[i] - stamp))
    if abs(stamps[k] - stamp) > 0.5 / truth["fps"]:
        raise DemoError("stamp %.6f is no frame of the scene" % stamp)
    return k


def region_truth(truth, k, rid):
    return next((r for r in truth["frames"][k]["regions"] if r["id"] == rid), None)


def anchor_visible(truth, k, p):
    """True when the wall point p is in view at frame k and no card is within
    ANCHOR_CLEARANCE_PX of it (a card passing in front would occlude it)."""
    w, h = truth["width"], truth["height"]
    x, y = p
    if not (10 <= x < w - 10 and 10 <= y < h - 10):
        return False
    for r in truth["frames"][k]["regions"]:
        bx, by, bw, bh = r["box_unclipped"]
        if math.hypot(max(bx - x, 0, x - (bx + bw)), max(by - y, 0, y - (by + bh))) < ANCHOR_CLEARANCE_PX:
            return False
    return True


def choose_anchor_point(truth, k0):
    """A wall pixel at frame k0, clear of the cards there, seen clear of them in
    the most frames (each frame a card comes near it costs three); None if
    there is none."""
    w, h = truth["width"], truth["height"]
    best = None
    for v in range(40, h - 39, 20):
        for u in range(40, w - 39, 20):
            p = (u + 0.5, v + 0.5)
            if not anchor_visible(truth, k0, p):
                continue
            track = chain(truth, k0, [p])
            clear = sum(anchor_visible(truth, k, q[0]) for k, q in track.items())
            in_view = sum(10 <= q[0][0] < w - 10 and 10 <= q[0][1] < h - 10 for q in track.values())
            key = (clear - 3 * (in_view - clear), -math.hypot(u - w / 2, v - h / 2))
            if best is None or key > best[0]:
                best = (key, p)
    return best[1] if best else None


def make_plan(truth, init):
    """The items to add, each {service, id, stamp, request fields, truth:
    {frame: value}}: INIT.yaml's regions, planar targets and anchors; for a
    scene whose INIT has no planar target / anchor but a planar background
    (cards), one of each on the wall."""
    init = init or {}
    items = []
    for r in init.get("regions") or []:
        items.append({"service": "add_region", "kind": "region", "id": r["id"], "stamp": r["stamp"],
                      "fields": dict(zip(("x", "y", "width", "height"), map(float, r["box"])))})
    for t in init.get("planar_targets") or []:
        k0 = frame_index(truth, t["stamp"])
        gt = {k: next((x["corners"] for x in f["planar_targets"] if x["id"] == t["id"]), None)
              for k, f in enumerate(truth["frames"]) if k >= k0}
        items.append({"service": "add_planar_target", "kind": "planar target", "id": t["id"],
                      "stamp": t["stamp"], "corners": t["corners"], "size": t["size"],
                      "truth": {k: c for k, c in gt.items() if c}})
    for a in init.get("anchors") or []:
        k0 = frame_index(truth, a["stamp"])
        gt = {}
        for k, f in enumerate(truth["frames"]):
            x = next((x for x in f["anchors"] if x["id"] == a["id"]), None) if k >= k0 else None
            if x and x["in_view"]:
                gt[k] = x["pixel"]
        items.append({"service": "add_anchor", "kind": "anchor", "id": a["id"], "stamp": a["stamp"],
                      "fields": {"u": float(a["point"][0]), "v": float(a["point"][1]),
                                 "depth": float(a.get("depth", 0.0))}, "truth": gt})
    planar_background = any(f["background_homography"] for f in truth["frames"])
    patch = next((r for r in init.get("regions") or [] if r["id"] == CARDS_PATCH_ID), None)
    if truth.get("preset") == "cards" and planar_background and patch and not init.get("planar_targets"):
        k0 = frame_index(truth, patch["stamp"])
        x, y, bw, bh = map(float, patch["box"])
        corners = [(x, y), (x + bw, y), (x + bw, y + bh), (x, y + bh)]  # TL, TR, BR, BL
        items.append({"service": "add_planar_target", "kind": "planar target", "id": 1,
                      "stamp": patch["stamp"], "corners": corners, "size": CARDS_PATCH_SIZE,
                      "truth": chain(truth, k0, corners)})
    if planar_background and not init.get("anchors"):
        k0 = frame_index(truth, patch["stamp"]) if patch else 1
        p = choose_anchor_point(truth, k0)
        if p:
            stamp = truth["frames"][k0]["stamp"]
            track = chain(truth, k0, [p])
            gt = {k: q[0] for k, q in track.items() if anchor_visible(truth, k, q[0])}
            items.append({"service": "add_anchor", "kind": "anchor", "id": 1, "stamp": stamp,
                          "fields": {"u": p[0], "v": p[1], "depth": 0.0}, "truth": gt})
    return items


# --- scoring (no ROS) --------------------------------------------------------

def pct(values, p):
    v = sorted(values)
    return v[int(p * (len(v) - 1))] if v else float("nan")


def score(truth, plan, rec):
    """Accuracy of the recorded outputs against the ground truth, per item."""
    w, h = truth["width"], truth["height"]
    frame_of = {round(f["stamp"], 6): k for k, f in enumerate(truth["frames"])}
    result = {"regions": {}, "planar_targets": {}, "anchors": {}}
    for stamp, states in rec["regions"]:
        k = frame_of.get(round(stamp, 6))
        for s in states if k is not None else []:
            gt = region_truth(truth, k, s["id"])
            if not gt or gt["visible_fraction"] < 0.5:
                continue
            v = iou(clip(s["box"], w, h), clip(gt["box"], w, h)) if s["status"] != "lost" else 0.0
            result["regions"].setdefault(s["id"], []).append(v)
    truth_of = {(i["kind"], i["id"]): i.get("truth", {}) for i in plan}
    for stamp, states in rec["planar_targets"]:
        k = frame_of.get(round(stamp, 6))
        for s in states if k is not None else []:
            gt = truth_of.get(("planar target", s["id"]), {}).get(k)
            if gt and s["status"] != "lost":
                e = [math.hypot(c[0] - g[0], c[1] - g[1]) for c, g in zip(s["corners"], gt)]
                result["planar_targets"].setdefault(s["id"], []).append(math.sqrt(sum(x * x for x in e) / 4))
    for stamp, states in rec["anchors"]:
        k = frame_of.get(round(stamp, 6))
        for s in states if k is not None else []:
            gt = truth_of.get(("anchor", s["id"]), {}).get(k)
            if gt and s["status"] != "lost":
                result["anchors"].setdefault(s["id"], []).append(math.hypot(s["u"] - gt[0], s["v"] - gt[1]))
    return result


REGION_BGR = (0, 220, 255)  # core/debug_draw.h kRegionColour


def overlay_check(images, regions, targets):
    """How many (frame, region) pairs of the debug images have the region's
    box drawn where the regions topic says it is at that frame's stamp: at
    least two of its four edge midpoints in the region colour (another item
    may be drawn over one edge; a box under a planar target's quad, drawn
    over it, is not checked). Returns (checked, drawn, misses: [stamp, id, edges hit])."""
    by_stamp = {round(st, 6): states for st, states in regions}
    quads = {}
    for st, states in targets:
        for t in states:
            xs, ys = [c[0] for c in t["corners"]], [c[1] for c in t["corners"]]
            quads.setdefault(round(st, 6), []).append([min(xs), min(ys), max(xs) - min(xs), max(ys) - min(ys)])
    checked = drawn = 0
    misses = []
    for stamp, img in images.items():
        h, w = img.shape[:2]
        for s in by_stamp.get(stamp, []):
            x, y, bw, bh = s["box"]
            if s["status"] != "tracked" or x < 2 or y < 2 or x + bw > w - 2 or y + bh > h - 2:
                continue
            if any(iou(s["box"], q) > 0.5 for q in quads.get(stamp, [])):
                continue
            # Pixel (column, row) holding each edge's midpoint (our convention: centres at +0.5).
            mids = [(x, y + bh / 2), (x + bw - 1, y + bh / 2), (x + bw / 2, y), (x + bw / 2, y + bh - 1)]
            hits = sum(tuple(img[int(round(py)), int(round(px))]) == REGION_BGR for px, py in mids)
            checked += 1
            drawn += hits >= 2
            if hits < 2:
                misses.append([stamp, s["id"], hits])
    return checked, drawn, misses


# --- the live part (rospy) ---------------------------------------------------

class Recorder:
    """Keeps the graph's outputs as plain data; debug images go to a video as
    they arrive, and the few chosen for the strip are kept."""

    def __init__(self, out_dir, fps, image_topic):
        import cv2  # noqa: F401  (here, before playing: importing it takes seconds on a loaded
        # machine and holds every other thread of this process, the main loop's included)
        import rospy
        from diagnostic_msgs.msg import DiagnosticArray
        from instant_motion_tracking.msg import AnchorArray, PlanarTargetArray, TrackedRegionArray
        from sensor_msgs.msg import Image
        from tf2_msgs.msg import TFMessage
        self.lock = threading.Lock()
        self.out_dir, self.fps = out_dir, fps
        self.strip_stamps, self.strip = [], {}  # set_strip(): slot -> (stamp, image)
        self.image_arrival = {}  # round(stamp, 6) -> wall time the input image arrived here
        self.data = {"regions": [], "planar_targets": [], "anchors": [], "debug_image": [], "tf": 0}
        self.stamps = {}        # round(stamp, 6) -> rospy.Time, from the outputs
        # Wall time from the input image's arrival here to the output's (s).
        self.delays = {"regions": [], "planar_targets": [], "anchors": [], "debug_image": []}
        self.diagnostics = {}   # status name -> [values dict per period with frames]
        self.video, self.video_path, self.video_tried = None, None, False
        self.video_lock = threading.Lock()  # the video writer's own (close() may race a write)
        self.rospy = rospy
        q = 2000
        self.subs = [
            rospy.Subscriber("regions", TrackedRegionArray, self.on_regions, queue_size=q),
            rospy.Subscriber("planar_targets", PlanarTargetArray, self.on_targets, queue_size=q),
            rospy.Subscriber("anchors", AnchorArray, self.on_anchors, queue_size=q),
            rospy.Subscriber("debug_image", Image, self.on_image, queue_size=q, buff_size=1 << 26),
            rospy.Subscriber("/tf", TFMessage, self.on_tf, queue_size=q),
            rospy.Subscriber("/diagnostics", DiagnosticArray, self.on_diagnostics, queue_size=q),
            rospy.Subscriber(image_topic, Image, self.on_input, queue_size=q, buff_size=1 << 26),
        ]

    def set_strip(self, stamps):
        """Keeps, from now on, for each of these stamps the first debug image
        at or after it (and before the next one): a frame the graph dropped
        under load leaves no hole in the strip."""
        with self.lock:
            self.strip_stamps = sorted(round(s, 6) for s in stamps)
            self.strip = {}

    def strip_images(self):
        """{stamp: image} of the strip's frames that arrived."""
        with self.lock:
            return dict(self.strip.values())

    def strip_tiles(self):
        """One image or None per strip slot, in order."""
        with self.lock:
            return [self.strip[k][1] if k in self.strip else None for k in range(len(self.strip_stamps))]

    def on_input(self, m):
        now = time.monotonic()
        with self.lock:
            self.image_arrival[round(m.header.stamp.to_sec(), 6)] = now

    def _delay(self, topic, stamp):
        arrived = self.image_arrival.get(round(stamp.to_sec(), 6))
        if arrived is not None:
            self.delays[topic].append(time.monotonic() - arrived)

    def on_regions(self, m):
        states = [{"id": r.id, "box": [r.x, r.y, r.width, r.height], "rect": [r.angle, r.rect_width, r.rect_height],
                   "status": r.status,
                   "confidence": r.confidence} for r in m.regions]
        with self.lock:
            self._delay("regions", m.header.stamp)
            self.stamps[round(m.header.stamp.to_sec(), 6)] = m.header.stamp
            self.data["regions"].append((m.header.stamp.to_sec(), states))

    def on_targets(self, m):
        states = [{"id": t.id, "corners": [(c.x, c.y) for c in t.corners], "status": t.status,
                   "pose": pose_list(t.pose)} for t in m.targets]
        with self.lock:
            self._delay("planar_targets", m.header.stamp)
            self.data["planar_targets"].append((m.header.stamp.to_sec(), states))

    def on_anchors(self, m):
        states = [{"id": a.id, "u": a.u, "v": a.v, "status": a.status, "pose": pose_list(a.pose)}
                  for a in m.anchors]
        with self.lock:
            self._delay("anchors", m.header.stamp)
            self.data["anchors"].append((m.header.stamp.to_sec(), states))

    def on_tf(self, m):
        with self.lock:
            self.data["tf"] += 1

    def on_diagnostics(self, m):
        with self.lock:
            for s in m.status:
                values = {kv.key: kv.value for kv in s.values}
                if "processing mean (ms)" in values and s.message != "no frames in the period":
                    self.diagnostics.setdefault(s.name, []).append(values)

    def on_image(self, m):
        if m.encoding != "bgr8":
            return
        img = np.frombuffer(m.data, np.uint8).reshape(m.height, m.step)[:, :m.width * 3]
        img = img.reshape(m.height, m.width, 3)
        stamp = m.header.stamp.to_sec()
        with self.lock:
            self._delay("debug_image", m.header.stamp)
            self.data["debug_image"].append(stamp)
            slot = bisect.bisect_right(self.strip_stamps, round(stamp, 6)) - 1
            keep = slot >= 0 and slot not in self.strip
            if keep:
                self.strip[slot] = (round(stamp, 6), None)
        # Outside self.lock: encoding takes long on a loaded machine, and the
        # other callbacks and the main loop must not wait for it.
        if keep:
            copy = img.copy()
            with self.lock:
                if self.strip.get(slot, (None,))[0] == round(stamp, 6):
                    self.strip[slot] = (round(stamp, 6), copy)
        with self.video_lock:
            if not self.video_tried:
                self.video_tried = True
                self.video, self.video_path = open_video(self.out_dir, self.fps, (m.width, m.height))
            if self.video is not None:
                self.video.write(np.ascontiguousarray(img))

    def close(self):
        for s in self.subs:
            s.unregister()
        with self.video_lock:
            if self.video is not None:
                self.video.release()
                self.video = None

    def latest_stamp(self):
        """The stamp of the latest regions message (s): how far the graph is."""
        with self.lock:
            return self.data["regions"][-1][0] if self.data["regions"] else None


def pose_list(p):
    return [p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y, p.orientation.z,
            p.orientation.w]


def open_video(out_dir, fps, size):
    import cv2
    for name, fourcc in (("debug_image.mp4", "mp4v"), ("debug_image.avi", "MJPG")):
        path = os.path.join(out_dir, name)
        v = cv2.VideoWriter(path, cv2.VideoWriter_fourcc(*fourcc), fps, size)
        if v.isOpened():
            return v, path
        v.release()
    print("demo_live: cannot write a video (no mp4v or MJPG encoder); the strip is still written",
          file=sys.stderr)
    return None, None


def wall_wait(predicate, timeout, step=0.02):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return predicate()


def image_subscribed(image_topic):
    """True when a node other than this one subscribes to the image."""
    import rosgraph
    import rospy
    _, subscribers, _ = rosgraph.Master(rospy.get_name()).getSystemState()
    return any(t == image_topic and set(nodes) - {rospy.get_name()} for t, nodes in subscribers)


def call_add(item, stamp_msg):
    """Calls the item's add service; returns (success, message)."""
    import rospy
    from geometry_msgs.msg import Point32
    from instant_motion_tracking.srv import AddAnchor, AddPlanarTarget, AddRegion
    srv = {"add_region": AddRegion, "add_planar_target": AddPlanarTarget, "add_anchor": AddAnchor}[item["service"]]
    if item["service"] == "add_planar_target":
        fields = {"corners": [Point32(x=c[0], y=c[1]) for c in item["corners"]],
                  "width_m": item["size"][0], "height_m": item["size"][1]}
    else:
        fields = item["fields"]
    try:
        res = rospy.ServiceProxy(item["service"], srv)(stamp=stamp_msg, id=item["id"], **fields)
    except (rospy.ServiceException, rospy.ROSException) as e:
        return False, str(e)
    return res.success, res.message


def run_live(args, truth, plan):
    import rosgraph
    import rospy
    from std_srvs.srv import SetBool
    if not rosgraph.is_master_online():
        raise DemoError("no ROS master at %s" % rosgraph.get_master_uri())

    def sim_time_set():
        try:
            return rosgraph.Master("/imt_demo").getParam("/use_sim_time") is True
        except (rosgraph.MasterException, OSError):  # not set yet, or the master not answering
            return False
    # The player's clock is read through rospy's sim time (player_at below),
    # which rospy takes up only where use_sim_time is set when the node
    # starts: replay.launch sets it, maybe after this script has started.
    if not wall_wait(sim_time_set, args.timeout, 0.1):
        raise DemoError("/use_sim_time was not set within %.0f s (is launch/replay.launch running?)" % args.timeout)
    rospy.init_node("imt_demo", anonymous=True, disable_signals=True)
    frames = truth["frames"]
    last_stamp = frames[-1]["stamp"]
    rec = Recorder(args.out, truth["fps"], args.image)

    def choose_strip(after):
        """Strip frames: evenly from a few frames after `after` to the end."""
        ks = [k for k, f in enumerate(frames) if f["stamp"] > after + 0.2] or [len(frames) - 1]
        picks = np.linspace(ks[0], ks[-1], STRIP_FRAMES).round().astype(int)
        rec.set_strip([frames[k]["stamp"] for k in picks])

    choose_strip(frames[0]["stamp"] - 1)  # until every item is added

    for name in ["add_region", "add_planar_target", "add_anchor"]:
        if any(i["service"] == name for i in plan):
            try:
                rospy.wait_for_service(name, timeout=args.timeout)
            except rospy.ROSException:
                raise DemoError("service %s did not appear within %.0f s (is launch/replay.launch "
                                "running? see the ROS logs)" % (rospy.resolve_name(name), args.timeout))
    # Connected to every output, then the lazy chain: our subscriptions ->
    # trackers -> motion_data -> the image.
    if not wall_wait(lambda: all(s.get_num_connections() > 0 for s in rec.subs[:4]), args.timeout, 0.1):
        raise DemoError("not connected to %s within %.0f s" % (
            ", ".join(s.name for s in rec.subs[:4] if s.get_num_connections() == 0), args.timeout))
    if not wall_wait(lambda: image_subscribed(args.image), args.timeout, 0.1):
        raise DemoError("nothing subscribed to %s within %.0f s: the graph did not connect"
                        % (args.image, args.timeout))
    time.sleep(1.0)  # the player connects to the new subscribers
    try:
        rospy.wait_for_service("/player/pause_playback", timeout=args.timeout)
        pause_srv = rospy.ServiceProxy("/player/pause_playback", SetBool)
    except rospy.ROSException as e:
        raise DemoError("no player service /player/pause_playback: %s" % e)

    def pause(on):
        """Pauses or resumes the player; False when it has gone (it exits at
        the bag's end)."""
        try:
            pause_srv(on)
            return True
        except (rospy.ServiceException, rospy.ROSException):
            return False

    def player_at():
        """The player's time (s, its /clock), None before its first. Not the
        images' arrival here: on a loaded machine this process receives the
        large image messages seconds after the player sent them."""
        t = rospy.get_rostime().to_sec()
        return t if t > 0 else None

    def settle():
        """Waits, the player paused, until the graph's regions have come for
        the last frame played, or none came for a second (a frame the graph
        dropped never comes); bounded by --timeout."""
        end = time.monotonic() + args.timeout
        seen, quiet_since = rec.latest_stamp(), time.monotonic()
        while time.monotonic() < end:
            latest, played = rec.latest_stamp(), player_at()
            if latest is not None and played is not None and latest >= played - 1.0 / truth["fps"] + 1e-6:
                return
            if latest != seen:
                seen, quiet_since = latest, time.monotonic()
            elif time.monotonic() - quiet_since > 1.0:
                return
            time.sleep(0.02)

    if not pause(False):
        raise DemoError("cannot resume the player (/player/pause_playback)")
    t0 = time.monotonic()
    print("demo_live: playing %d frames; adding %d items" % (len(frames), len(plan)), flush=True)

    pending, added, paused_s = list(plan), [], 0.0
    deadline = t0 + (last_stamp - frames[0]["stamp"]) / args.rate + args.timeout
    while time.monotonic() < deadline:
        played = player_at()
        at_end = played is not None and played >= last_stamp - 1e-6
        due = [i for i in pending if played is not None and (i["stamp"] + ADD_LAG_S <= played or at_end)]
        if due:
            # Paused while adding: on a loaded machine the graph (and this
            # recorder) may trail the player by seconds, and items added only
            # then would have few frames left to be tracked in.
            paused_at = time.monotonic()
            if pause(True):
                settle()
            latest = rec.latest_stamp()
            for item in due:
                stamp_msg = rec.stamps.get(round(item["stamp"], 6)) or rospy.Time.from_sec(item["stamp"])
                ok, msg = call_add(item, stamp_msg)
                added.append({"service": item["service"], "id": item["id"], "stamp": item["stamp"],
                              "success": ok, "message": msg, "at_latest": latest})
                print("demo_live: %s id %d at stamp %.6f (graph at %s): %s" % (
                    item["service"], item["id"], item["stamp"], "%.6f" % latest if latest is not None else "none",
                    msg if ok else "REFUSED: " + msg), flush=True)
                pending.remove(item)
            if not pending:
                choose_strip(latest if latest is not None else played)
            pause(False)
            paused_s += time.monotonic() - paused_at
        latest = rec.latest_stamp()
        if latest is not None and latest >= last_stamp - 1e-6 and not pending:
            break
        time.sleep(0.02)
    time.sleep(1.0)  # the last debug images and tf
    rec.close()
    with rec.lock:
        if not rec.data["regions"]:
            raise DemoError("no regions message arrived: the graph did not process the bag")
        return rec, added, time.monotonic() - t0, paused_s


# --- outputs -----------------------------------------------------------------

def write_strip(path, tiles):
    """Tiles the images 3 a row; a None (a frame that did not arrive) stays
    black. False when no image arrived at all."""
    import cv2
    images = [t for t in tiles if t is not None]
    if not images:
        return False
    h, w = images[0].shape[:2]
    cols = 3
    rows = (len(tiles) + cols - 1) // cols
    strip = np.zeros((rows * h, cols * w, 3), np.uint8)
    for i, img in enumerate(tiles):
        if img is not None and img.shape[:2] == (h, w):
            r, c = divmod(i, cols)
            strip[r * h:(r + 1) * h, c * w:(c + 1) * w] = img
    return cv2.imwrite(path, strip)


def write_csvs(out, rec):
    def num(v):
        return "" if v is None or (isinstance(v, float) and math.isnan(v)) else "%.6f" % v

    with open(os.path.join(out, "regions.csv"), "w") as f:
        f.write("stamp,id,x,y,width,height,status,confidence,angle,rect_width,rect_height\n")
        for stamp, states in rec["regions"]:
            for s in states:
                f.write("%.6f,%d,%s,%s,%s\n" % (stamp, s["id"], ",".join(num(v) for v in s["box"]),
                                                s["status"] + "," + num(s["confidence"]),
                                                ",".join(num(v) for v in s["rect"])))
    with open(os.path.join(out, "planar_targets.csv"), "w") as f:
        f.write("stamp,id,x0,y0,x1,y1,x2,y2,x3,y3,tx,ty,tz,qx,qy,qz,qw,status\n")
        for stamp, states in rec["planar_targets"]:
            for s in states:
                xy = [num(v) for c in s["corners"] for v in c]
                f.write("%.6f,%d,%s,%s,%s\n" % (stamp, s["id"], ",".join(xy), ",".join(num(v) for v in s["pose"]),
                                                s["status"]))
    with open(os.path.join(out, "anchors.csv"), "w") as f:
        f.write("stamp,id,u,v,tx,ty,tz,qx,qy,qz,qw,status\n")
        for stamp, states in rec["anchors"]:
            for s in states:
                f.write("%.6f,%d,%s,%s,%s,%s\n" % (stamp, s["id"], num(s["u"]), num(s["v"]),
                                                   ",".join(num(v) for v in s["pose"]), s["status"]))


def summarize(truth, plan, rec, added, seconds, args):
    data = rec.data
    n = len(truth["frames"])
    report = {"scene": {"preset": truth.get("preset"), "seed": truth.get("seed"), "frames": n,
                        "fps": truth["fps"], "rate": args.rate},
              "seconds": round(seconds, 2),
              "added": added,
              "frames_received": {k: len({round(s, 6) for s, _ in data[k]})
                                  for k in ("regions", "planar_targets", "anchors")},
              "tf_messages": data["tf"]}
    report["frames_received"]["debug_image"] = len({round(s, 6) for s in data["debug_image"]})
    got = {round(s, 6) for s in data["debug_image"]}
    report["debug_image_missing_frames"] = [k for k, f in enumerate(truth["frames"]) if round(f["stamp"], 6) not in got]
    statuses = {}
    for kind in ("regions", "planar_targets", "anchors"):
        counts = {}
        for _, states in data[kind]:
            for s in states:
                counts[s["status"]] = counts.get(s["status"], 0) + 1
        statuses[kind] = counts
    report["item_frames_by_status"] = statuses
    sc = score(truth, plan, data)
    acc = {"regions": {}, "planar_targets": {}, "anchors": {}}
    for rid, v in sorted(sc["regions"].items()):
        acc["regions"][str(rid)] = {"mean_iou": sum(v) / len(v), "frames": len(v)}
    all_iou = [x for v in sc["regions"].values() for x in v]
    acc["regions_mean_iou"] = sum(all_iou) / len(all_iou) if all_iou else None
    for tid, e in sorted(sc["planar_targets"].items()):
        acc["planar_targets"][str(tid)] = {"corner_error_median_px": pct(e, 0.5),
                                           "corner_error_p95_px": pct(e, 0.95), "frames": len(e)}
    for aid, e in sorted(sc["anchors"].items()):
        acc["anchors"][str(aid)] = {"pixel_error_median_px": pct(e, 0.5), "pixel_error_p95_px": pct(e, 0.95),
                                    "frames": len(e)}
    report["accuracy"] = acc
    report["latency_ms"] = {k: {"median": 1e3 * pct(v, 0.5), "p95": 1e3 * pct(v, 0.95)}
                            for k, v in rec.delays.items() if v}
    proc = {}
    for name, periods in sorted(rec.diagnostics.items()):
        def mean(key):
            vals = [float(p[key]) for p in periods if key in p]
            return sum(vals) / len(vals) if vals else None
        proc[name] = {"processing_ms": mean("processing mean (ms)"),
                      "delay_ms": mean("delay after the image stamp mean (ms)")}
    report["diagnostics"] = proc
    return report


def format_report(r, out):
    s = r["scene"]
    lines = ["instant_motion_tracking live demo: scene '%s' (seed %s), %d frames at %g fps, played at rate %g "
             "through launch/replay.launch in %.1f s (paused %.1f s of it for the adds)"
             % (s["preset"], s["seed"], s["frames"], s["fps"], s["rate"], r["seconds"],
                r.get("paused_for_the_adds_s", 0.0)), "",
             "Items added through the services (at a past stamp, the player paused; the trackers catch up):"]
    for a in r["added"]:
        lines.append("  %-18s id %d at stamp %.6f: %s" % (a["service"], a["id"], a["stamp"],
                                                           a["message"] if a["success"] else "REFUSED: " + a["message"]))
    lines += ["", "Frames received (of %d in the bag):" % s["frames"],
              "  " + ", ".join("%s %d" % kv for kv in r["frames_received"].items()) +
              ", /tf messages %d" % r["tf_messages"], "", "Item-frames by status:"]
    for kind, counts in r["item_frames_by_status"].items():
        lines.append("  %-15s %s" % (kind, ", ".join("%s %d" % kv for kv in sorted(counts.items())) or "none"))
    acc = r["accuracy"]
    lines += ["", "Accuracy against the scene's ground truth:"]
    for rid, a in acc["regions"].items():
        lines.append("  region %s: mean IoU %.3f over %d frames (at least half in view)" % (rid, a["mean_iou"],
                                                                                         a["frames"]))
    if acc["regions_mean_iou"] is not None:
        lines.append("  regions overall: mean IoU %.3f" % acc["regions_mean_iou"])
    for tid, a in acc["planar_targets"].items():
        lines.append("  planar target %s: corner error median %.2f px, p95 %.2f px over %d frames" % (
            tid, a["corner_error_median_px"], a["corner_error_p95_px"], a["frames"]))
    for aid, a in acc["anchors"].items():
        lines.append("  anchor %s: pixel error median %.2f px, p95 %.2f px over %d frames in view (unoccluded)" % (
            aid, a["pixel_error_median_px"], a["pixel_error_p95_px"], a["frames"]))
    if r["latency_ms"]:
        lines += ["", "Latency, from the input image's arrival here to the output's (wall time):"]
        lines += ["  %-15s median %.0f ms, p95 %.0f ms" % (k, v["median"], v["p95"]) for k, v in r["latency_ms"].items()]
    if r["diagnostics"]:
        lines += ["", "Processing time per frame (/diagnostics, mean over the reporting periods):",
                  "  " + ", ".join("%s %.2f ms" % (name.split(":")[0], d["processing_ms"])
                                   for name, d in r["diagnostics"].items() if d["processing_ms"] is not None)]
    if "overlay_check" in r:
        o = r["overlay_check"]
        lines += ["", "debug_image overlay: %d of %d tracked regions in the strip's frames drawn where the regions "
                  "topic has them at the frame's stamp" % (o["drawn_at_their_stamp"], o["regions_checked"])]
    lines += ["", "Files in %s: %s" % (out, " ".join(sorted(f for f in os.listdir(out) if "." in f)))]
    return "\n".join(lines) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--truth", required=True)
    p.add_argument("--init", required=True)
    p.add_argument("--out", required=True)
    p.add_argument("--image", default="/camera/image_raw", help="image topic the graph subscribes to")
    p.add_argument("--rate", type=float, default=1.0, help="the player's rate (for the deadline)")
    p.add_argument("--timeout", type=float, default=60.0, help="s to wait for the graph at each step")
    args = p.parse_args()
    try:
        truth = json.load(open(args.truth))
        init = yaml.safe_load(open(args.init))
        plan = make_plan(truth, init)
        os.makedirs(args.out, exist_ok=True)
        rec, added, seconds, paused_s = run_live(args, truth, plan)
        write_csvs(args.out, rec.data)
        tiles = rec.strip_tiles()
        if not write_strip(os.path.join(args.out, "strip.png"), tiles):
            raise DemoError("no debug_image frame of the strip's arrived (debug_image frames received: %d)"
                            % len(rec.data["debug_image"]))
        report = summarize(truth, plan, rec, added, seconds, args)
        report["paused_for_the_adds_s"] = round(paused_s, 2)
        report["strip_frames"] = sum(t is not None for t in tiles)
        checked, drawn, misses = overlay_check(rec.strip_images(), rec.data["regions"], rec.data["planar_targets"])
        report["overlay_check"] = {"regions_checked": checked, "drawn_at_their_stamp": drawn, "misses": misses}
        report["video"] = rec.video_path and os.path.basename(rec.video_path)
        with open(os.path.join(args.out, "report.json"), "w") as f:
            json.dump(report, f, indent=1)
        text = format_report(report, args.out)
        with open(os.path.join(args.out, "report.txt"), "w") as f:
            f.write(text)
        print(text, end="")
        refused = [a for a in added if not a["success"]]
        if refused:
            raise DemoError("%d item(s) refused by the services: %s" % (
                len(refused), "; ".join("%s %d: %s" % (a["service"], a["id"], a["message"]) for a in refused)))
        if len(added) < len(plan):
            raise DemoError("%d item(s) never added (the graph did not reach their stamps)" % (len(plan) - len(added)))
    except (DemoError, OSError, ValueError, KeyError, yaml.YAMLError) as e:
        print("demo_live: %s" % e, file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
