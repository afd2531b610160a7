#!/usr/bin/env python3
"""Scores track_bag's CSV output against make_scene's ground truth.

usage: evaluate.py TRUTH.json OUT_DIR

Prints, per region, the mean IoU over the frames where the region is at least
half in view (boxes clipped to the image), per planar target the median corner
error, and for the camera motion the median and 95th-percentile transfer error
of the estimated homography over a grid of points (frames with a planar
background), and per anchor the median pixel and range errors while in view.
Standard library only.
"""
import csv
import json
import math
import os
import sys


def clip(b, w, h):
    x0, y0 = max(0.0, b[0]), max(0.0, b[1])
    x1, y1 = min(w, b[0] + b[2]), min(h, b[1] + b[3])
    return [x0, y0, max(0.0, x1 - x0), max(0.0, y1 - y0)]


def iou(a, b):
    ix = max(0.0, min(a[0] + a[2], b[0] + b[2]) - max(a[0], b[0]))
    iy = max(0.0, min(a[1] + a[3], b[1] + b[3]) - max(a[1], b[1]))
    inter = ix * iy
    union = a[2] * a[3] + b[2] * b[3] - inter
    return inter / union if union > 0 else 0.0


def apply(H, x, y):
    d = H[6] * x + H[7] * y + H[8]
    return (H[0] * x + H[1] * y + H[2]) / d, (H[3] * x + H[4] * y + H[5]) / d


def pct(v, p):
    v = sorted(v)
    return v[int(p * (len(v) - 1))] if v else float("nan")


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    truth = json.load(open(sys.argv[1]))
    out = sys.argv[2]
    w, h = truth["width"], truth["height"]
    frame_of = {round(f["stamp"], 6): f for f in truth["frames"]}

    def frame(stamp):
        return frame_of.get(round(float(stamp), 6))

    # Camera motion: transfer error over a 10 x 8 grid.
    errors = []
    for row in csv.DictReader(open(os.path.join(out, "camera_motion.csv"))):
        f = frame(row["stamp"])
        if not f or f["background_homography"] is None or row["model"] == "invalid":
            continue
        H = [float(row[k]) for k in ("h00", "h01", "h02", "h10", "h11", "h12", "h20", "h21", "h22")]
        G = f["background_homography"]
        for i in range(10):
            for j in range(8):
                x, y = (i + 0.5) * w / 10, (j + 0.5) * h / 8
                ex, ey = apply(H, x, y)
                gx, gy = apply(G, x, y)
                errors.append(math.hypot(ex - gx, ey - gy))
    if errors:
        print(f"camera motion: transfer error median {pct(errors, 0.5):.3f} px, p95 {pct(errors, 0.95):.3f} px")

    scores = {}
    for row in csv.DictReader(open(os.path.join(out, "regions.csv"))):
        f = frame(row["stamp"])
        gt = f and next((r for r in f["regions"] if r["id"] == int(row["id"])), None)
        if not gt or gt["visible_fraction"] < 0.5:
            continue
        box = [float(row[k]) for k in ("x", "y", "width", "height")] if row["x"] else None
        s = iou(clip(box, w, h), clip(gt["box"], w, h)) if box else 0.0
        scores.setdefault(int(row["id"]), []).append(s)
    for rid, s in sorted(scores.items()):
        print(f"region {rid}: mean IoU {sum(s) / len(s):.3f} over {len(s)} frames")

    corner = {}
    for row in csv.DictReader(open(os.path.join(out, "planar_targets.csv"))):
        f = frame(row["stamp"])
        gt = f and next((t for t in f["planar_targets"] if t["id"] == int(row["id"])), None)
        if not gt or not row["x0"]:
            continue
        e = [math.hypot(float(row[f"x{i}"]) - gt["corners"][i][0], float(row[f"y{i}"]) - gt["corners"][i][1])
             for i in range(4)]
        corner.setdefault(int(row["id"]), []).append(math.sqrt(sum(x * x for x in e) / 4))
    for tid, e in sorted(corner.items()):
        print(f"planar target {tid}: corner error median {pct(e, 0.5):.2f} px, last frame {e[-1]:.2f} px")
    score_anchors(truth, out, frame)


def score_anchors(truth, out, frame):
    px, rng = {}, {}
    for row in csv.DictReader(open(os.path.join(out, "anchors.csv"))):
        f = frame(row["stamp"])
        gt = f and next((a for a in f["anchors"] if a["id"] == int(row["id"])), None)
        if not gt or not gt["in_view"] or not row["u"]:
            continue
        aid = int(row["id"])
        px.setdefault(aid, []).append(math.hypot(float(row["u"]) - gt["pixel"][0], float(row["v"]) - gt["pixel"][1]))
        est = math.sqrt(sum(float(row[k]) ** 2 for k in ("tx", "ty", "tz")))
        rng.setdefault(aid, []).append(abs(est / math.sqrt(sum(x * x for x in gt["t"])) - 1))
    for aid in sorted(px):
        print(f"anchor {aid}: pixel error median {pct(px[aid], 0.5):.2f} px in view, "
              f"range error median {100 * pct(rng[aid], 0.5):.1f}%")


if __name__ == "__main__":
    main()
