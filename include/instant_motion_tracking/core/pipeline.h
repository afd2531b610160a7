// The one pipeline object used by the nodelets and by track_bag, so that what
// runs on a rosbag offline is exactly what runs live. It owns the motion
// analysis, the region tracking and the planar-target tracking (anchors
// arrive with their issue), and times each stage.
//
// Usage:
//   imt::Pipeline pipeline(options);              // options.validate() must be empty
//   pipeline.setIntrinsics(k);                    // optional (camera_info)
//   pipeline.addImu(sample);                      // any time, in stamp order
//   imt::FrameResult r = pipeline.processFrame(gray, stamp);
// Threading: not thread-safe; call from one thread.
#pragma once

#include "instant_motion_tracking/core/motion_analysis.h"
#include "instant_motion_tracking/core/options.h"
#include "instant_motion_tracking/core/planar_target_manager.h"
#include "instant_motion_tracking/core/region_manager.h"
#include "instant_motion_tracking/core/types.h"

#include <map>
#include <string>
#include <vector>

namespace imt {

struct FrameResult {
  MotionData motion;
  std::vector<RegionState> regions;         // every region's state at this frame
  std::vector<PlanarTargetState> targets;   // every planar target's state at this frame
};

// Accumulated wall time per stage (s) and counts.
struct StageTimes {
  std::map<std::string, double> seconds;  // stage name -> total seconds
  int frames = 0;
};

class Pipeline {
 public:
  // `keep_all_motion_data`: the offline mode of track_bag, where the cache
  // holds the whole bag so items given at any frame are tracked both ways.
  explicit Pipeline(const PipelineOptions& options, bool keep_all_motion_data = false);

  void setIntrinsics(const CameraModel& k) { intrinsics_ = k; }
  const CameraModel& intrinsics() const { return intrinsics_; }
  void addImu(const ImuSample& s) { imu_.push_back(s); }
  size_t imuCount() const { return imu_.size(); }
  const std::vector<ImuSample>& imuSamples() const { return imu_; }

  // Whether frames are kept (within planar_tracking.image_memory_mb) for the
  // planar targets' appearance alignment; on by default when it is enabled.
  // track_bag turns it off for bags without planar targets.
  void setKeepImages(bool keep);
  // Processes one gray frame (CV_8UC1).
  FrameResult processFrame(const cv::Mat& gray, double stamp);
  // Why the last frame reset the analysis ("" when it did not).
  const std::string& lastReset() const { return analyzer_.lastReset(); }
  // The regions over the motion-data cache (add, remove, seek).
  RegionManager& regions() { return regions_; }
  // The planar targets over the same cache (regions().cache()).
  PlanarTargetManager& planarTargets() { return targets_; }
  const MotionCache& cache() const { return regions_.cache(); }
  const StageTimes& times() const { return times_; }
  const PipelineOptions& options() const { return options_; }

 private:
  PipelineOptions options_;
  CameraModel intrinsics_;
  std::vector<ImuSample> imu_;
  MotionAnalyzer analyzer_;
  RegionManager regions_;
  PlanarTargetManager targets_;
  StageTimes times_;
  bool keep_images_ = false;
};

}  // namespace imt
