// Region tracking on motion data alone (paper 3.2).
//
// A region is a box whose motion is fitted, frame to frame, to the motion
// vectors of the features inside it (dilated) by IRLS with weights
// w_i = prior_i / error_i: the prior favours the features that supported the
// region last frame (its implicit appearance, kept as feature IDs) and those
// near its centre; the error is the feature's residual against the current
// fit. The tracker never sees pixels.
//
// A step works in either time direction: forward (frame k-1 -> k) and
// backward (k -> k-1) use the same fit on reversed correspondences, which is
// what lets the cache (region_cache.h) track regions added in the past and
// seek to any cached stamp.
//
// Usage:
//   imt::RegionTracker tracker(options, image_size);
//   imt::RegionState s = imt::RegionState::start(7, box, stamp);
//   s = tracker.step(s, motion_data_of_next_frame, imt::Direction::kForward);
// Threading: const methods only; one tracker may serve many threads.
#pragma once

#include "instant_motion_tracking/core/region/region_tracker_options.h"
#include "instant_motion_tracking/core/types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace imt {

enum class RegionStatus : uint8_t { kTracked, kFeatureless, kOutOfView, kLost };
// "tracked", "featureless", "out_of_view", "lost" (the CSV spelling).
const char* regionStatusName(RegionStatus s);

enum class Direction { kForward, kBackward };

// The tracking state of one region at one frame.
struct RegionState {
  uint32_t id = 0;
  double stamp = 0;
  cv::Rect2d box;                  // x, y, width, height (px); meaningless when lost
  RegionStatus status = RegionStatus::kTracked;
  double confidence = 0;           // 0 .. 1
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();  // px/frame of the box centre, in the tracking direction
  Eigen::Vector2d object_velocity = Eigen::Vector2d::Zero();  // px/frame relative to the background (camera) motion
  double support = 0;              // reference inlier count (slowly decaying maximum)
  std::vector<uint32_t> inliers;   // feature IDs that support the region (sorted)
  std::vector<uint32_t> outliers;  // feature IDs inside it that move differently (sorted)
  cv::Point2d inlier_centroid;     // px
  cv::Size2d inlier_extent;        // px; 3.3 standard deviations of the inliers in x and y (0 without inliers)
  int coast_frames = 0;            // consecutive frames predicted without support
  double frame_interval = 0;       // s; the "frame" of the velocities (the usual interval; 0 until known)
  std::string reason;              // why the region is lost (empty otherwise)

  static RegionState start(uint32_t id, const cv::Rect2d& box, double stamp);
  // The state with its direction of travel reversed (velocities negated).
  RegionState reversed() const;
};

class RegionTracker {
 public:
  RegionTracker(const RegionTrackerOptions& options, cv::Size image_size)
      : options_(options), image_size_(image_size) {}

  // Advances `state` by one frame. Forward: `md` is the motion data of the
  // next frame (it describes previous -> md). Backward: `md` is the motion
  // data of the state's own frame, and the result belongs to the frame
  // before it (`prev_stamp`).
  RegionState step(const RegionState& state, const MotionData& md, Direction dir,
                   double prev_stamp = 0) const;

  const RegionTrackerOptions& options() const { return options_; }
  cv::Size imageSize() const { return image_size_; }

 private:
  RegionTrackerOptions options_;
  cv::Size image_size_;
};

}  // namespace imt
