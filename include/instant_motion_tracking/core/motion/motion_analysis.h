// Motion analysis (paper 3.1): corner features tracked frame to frame with
// persistent IDs, the camera (background) motion model chosen per frame, every
// feature classed foreground/background, packed as MotionData.
//
// Usage:
//   imt::MotionAnalyzer analyzer(options.motion_analysis);
//   imt::MotionData md = analyzer.process(gray, stamp);   // once per frame, in stamp order
//
// Per frame: the image is downscaled to `analysis_width` (never upscaled);
// FeatureTracker tracks the grid-spread corners (pyramidal LK, selective
// forward-backward check, refills empty cells); CameraMotionEstimator fits
// translation / similarity / homography by IRLS, favouring features that were
// background last frame, and picks the highest model within its bounds; each
// feature's residual against that model, accumulated over a few frames, gives
// its background weight and foreground flag.
//
// MotionData (full-resolution pixels, origin at the top-left pixel corner):
//   camera.H      previous -> current, H(2,2) = 1; identity when `invalid`
//                 (first frame, after a reset, too few or unstable features).
//   features[i]   x, y: current position; dx, dy = current - H * previous
//                 (the motion with the camera's removed; ~0 on the background);
//                 age: frames tracked, 0 = detected in this frame (dx = dy = 0,
//                 no motion measured; bg_weight is its grid cell's average);
//                 bg_weight in [0, 1] and foreground = bg_weight <
//                 foreground_threshold. With an invalid model bg_weight is 1.
//
// A frame size change, a stamp that does not increase, or an unusable image
// (empty, not CV_8UC1, smaller than 16 px) resets the feature tracks (the
// result is then `invalid`, like a first frame); `lastReset()` says why, so
// the caller can log it once. Nothing here throws on image content.
// Threading: not thread-safe; one analyzer per image stream.
#pragma once

#include "instant_motion_tracking/core/motion/camera_motion_estimator.h"
#include "instant_motion_tracking/core/motion/feature_tracker.h"
#include "instant_motion_tracking/core/options.h"
#include "instant_motion_tracking/core/types.h"

#include <memory>
#include <string>

namespace imt {

class MotionAnalyzer {
 public:
  // Throws std::invalid_argument on invalid options (validate()).
  explicit MotionAnalyzer(const MotionAnalysisOptions& options);
  ~MotionAnalyzer();
  MotionAnalyzer(MotionAnalyzer&&) noexcept;
  MotionAnalyzer& operator=(MotionAnalyzer&&) noexcept;

  // Analyses one frame (CV_8UC1, any size). Never throws on image content.
  MotionData process(const cv::Mat& gray, double stamp);
  // Forgets all tracks; the next frame is treated as a first frame.
  void reset();
  // Why the last process() call reset the tracks ("" when it did not).
  const std::string& lastReset() const;
  const MotionAnalysisOptions& options() const;

  // What the last process() call did: feature bookkeeping and every camera
  // model's verdict (for logs, debug overlays and tests).
  struct Diagnostics {
    FeatureTracker::Stats tracking;
    CameraMotionEstimate estimate;
  };
  const Diagnostics& diagnostics() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace imt
