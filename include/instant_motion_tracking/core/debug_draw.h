// Debug overlays for the `debug_image` topic and the demo: features coloured
// by foreground (red) / background (green) with their motion vectors, the
// camera model's name, and the trackers' outputs (region boxes, planar-target
// quads, anchors) with their ids and statuses. Pure OpenCV; pixel coordinates
// as in docs/conventions.md.
//
//   cv::Mat bgr = drawMotionData(gray, md);
//   OverlayHistory history;                       // fed from the tracker outputs
//   history.addRegions(stamp, regions);
//   drawOverlay(&bgr, history.select(md.stamp));  // the states of that frame
//
// Threading: free functions are reentrant; OverlayHistory is not synchronised.
#pragma once

#include "instant_motion_tracking/core/anchor/anchor_manager.h"
#include "instant_motion_tracking/core/planar/planar_target.h"
#include "instant_motion_tracking/core/region/region_tracker.h"
#include "instant_motion_tracking/core/types.h"

#include <deque>
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

// Recent tracker outputs by image stamp, to draw each frame with the states
// computed from it. The trackers publish after the image has been analysed,
// so a frame waits for them (complete()) or is drawn with the latest states
// not older than `max_age_s` (select()).
class OverlayHistory {
 public:
  // max_age_s: states older than this before the frame are not drawn (s).
  // depth: states kept per kind (frames).
  explicit OverlayHistory(double max_age_s = 0.5, size_t depth = 30)
      : max_age_s_(max_age_s), depth_(depth) {}

  void addRegions(double stamp, std::vector<RegionState> states);
  void addTargets(double stamp, std::vector<PlanarTargetState> states);
  void addAnchors(double stamp, std::vector<AnchorState> states);

  // Per kind: the states of exactly `stamp` if received, else the latest
  // received no later than `stamp` and not older than max_age_s; else none.
  DebugOverlay select(double stamp) const;
  // True when every kind heard from within max_age_s before `stamp` has its
  // states of exactly `stamp` (a tracker that is not running is not awaited).
  bool complete(double stamp) const;
  // Forgets everything (time jumped backwards: a looping bag).
  void clear();

 private:
  template <class T>
  struct Entry {
    double stamp;
    std::vector<T> states;
  };
  template <class T>
  void add(std::deque<Entry<T>>* q, double stamp, std::vector<T> states);
  template <class T>
  const std::vector<T>* pick(const std::deque<Entry<T>>& q, double stamp) const;
  template <class T>
  bool ready(const std::deque<Entry<T>>& q, double stamp) const;

  double max_age_s_;
  size_t depth_;
  std::deque<Entry<RegionState>> regions_;
  std::deque<Entry<PlanarTargetState>> targets_;
  std::deque<Entry<AnchorState>> anchors_;
};

}  // namespace imt
