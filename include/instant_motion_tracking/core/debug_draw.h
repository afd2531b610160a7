// Debug overlays for the `debug_image` topic and the demo: features coloured
// by foreground (red) / background (green) with their motion vectors, the
// camera model's name, and the trackers' outputs (region boxes, planar-target
// quads, anchors) with their ids and statuses. Pure OpenCV; pixel coordinates
// as in docs/conventions.md.
//
//   cv::Mat bgr = drawMotionData(gray, md);
//   drawOverlay(&bgr, {result.regions, result.targets, result.anchors, result.camera});
//                                                 // a TrackingSession's FrameResult
//
// Threading: reentrant.
#pragma once

#include "instant_motion_tracking/core/anchor/anchor_manager.h"
#include "instant_motion_tracking/core/planar/planar_target.h"
#include "instant_motion_tracking/core/region/region_tracker.h"
#include "instant_motion_tracking/core/types.h"

#include <vector>

namespace imt {

// Returns a BGR copy of `gray` (CV_8UC1) with the motion data drawn on it.
// Vectors are drawn `vector_scale` times their length (they are small).
cv::Mat drawMotionData(const cv::Mat& gray, const MotionData& md, double vector_scale = 3.0);

// The tracker outputs drawn over one frame.
struct DebugOverlay {
  std::vector<RegionState> regions;
  std::vector<PlanarTargetState> targets;
  std::vector<AnchorState> anchors;
  // Projects the 3D axes of targets and anchors (through its distortion);
  // without a valid model anchors get a marker only and targets their quad only.
  CameraModel intrinsics;
};

// Colours (BGR) of the overlay, by item kind; out-of-view and featureless
// items are drawn at half intensity, lost items are not drawn.
inline const cv::Scalar kRegionColour(0, 220, 255);        // yellow
inline const cv::Scalar kPlanarTargetColour(255, 0, 255);  // magenta
inline const cv::Scalar kAnchorColour(255, 255, 0);        // cyan

// Draws `overlay` into `bgr` (CV_8UC3, the frame the states belong to):
// region boxes with "id status", planar-target quads (TL corner marked) with
// "P<id>" and their axes, anchors as a ringed dot with "A<id>" and their axes
// (x red, y green, z blue; 10% of the anchor's distance long). Items whose
// geometry is not finite are skipped.
void drawOverlay(cv::Mat* bgr, const DebugOverlay& overlay);

}  // namespace imt
