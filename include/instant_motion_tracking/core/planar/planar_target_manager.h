// Many planar targets over a motion-data cache (paper 3.3). A target given at
// any cached frame is tracked forward to the newest frame at once, and
// backwards from its initial frame on demand (track_bag produces every frame
// of a bag this way). The cache is owned by the caller (shared with the
// region manager in the pipeline). Frames the cache keeps an image of are
// also aligned with each target's appearance (PlanarTargetOptions::refine).
//
// Usage (the same shape as RegionManager and AnchorManager):
//   imt::PlanarTargetManager targets(options.planar_tracking, &cache);
//   cache.push(md, &reset);  auto states = targets.update();
//   targets.add(0, stamp, corners, 0.6, 0.45, camera, &id, &error);
//   targets.statesAt(stamp, {id}, &states, &error);   // any cached frame
//   targets.addImage(0, stamp, picture, 0.6, 0.45, camera, &id, &error);  // found from its picture
// Threading: not thread-safe.
#pragma once

#include "instant_motion_tracking/core/motion_cache.h"
#include "instant_motion_tracking/core/planar/image_target_detector.h"
#include "instant_motion_tracking/core/planar/planar_target.h"

#include <map>
#include <memory>
#include <string>
#include <vector>

namespace imt {

class PlanarTargetManager {
 public:
  // `cache` (the caller's, shared with the regions in a TrackingSession) must
  // outlive the manager. Throws std::invalid_argument on invalid options.
  PlanarTargetManager(const PlanarTargetOptions& options, const MotionCache* cache);

  // Advances every target to the newest frame of the cache.
  std::vector<PlanarTargetState> update();
  // A target given by its corners at the cached frame nearest `stamp` (0 =
  // the latest), seen through camera `k`; id 0 chooses a free id.
  bool add(uint32_t id, double stamp, const std::array<cv::Point2d, 4>& corners, double width_m,
           double height_m, const CameraModel& k, uint32_t* assigned_id, std::string* error);
  // An image target: known by its picture (CV_8UC1 or BGR; its corners are
  // the target's TL, TR, BR, BL), searched for from the cached frame nearest
  // `stamp` (0 = the latest) on, every detect_interval frames while it is
  // not tracked (status not_found until found; lost or out of view: found
  // again), and tracked like any target once found. Frames before that one
  // are not_found. Needs the frames' images (PlanarTargetOptions::usesImages()).
  bool addImage(uint32_t id, double stamp, const cv::Mat& picture, double width_m, double height_m,
                const CameraModel& k, uint32_t* assigned_id, std::string* error);
  bool remove(uint32_t id, std::string* error);
  // The states of `ids` (empty = all, in id order) at the cached frame
  // nearest `stamp`; false for an unknown id or a stamp outside the cache.
  bool statesAt(double stamp, const std::vector<uint32_t>& ids, std::vector<PlanarTargetState>* states,
                std::string* error);
  void clear() {
    targets_.clear();
    described_ = ImageTargetDetector::Frame();
  }
  size_t size() const { return targets_.size(); }
  std::vector<uint32_t> ids() const;  // in id order

 private:
  struct Target {
    std::unique_ptr<PlanarTargetTracker> forward, backward;  // at seq_fwd / seq_bwd
    uint64_t seq_fwd = 0, seq_bwd = 0;
    std::map<uint64_t, PlanarTargetState> states;
    // Image targets only: the picture, and what starting a tracker needs.
    std::shared_ptr<const ImageTargetDetector> picture;
    PlanarTargetState not_found;  // the state while no tracker follows it
    CameraModel camera;
    uint64_t next_search = 0;  // the next frame searched
  };
  const PlanarTargetState& advance(Target& t, uint64_t seq);
  // An image target at frame `seq` whose tracker (if any) gave `s`: searched
  // for when it is due and not tracked; found, a new tracker starts there.
  PlanarTargetState findImageTarget(Target& t, uint64_t seq, const PlanarTargetState& s);
  // The frame's keypoints, described once for every image target.
  const ImageTargetDetector::Frame& describedFrame(uint64_t seq);
  bool checkNewTarget(uint32_t* id, std::string* error) const;

  PlanarTargetOptions options_;
  const MotionCache* cache_;
  std::map<uint32_t, Target> targets_;
  uint64_t described_seq_ = 0;
  ImageTargetDetector::Frame described_;
};

}  // namespace imt
