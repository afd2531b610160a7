#!/usr/bin/env python3
"""scripts/placement_tool.py without a window or a master: mouse events become
the right service requests, images of each encoding convert (bad ones are
refused with a reason), and a missing service becomes a clear message."""
import importlib.util
import os
import sys

import numpy as np
import rospy
from instant_motion_tracking.srv import AddAnchor, AddRegion
from sensor_msgs.msg import Image

HERE = os.path.dirname(os.path.abspath(__file__))
spec = importlib.util.spec_from_file_location("placement_tool", os.path.join(HERE, "..", "scripts", "placement_tool.py"))
tool = importlib.util.module_from_spec(spec)
spec.loader.exec_module(tool)

failures = []


def check(cond, what):
    if not cond:
        failures.append(what)


# Drag (any direction) -> add_region with a positive box.
p = tool.Placement(target_size=(0.5, 0.4))
p.down(200, 150)
p.move(120, 100)
check(p.up(100, 90) == ("add_region", {"id": 0, "x": 100.0, "y": 90.0, "width": 100.0, "height": 60.0}),
      "drag up-left: add_region 100,90 100x60")
# A release within DRAG_MIN_PX is a click -> add_anchor at the release pixel.
p.down(300, 200)
check(p.up(302, 203) == ("add_anchor", {"id": 0, "u": 302.0, "v": 203.0, "depth": 0.0}), "click: add_anchor")
# Planar mode: three clicks ask for more, the fourth gives the target in click order.
p.set_mode("planar")
corners = [(10, 10), (110, 12), (108, 90), (12, 88)]
results = []
for x, y in corners:
    p.down(x, y)
    results.append(p.up(x, y))
check(results[:3] == [None, None, None], "planar: no request before the fourth click")
check(results[3] == ("add_planar_target", {"id": 0, "corners": [(float(x), float(y)) for x, y in corners],
                                           "width_m": 0.5, "height_m": 0.4}), "planar: four corners + size")
check(p.clicks == [], "planar: clicks consumed")
# A drag in planar mode is still a region; cancel drops pending clicks.
p.down(0, 0)
p.up(5, 1)
check(len(p.clicks) == 1, "planar: a small move is a click")
p.cancel()
check(p.clicks == [], "cancel")
check(p.up(1, 1) is None, "release without press: nothing")


def image(encoding, w, h, step, data):
    m = Image()
    m.encoding, m.width, m.height, m.step, m.data = encoding, w, h, step, bytes(data)
    return m


px = np.arange(2 * 3 * 3, dtype=np.uint8).reshape(2, 3, 3)
img, why = tool.image_to_bgr(image("bgr8", 3, 2, 9, px.tobytes()))
check(img is not None and (img == px).all(), "bgr8 " + why)
img, _ = tool.image_to_bgr(image("rgb8", 3, 2, 9, px.tobytes()))
check(img is not None and (img == px[:, :, ::-1]).all(), "rgb8 swapped")
padded = np.zeros((2, 4), np.uint8)
padded[:, :3] = [[1, 2, 3], [4, 5, 6]]
img, _ = tool.image_to_bgr(image("mono8", 3, 2, 4, padded.tobytes()))
check(img is not None and img.shape == (2, 3, 3) and img[1, 2, 0] == 6, "mono8 with row padding")
img, why = tool.image_to_bgr(image("16UC1", 3, 2, 6, bytes(12)))
check(img is None and "unsupported encoding '16UC1'" in why, "16UC1 refused: " + why)
img, why = tool.image_to_bgr(image("bgr8", 3, 2, 9, bytes(10)))
check(img is None and "malformed" in why, "short data refused: " + why)


# A missing service (no AnchorNodelet) is a message, not an exception.
def missing(name, timeout):
    raise rospy.ROSException("timeout exceeded while waiting for service %s" % name)


caller = tool.ServiceCaller(wait_for_service=missing, resolve=lambda n: "/" + n)
ok, message = caller.call("add_anchor", AddAnchor, rospy.Time(1000), {"id": 0, "u": 1.0, "v": 2.0, "depth": 0.0})
check(not ok and message == "service /add_anchor is not available: is the AnchorNodelet running?", message)


# A present service gets the fields and the stamp.
class Proxy:
    def __init__(self, name, srv_type):
        self.name = name

    def __call__(self, req):
        Proxy.req = req
        return AddRegion._response_class(id=4, success=True, message="tracking region 4")


caller = tool.ServiceCaller(wait_for_service=lambda n, timeout: None, proxy=Proxy, resolve=lambda n: "/ns/" + n)
ok, message = caller.call("add_region", AddRegion, rospy.Time(1000.5),
                          {"id": 0, "x": 1.0, "y": 2.0, "width": 30.0, "height": 40.0})
check(ok and message == "tracking region 4", "add_region call")
check(Proxy.req.stamp == rospy.Time(1000.5) and Proxy.req.width == 30.0, "add_region request fields")

for f in failures:
    print("FAIL:", f)
print("%d failures" % len(failures))
sys.exit(1 if failures else 0)
