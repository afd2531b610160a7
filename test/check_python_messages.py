#!/usr/bin/env python3
"""Every message and service of the interface spec is generated for Python
and carries the fields the spec names."""
import sys

from instant_motion_tracking import msg, srv

SPEC = {
    msg.MotionData: ["header", "width", "height", "analysis_scale", "model", "homography", "ids", "x", "y",
                     "dx", "dy", "background_weight", "foreground", "age"],
    msg.TrackedRegion: ["id", "x", "y", "width", "height", "status", "confidence"],
    msg.TrackedRegionArray: ["header", "regions"],
    msg.PlanarTarget: ["id", "corners", "pose", "status"],
    msg.PlanarTargetArray: ["header", "targets"],
    msg.Anchor: ["id", "u", "v", "pose", "status"],
    msg.AnchorArray: ["header", "anchors"],
    srv.AddRegionRequest: ["stamp", "id", "x", "y", "width", "height"],
    srv.AddRegionResponse: ["id", "success", "message"],
    srv.RemoveRegionRequest: ["id"],
    srv.RemoveRegionResponse: ["success", "message"],
    srv.SeekRegionsRequest: ["stamp", "ids"],
    srv.SeekRegionsResponse: ["regions", "success", "message"],
    srv.AddPlanarTargetRequest: ["stamp", "id", "corners", "width_m", "height_m"],
    srv.AddPlanarTargetResponse: ["id", "success", "message"],
    srv.AddAnchorRequest: ["stamp", "id", "u", "v", "depth"],
    srv.AddAnchorResponse: ["id", "success", "message"],
}

missing = [f"{cls.__name__}.{f}" for cls, fields in SPEC.items() for f in fields
           if f not in cls.__slots__]
if missing:
    print("missing fields:", ", ".join(missing))
    sys.exit(1)
print(f"{len(SPEC)} Python message/service types generated with the spec's fields")
