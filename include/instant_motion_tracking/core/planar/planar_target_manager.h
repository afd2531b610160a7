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
// Threading: not thread-safe.
#pragma once

#include "instant_motion_tracking/core/motion_cache.h"
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
  bool remove(uint32_t id, std::string* error);
  // The states of `ids` (empty = all, in id order) at the cached frame
  // nearest `stamp`; false for an unknown id or a stamp outside the cache.
  bool statesAt(double stamp, const std::vector<uint32_t>& ids, std::vector<PlanarTargetState>* states,
                std::string* error);
  void clear() { targets_.clear(); }
  size_t size() const { return targets_.size(); }
  std::vector<uint32_t> ids() const;  // in id order

 private:
  struct Target {
    std::unique_ptr<PlanarTargetTracker> forward, backward;  // at seq_fwd / seq_bwd
    uint64_t seq_fwd = 0, seq_bwd = 0;
    std::map<uint64_t, PlanarTargetState> states;
  };
  const PlanarTargetState& advance(Target& t, uint64_t seq);

  PlanarTargetOptions options_;
  const MotionCache* cache_;
  std::map<uint32_t, Target> targets_;
};

}  // namespace imt
