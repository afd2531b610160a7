#include "instant_motion_tracking/core/pipeline.h"

#include <chrono>

namespace imt {

Pipeline::Pipeline(const PipelineOptions& options, bool keep_all_motion_data)
    : options_(options),
      analyzer_(options.motion_analysis),
      regions_(options.region_tracking, keep_all_motion_data ? 0.0 : options.cache_seconds),
      targets_(options.planar_tracking) {
  setKeepImages(true);
}

void Pipeline::setKeepImages(bool keep) {
  const PlanarTargetOptions& p = options_.planar_tracking;
  keep_images_ = keep && p.refine && p.model == "perspective" && p.image_memory_mb > 0;
  regions_.setImageBudget(keep_images_ ? static_cast<size_t>(p.image_memory_mb * 1024 * 1024) : 0);
}

FrameResult Pipeline::processFrame(const cv::Mat& gray, double stamp) {
  using Clock = std::chrono::steady_clock;
  FrameResult r;
  const auto t0 = Clock::now();
  r.motion = analyzer_.process(gray, stamp);
  const auto t1 = Clock::now();
  r.regions = regions_.update(r.motion, keep_images_ ? gray.clone() : cv::Mat());
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
