#!/usr/bin/python3
"""Mutants of seed bags and INIT files for scripts/fuzz.sh (issue 16).

  fuzz_mutate.py --seeds DIR --out DIR --cases N [--seed S]

DIR holds seed pairs NAME.bag + NAME.yaml (make_scene --init). Writes
case_NNNN.bag and case_NNNN.yaml for N cases, and manifest.tsv (case, seed
pair, kind: bytes / messages / init / both, what was mutated). Seeded: the same arguments give the same files.

Each case mutates the bag, the INIT file or both:
  bag bytes    truncation, bit flips, a range overwritten or zeroed;
  bag messages (read and written again with rosbag) image size, step,
               encoding and data length; compressed format and data; header
               stamps (duplicated, a little or far back, far forward, zero);
               camera_info K and D; IMU values (NaN, inf, 1e300); /tf_static
               frames and quaternions; a topic dropped; messages reordered;
  INIT         a field set to a value of another type or out of range, a
               field dropped or an unknown one added, ids duplicated, corners
               wound the other way, thousands of items; the text truncated or
               with bytes inserted.
"""
import argparse
import copy
import math
import os
import random
import sys

import rosbag
import yaml

WEIRD_VALUES = [None, "", "abc", [], {}, [1], [1, 2, 3, 4, 5], float("nan"), float("inf"), float("-inf"),
                1e308, -1e308, 0, -1, 2 ** 63, 1e-300, True, [[1, 2], [3]], {"x": 1}, "1e999"]
ENCODINGS = ["mono8", "mono16", "bgr8", "rgb8", "bgra8", "rgba8", "yuv422", "32FC1", "16UC1", "", "MONO8",
             "bayer_rggb8", "mono8\x00junk", "\xff\xfe"]
U32 = 2 ** 32 - 1


def u32(rng):
    return rng.choice([0, 1, 2, 3, 7, 64, 65535, 2 ** 16 + 1, 2 ** 31 - 1, 2 ** 31, U32])


# --- bag bytes ---------------------------------------------------------------

def mutate_bytes(data, rng):
    data = bytearray(data)
    kind = rng.choice(["truncate", "bitflip", "overwrite", "zero"])
    if kind == "truncate":
        cut = rng.randrange(0, len(data))
        return bytes(data[:cut]), f"truncated at {cut} of {len(data)} bytes"
    if kind == "bitflip":
        n = rng.choice([1, 2, 8, 64])
        for _ in range(n):
            i = rng.randrange(len(data))
            data[i] ^= 1 << rng.randrange(8)
        return bytes(data), f"{n} bits flipped"
    start = rng.randrange(len(data))
    length = min(len(data) - start, rng.choice([1, 4, 16, 256, 4096]))
    fill = bytes(rng.randrange(256) for _ in range(length)) if kind == "overwrite" else bytes(length)
    data[start:start + length] = fill
    return bytes(data), f"{length} bytes {'overwritten' if kind == 'overwrite' else 'zeroed'} at {start}"


# --- bag messages ------------------------------------------------------------

def edit_image(msg, rng):
    what = rng.choice(["width", "height", "step", "encoding", "data", "bigendian"])
    if what in ("width", "height", "step"):
        setattr(msg, what, u32(rng))
    elif what == "encoding":
        msg.encoding = rng.choice(ENCODINGS)
    elif what == "data":
        n = len(msg.data)
        msg.data = msg.data[:rng.randrange(0, max(1, n))] if rng.random() < 0.7 else msg.data + b"\x00" * 100
    else:
        msg.is_bigendian = 1 - msg.is_bigendian
    return f"image {what}"


def edit_compressed(msg, rng):
    what = rng.choice(["format", "data", "garbage"])
    if what == "format":
        msg.format = rng.choice(["", "jpeg", "png", "rgb8; compressedDepth png", "tiff", "\xff"])
    elif what == "data":
        msg.data = msg.data[:rng.randrange(0, max(1, len(msg.data)))]
    else:
        msg.data = bytes(rng.randrange(256) for _ in range(rng.choice([0, 1, 100, 5000])))
    return f"compressed {what}"


