#include "instant_motion_tracking/core/pipeline.h"

#include <chrono>

namespace imt {

Pipeline::Pipeline(const PipelineOptions& options)
    : options_(options), analyzer_(options.motion_analysis) {}

FrameResult Pipeline::processFrame(const cv::Mat& gray, double stamp) {
  using Clock = std::chrono::steady_clock;
  FrameResult r;
  const auto t0 = Clock::now();
  r.motion = analyzer_.process(gray, stamp);
  times_.seconds["motion_analysis"] += std::chrono::duration<double>(Clock::now() - t0).count();
  ++times_.frames;
  return r;
}

}  // namespace imt
