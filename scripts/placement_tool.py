#!/usr/bin/python3
"""Interactive placement: an OpenCV window on the live debug image.

  rosrun instant_motion_tracking placement_tool.py [_image:=debug_image] [_target_width:=0.3 _target_height:=0.2]
                                                   [_draw_states:=false]

  drag                 add_region (the dragged box)
  click                add_anchor at the pixel (needs the AnchorNodelet)
  p, then 4 clicks     add_planar_target, corners clicked TL, TR, BR, BL (size ~target_width/height, m)
  a                    back to anchor clicks;  c: cancel the pending clicks
  space                freeze / unfreeze the picture (place on a still frame)
  q, Esc               quit

Requests carry the stamp of the frame shown, so what is placed on a frozen
or late frame is placed where it was (the trackers accept stamps within
their cache, cache_seconds). debug_image already shows the regions, planar
targets and anchors of its frame; on another image (e.g. _image:=/camera/image_raw)
the latest ones are drawn over it (~draw_states, default: unless the image
is a debug_image). Services are called by their relative names
(remap or set ROS_NAMESPACE); a missing service (e.g. add_anchor without an
AnchorNodelet) is reported in the window and on the console.
Python 3 with python3-opencv and numpy; no cv_bridge.
"""
import sys

import numpy as np

DRAG_MIN_PX = 6  # a press and release closer than this is a click


class Placement:
    """Turns mouse events on the shown frame into service requests.

    No ROS and no GUI: each request is (service name, fields dict); the
    caller adds the stamp and calls the service."""

    def __init__(self, target_size=(0.3, 0.2), anchor_depth=0.0):
        self.target_size = target_size
        self.anchor_depth = anchor_depth
        self.mode = "anchor"  # what a click does: "anchor" or "planar"
        self.press = None     # where the button went down
        self.cursor = None
        self.clicks = []      # pending planar-target corners

    def set_mode(self, mode):
        self.mode = mode
        self.clicks = []

    def cancel(self):
        self.clicks = []
        self.press = None

    def down(self, x, y):
        self.press = (x, y)
        self.cursor = (x, y)

    def move(self, x, y):
        self.cursor = (x, y)

    def up(self, x, y):
        """Returns a request (service, fields) or None (more clicks needed)."""
        if self.press is None:
            return None
        x0, y0 = self.press
        self.press = None
        if abs(x - x0) >= DRAG_MIN_PX or abs(y - y0) >= DRAG_MIN_PX:
            return ("add_region", {"id": 0, "x": float(min(x, x0)), "y": float(min(y, y0)),
                                   "width": float(abs(x - x0)), "height": float(abs(y - y0))})
        if self.mode == "planar":
            self.clicks.append((float(x), float(y)))
            if len(self.clicks) < 4:
                return None
            corners, self.clicks = self.clicks, []
            return ("add_planar_target", {"id": 0, "corners": corners, "width_m": float(self.target_size[0]),
                                          "height_m": float(self.target_size[1])})
        return ("add_anchor", {"id": 0, "u": float(x), "v": float(y), "depth": float(self.anchor_depth)})

    def hint(self):
        if self.mode == "planar":
            names = ["TL", "TR", "BR", "BL"]
            return "planar target: click %s (%d of 4); c cancels, a: anchors" % (names[len(self.clicks)],
                                                                                 len(self.clicks) + 1)
        return "drag: region, click: anchor, p: planar target, space: freeze, q: quit"


def image_to_bgr(msg):
    """(BGR uint8 array, "") from a sensor_msgs/Image, or (None, why)."""
    channels = {"bgr8": 3, "rgb8": 3, "mono8": 1, "bgra8": 4, "rgba8": 4}
    if msg.encoding not in channels:
        return None, "unsupported encoding '%s' (bgr8, rgb8, mono8, bgra8, rgba8)" % msg.encoding
    c = channels[msg.encoding]
    if msg.width == 0 or msg.height == 0 or msg.step < msg.width * c or len(msg.data) < msg.step * msg.height:
        return None, "malformed image %dx%d, step %d, %d bytes" % (msg.width, msg.height, msg.step, len(msg.data))
    rows = np.frombuffer(msg.data, np.uint8, msg.step * msg.height).reshape(msg.height, msg.step)
    img = rows[:, :msg.width * c].reshape(msg.height, msg.width, c)
    if msg.encoding == "mono8":
        img = np.repeat(img, 3, axis=2)
    elif msg.encoding in ("rgb8", "rgba8"):
        img = img[:, :, 2::-1]
    elif msg.encoding == "bgra8":
        img = img[:, :, :3]
    return np.ascontiguousarray(img), ""