def edit_camera_info(msg, rng):
    what = rng.choice(["K", "D", "size", "model"])
    if what == "K":
        k = list(msg.K)
        k[rng.randrange(9)] = rng.choice([0.0, -500.0, float("nan"), float("inf"), 1e300, 1e-300])
        msg.K = k
    elif what == "D":
        msg.D = [rng.choice([0.0, 1e10, float("nan"), -5.0]) for _ in range(rng.choice([0, 1, 5, 8, 14, 100]))]
    elif what == "size":
        msg.width, msg.height = u32(rng), u32(rng)
    else:
        msg.distortion_model = rng.choice(["", "plumb_bob", "equidistant", "rational_polynomial", "fisheye", "x"])
    return f"camera_info {what}"


def edit_imu(msg, rng):
    value = rng.choice([float("nan"), float("inf"), -float("inf"), 1e300, -1e30, 0.0])
    vec = rng.choice(["angular_velocity", "linear_acceleration", "orientation"])
    setattr(getattr(msg, vec), rng.choice(["x", "y", "z"]), value)
    return f"imu {vec} = {value}"


def edit_tf(msg, rng):
    if not msg.transforms:
        return "tf (empty)"
    t = rng.choice(msg.transforms)
    what = rng.choice(["frame", "child", "quaternion", "translation"])
    if what == "frame":
        t.header.frame_id = rng.choice(["", "/", "camera_optical_frame", "\xff"])
    elif what == "child":
        t.child_frame_id = rng.choice(["", t.header.frame_id, "imu_link", "x" * 300])
    elif what == "quaternion":
        q = t.transform.rotation
        q.x, q.y, q.z, q.w = rng.choice([(0, 0, 0, 0), (float("nan"), 0, 0, 1), (1e300, 0, 0, 1), (0, 0, 0, -1)])
    else:
        t.transform.translation.x = rng.choice([float("nan"), 1e300])
    return f"tf_static {what}"


def edit_stamp(msg, rng, previous):
    import rospy
    kind = rng.choice(["duplicate", "back_little", "back_far", "forward_far", "zero", "max"])
    s = msg.header.stamp
    if kind == "duplicate" and previous is not None:
        msg.header.stamp = previous
    elif kind == "back_little":
        msg.header.stamp = rospy.Time(max(0.0, s.to_sec() - 0.003))
    elif kind == "back_far":
        msg.header.stamp = rospy.Time(max(0.0, s.to_sec() - 500))
    elif kind == "forward_far":
        msg.header.stamp = rospy.Time(s.to_sec() + 1e5)
    elif kind == "zero":
        msg.header.stamp = rospy.Time(0)
    else:
        msg.header.stamp = rospy.Time(2 ** 31 - 1)
    return f"stamp {kind}"


def mutate_messages(src, dst, rng):
    with rosbag.Bag(src) as bag:
        entries = list(bag.read_messages())
    if not entries:
        raise ValueError("empty seed bag")
    notes = []
    kind = rng.choice(["edit", "edit", "edit", "stamps", "drop_topic", "reorder"])
    if kind == "drop_topic":
        topic = rng.choice(sorted({e.topic for e in entries}))
        entries = [e for e in entries if e.topic != topic]
        notes.append(f"topic {topic} dropped")
    elif kind == "reorder":
        i, j = rng.randrange(len(entries)), rng.randrange(len(entries))
        entries[i], entries[j] = entries[j], entries[i]
        notes.append("two messages swapped")
    msgs = [[e.topic, copy.deepcopy(e.message), e.timestamp] for e in entries]
    if kind in ("edit", "stamps"):
        topics = sorted({m[0] for m in msgs})
        for _ in range(rng.choice([1, 1, 2, 5])):
            # A topic first (the IMU's 200 messages a second would win every draw), then one of its messages.
            topic = rng.choice(topics)
            idx = rng.choice([i for i, m in enumerate(msgs) if m[0] == topic])
            topic, msg, _t = msgs[idx]
            t = msg._type
            if kind == "stamps" and hasattr(msg, "header"):
                prev = msgs[idx - 1][1].header.stamp if idx > 0 and hasattr(msgs[idx - 1][1], "header") else None
                notes.append(edit_stamp(msg, rng, prev))
            elif t == "sensor_msgs/Image":
                notes.append(edit_image(msg, rng))
            elif t == "sensor_msgs/CompressedImage":
                notes.append(edit_compressed(msg, rng))
            elif t == "sensor_msgs/CameraInfo":
                notes.append(edit_camera_info(msg, rng))
            elif t == "sensor_msgs/Imu":
                notes.append(edit_imu(msg, rng))
            elif t == "tf2_msgs/TFMessage":
                notes.append(edit_tf(msg, rng))
    with rosbag.Bag(dst, "w") as out:
        for topic, msg, t in msgs:
            out.write(topic, msg, t)
    return "; ".join(notes) or kind


