#include "instant_motion_tracking/core/pipeline.h"

#include <chrono>

namespace imt {

Pipeline::Pipeline(const PipelineOptions& options, bool keep_all_motion_data)
    : options_(options),
      analyzer_(options.motion_analysis),
      regions_(options.region_tracking, keep_all_motion_data ? 0.0 : options.cache_seconds),
      targets_(options.planar_tracking) {}

FrameResult Pipeline::processFrame(const cv::Mat& gray, double stamp) {
  using Clock = std::chrono::steady_clock;
  FrameResult r;
  const auto t0 = Clock::now();
  r.motion = analyzer_.process(gray, stamp);
  const auto t1 = Clock::now();
  r.regions = regions_.update(r.motion);
  const auto t2 = Clock::now();
  r.targets = targets_.update(regions_.cache());
  const auto t3 = Clock::now();
  times_.seconds["motion_analysis"] += std::chrono::duration<double>(t1 - t0).count();
  times_.seconds["region_tracking"] += std::chrono::duration<double>(t2 - t1).count();
  times_.seconds["planar_tracking"] += std::chrono::duration<double>(t3 - t2).count();
  ++times_.frames;
  return r;
}

}  // namespace imt