class ServiceCaller:
    """Calls the trackers' services by name; every failure becomes a message."""

    HINTS = {"add_region": "RegionTrackerNodelet", "add_planar_target": "PlanarTargetNodelet",
             "add_anchor": "AnchorNodelet"}

    def __init__(self, wait_for_service=None, proxy=None, resolve=None):
        import rospy
        self._rospy = rospy
        self._wait = wait_for_service or rospy.wait_for_service
        self._proxy = proxy or rospy.ServiceProxy
        self._resolve = resolve or rospy.resolve_name

    def call(self, service, srv_type, stamp, fields):
        """(success, message)."""
        from geometry_msgs.msg import Point32
        name = self._resolve(service)
        try:
            self._wait(name, timeout=1.0)
        except self._rospy.ROSException:
            return False, "service %s is not available: is the %s running?" % (name, self.HINTS.get(service, "tracker"))
        req = srv_type._request_class()
        req.stamp = stamp
        for key, value in fields.items():
            if key == "corners":
                value = [Point32(x=px, y=py) for px, py in value]
            setattr(req, key, value)
        try:
            res = self._proxy(name, srv_type)(req)
        except (self._rospy.ServiceException, self._rospy.ROSException) as e:
            return False, "%s failed: %s" % (name, e)
        return res.success, res.message


def draw_states(img, regions, targets, anchors):
    """The latest outputs of the trackers over the picture."""
    import cv2
    colors = {"tracked": (0, 255, 0), "featureless": (0, 255, 255), "out_of_view": (255, 128, 0), "lost": (0, 0, 255)}
    for r in regions.regions if regions else []:
        if not np.isfinite(r.x):
            continue
        c = colors.get(r.status, (255, 255, 255))
        cv2.rectangle(img, (int(r.x), int(r.y)), (int(r.x + r.width), int(r.y + r.height)), c, 2)
        cv2.putText(img, "r%d %s" % (r.id, r.status), (int(r.x), int(r.y) - 4), cv2.FONT_HERSHEY_SIMPLEX, 0.45, c, 1)
    for t in targets.targets if targets else []:
        if t.status == "lost":
            continue
        pts = np.array([[p.x, p.y] for p in t.corners], np.int32)
        cv2.polylines(img, [pts], True, (255, 0, 255), 2)
        cv2.putText(img, "t%d" % t.id, tuple(pts[0]), cv2.FONT_HERSHEY_SIMPLEX, 0.45, (255, 0, 255), 1)
    for a in anchors.anchors if anchors else []:
        cv2.drawMarker(img, (int(a.u), int(a.v)), (0, 200, 255), cv2.MARKER_CROSS, 16, 2)
        cv2.putText(img, "a%d %s" % (a.id, a.status), (int(a.u) + 6, int(a.v) - 6), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                    (0, 200, 255), 1)


