// The one pipeline object used by the nodelets and by track_bag, so that what
// runs on a rosbag offline is exactly what runs live. It owns the motion
// analysis and (in later versions) the region, planar-target and anchor
// trackers, and times each stage.
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
#include "instant_motion_tracking/core/types.h"

#include <map>
#include <string>
#include <vector>

namespace imt {

struct FrameResult {
  MotionData motion;
};

// Accumulated wall time per stage (s) and counts.
struct StageTimes {
  std::map<std::string, double> seconds;  // stage name -> total seconds
  int frames = 0;
};

class Pipeline {
 public:
  explicit Pipeline(const PipelineOptions& options);

  void setIntrinsics(const CameraIntrinsics& k) { intrinsics_ = k; }
  const CameraIntrinsics& intrinsics() const { return intrinsics_; }
  void addImu(const ImuSample& s) { imu_.push_back(s); }
  size_t imuCount() const { return imu_.size(); }

  // Processes one gray frame (CV_8UC1).
  FrameResult processFrame(const cv::Mat& gray, double stamp);
  // Why the last frame reset the analysis ("" when it did not).
  const std::string& lastReset() const { return analyzer_.lastReset(); }
  const StageTimes& times() const { return times_; }
  const PipelineOptions& options() const { return options_; }

 private:
  PipelineOptions options_;
  CameraIntrinsics intrinsics_;
  std::vector<ImuSample> imu_;
  MotionAnalyzer analyzer_;
  StageTimes times_;
};

}  // namespace imt
