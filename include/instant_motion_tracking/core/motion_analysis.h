// Motion analysis (paper 3.1): corner features tracked frame to frame with
// persistent IDs, the camera (background) motion model chosen per frame, every
// feature classed foreground/background, packed as MotionData.
//
// Usage:
//   imt::MotionAnalyzer analyzer(options.motion_analysis);
//   imt::MotionData md = analyzer.process(gray, stamp);   // once per frame, in stamp order
//
// A frame size change or a stamp that does not increase resets the feature
// tracks (the result is then `invalid`, like a first frame); `lastReset()`
// says why, so the caller can log it once.
// Threading: not thread-safe; one analyzer per image stream.
#pragma once

#include "instant_motion_tracking/core/options.h"
#include "instant_motion_tracking/core/types.h"

#include <memory>
#include <string>

namespace imt {

class MotionAnalyzer {
 public:
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

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace imt