def main():
    import os
    import threading

    import cv2
    import rospy
    from instant_motion_tracking.msg import AnchorArray, PlanarTargetArray, TrackedRegionArray
    from instant_motion_tracking.srv import AddAnchor, AddPlanarTarget, AddRegion
    from sensor_msgs.msg import Image

    if not os.environ.get("DISPLAY"):
        print("placement_tool: no DISPLAY: the tool needs a window (use rosservice call instead)", file=sys.stderr)
        return 1
    rospy.init_node("placement_tool", anonymous=True)
    placement = Placement((rospy.get_param("~target_width", 0.3), rospy.get_param("~target_height", 0.2)),
                          rospy.get_param("~anchor_depth", 0.0))
    caller = ServiceCaller()
    lock = threading.Lock()
    state = {"frame": None, "stamp": None, "regions": None, "targets": None, "anchors": None}

    def on_image(msg):
        img, why = image_to_bgr(msg)
        if img is None:
            rospy.logwarn_throttle(5.0, "placement_tool: dropping image: %s" % why)
            return
        with lock:
            if not state.get("frozen"):
                state["frame"], state["stamp"] = img, msg.header.stamp

    def keep(key):
        def cb(msg):
            with lock:
                state[key] = msg
        return cb

    image_topic = rospy.get_param("~image", "debug_image")
    draw = rospy.get_param("~draw_states", not image_topic.endswith("debug_image"))
    subs = [rospy.Subscriber(image_topic, Image, on_image, queue_size=1, buff_size=2 ** 24)]
    if draw:
        subs += [rospy.Subscriber("regions", TrackedRegionArray, keep("regions"), queue_size=1),
                 rospy.Subscriber("planar_targets", PlanarTargetArray, keep("targets"), queue_size=1),
                 rospy.Subscriber("anchors", AnchorArray, keep("anchors"), queue_size=1)]
    types = {"add_region": AddRegion, "add_planar_target": AddPlanarTarget, "add_anchor": AddAnchor}
    pending = []
    window = "instant_motion_tracking placement"
    cv2.namedWindow(window, cv2.WINDOW_AUTOSIZE | cv2.WINDOW_GUI_NORMAL)  # no toolbar: clicks are ours

    def on_mouse(event, x, y, flags, param):
        if event == cv2.EVENT_LBUTTONDOWN:
            placement.down(x, y)
        elif event == cv2.EVENT_MOUSEMOVE:
            placement.move(x, y)
        elif event == cv2.EVENT_LBUTTONUP:
            request = placement.up(x, y)
            if request:
                pending.append(request)

    cv2.setMouseCallback(window, on_mouse)
    status = "waiting for %s" % rospy.resolve_name(image_topic)
    while not rospy.is_shutdown():
        with lock:
            frame, stamp = state["frame"], state["stamp"]
            regions, targets, anchors = state["regions"], state["targets"], state["anchors"]
        while pending and stamp is not None:
            service, fields = pending.pop(0)
            ok, message = caller.call(service, types[service], stamp, fields)
            status = ("%s: %s" if ok else "%s FAILED: %s") % (service, message)
            (rospy.loginfo if ok else rospy.logerr)("placement_tool: " + status)
        if frame is not None:
            if status.startswith("waiting for"):
                status = "showing %s" % rospy.resolve_name(image_topic)
            img = frame.copy()
            draw_states(img, regions, targets, anchors)
            if placement.press and placement.cursor:
                cv2.rectangle(img, placement.press, placement.cursor, (255, 255, 0), 1)
            for i, (cx, cy) in enumerate(placement.clicks):
                cv2.circle(img, (int(cx), int(cy)), 4, (255, 0, 255), -1)
                cv2.putText(img, "TL TR BR BL".split()[i], (int(cx) + 5, int(cy) - 5), cv2.FONT_HERSHEY_SIMPLEX,
                            0.45, (255, 0, 255), 1)
            for row, text in enumerate([placement.hint() + ("  [frozen]" if state.get("frozen") else ""), status]):
                cv2.putText(img, text, (8, img.shape[0] - 28 + 18 * row), cv2.FONT_HERSHEY_SIMPLEX, 0.45,
                            (255, 255, 255), 1, cv2.LINE_AA)
            cv2.imshow(window, img)
        key = cv2.waitKey(30) & 0xFF
        if key in (ord("q"), 27):
            break
        if key == ord("p"):
            placement.set_mode("planar")
        elif key == ord("a"):
            placement.set_mode("anchor")
        elif key == ord("c"):
            placement.cancel()
        elif key == ord(" "):
            with lock:
                state["frozen"] = not state.get("frozen")
    for s in subs:
        s.unregister()
    cv2.destroyAllWindows()
    return 0


if __name__ == "__main__":
    sys.exit(main())