# --- INIT --------------------------------------------------------------------

def mutate_init(text, rng):
    if rng.random() < 0.25:
        data = bytearray(text.encode())
        kind = rng.choice(["truncate", "insert", "replace"])
        i = rng.randrange(max(1, len(data)))
        if kind == "truncate":
            data = data[:i]
        elif kind == "insert":
            data[i:i] = bytes(rng.choice(b"{}[]:,-\t\n'\"&*!|>%@`\x00\xff") for _ in range(rng.choice([1, 3])))
        else:
            data[i:i + 1] = bytes([rng.randrange(256)])
        return bytes(data), f"INIT text {kind} at {i}"
    doc = yaml.safe_load(text)
    kinds = [k for k in ("regions", "planar_targets", "anchors") if isinstance(doc, dict) and doc.get(k)]
    if not kinds:
        return text.encode(), "INIT unchanged (no items)"
    key = rng.choice(kinds)
    items = doc[key]
    item = rng.choice(items)
    kind = rng.choice(["value", "value", "value", "drop", "unknown", "dup_id", "winding", "many", "nested"])
    if kind == "value":
        field = rng.choice(sorted(item))
        item[field] = copy.deepcopy(rng.choice(WEIRD_VALUES))
        note = f"{key} {field} = {item[field]!r}"
    elif kind == "drop":
        field = rng.choice(sorted(item))
        del item[field]
        note = f"{key} {field} dropped"
    elif kind == "unknown":
        item[rng.choice(["colour", "Id", "box ", "extra"])] = 1
        note = f"{key} unknown field"
    elif kind == "dup_id":
        items.append(copy.deepcopy(item))
        note = f"{key} id duplicated"
    elif kind == "winding" and "corners" in item and isinstance(item["corners"], list):
        item["corners"] = list(reversed(item["corners"]))
        note = f"{key} corners reversed"
    elif kind == "many":
        n = rng.choice([1000, 5000])
        doc[key] = [dict(copy.deepcopy(item), id=i + 1) for i in range(n)]
        note = f"{key} x{n}"
    elif kind == "nested":
        doc[key] = rng.choice([item, "x", 5, None, [items]])
        note = f"{key} replaced by {type(doc[key]).__name__}"
    else:
        note = f"{key} unchanged"
    return yaml.safe_dump(doc, allow_unicode=False).encode(), "INIT " + note


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", required=True)
    ap.add_argument("--out", required=True)
    ap.add_argument("--cases", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    seeds = sorted(f[:-4] for f in os.listdir(a.seeds) if f.endswith(".bag"))
    if not seeds:
        sys.exit(f"fuzz_mutate.py: no seed bags in {a.seeds}")
    os.makedirs(a.out, exist_ok=True)
    rng = random.Random(a.seed)
    with open(os.path.join(a.out, "manifest.tsv"), "w") as manifest:
        for c in range(a.cases):
            name = rng.choice(seeds)
            base = os.path.join(a.out, f"case_{c:04d}")
            with open(os.path.join(a.seeds, name + ".bag"), "rb") as f:
                bag = f.read()
            with open(os.path.join(a.seeds, name + ".yaml")) as f:
                init = f.read()
            notes = []
            which = rng.choice(["bytes", "messages", "messages", "init", "init", "both"])
            if which in ("bytes", "both"):
                bag, note = mutate_bytes(bag, rng)
                notes.append(note)
            if which == "messages":
                notes.append(mutate_messages(os.path.join(a.seeds, name + ".bag"), base + ".bag", rng))
            else:
                with open(base + ".bag", "wb") as f:
                    f.write(bag)
            init_bytes = init.encode()
            if which in ("init", "both"):
                init_bytes, note = mutate_init(init, rng)
                notes.append(note)
            with open(base + ".yaml", "wb") as f:
                f.write(init_bytes)
            manifest.write(f"case_{c:04d}\t{name}\t{which}\t{' | '.join(notes)}\n")


if __name__ == "__main__":
    main()
