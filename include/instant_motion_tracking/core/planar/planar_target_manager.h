// Many planar targets over a motion-data cache (paper 3.3). A target given at
// any cached frame is tracked forward to the newest frame at once, and
// backwards from its initial frame on demand (track_bag produces every frame
// of a bag this way). The cache is owned by the caller (shared with the
// region manager in the pipeline). Frames the cache keeps an image of are
// also aligned with each target's appearance (PlanarTargetOptions::refine).
//
// Usage:
//   imt::PlanarTargetManager targets(options.planar_tracking);
//   cache.push(md, &reset);  auto states = targets.update(cache);
//   targets.add(0, stamp, corners, 0.6, 0.45, intrinsics, cache, &id, &error);
//   targets.stateAt(id, seq, cache, &state);     // any cached frame
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
  // Throws std::invalid_argument on invalid options (validate()).
  explicit PlanarTargetManager(const PlanarTargetOptions& options);

  // Advances every target to the newest frame of `cache`.
  std::vector<PlanarTargetState> update(const MotionCache& cache);
  bool add(uint32_t id, double stamp, const std::array<cv::Point2d, 4>& corners, double width_m,
           double height_m, const CameraModel& k, const MotionCache& cache, uint32_t* assigned_id,
           std::string* error);
  bool remove(uint32_t id, std::string* error);
  // The state of target `id` at cached frame `seq`; false for an unknown id
  // or a frame outside the cache.
  bool stateAt(uint32_t id, uint64_t seq, const MotionCache& cache, PlanarTargetState* state,
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
  const PlanarTargetState& advance(Target& t, uint64_t seq, const MotionCache& cache);

  PlanarTargetOptions options_;
  std::map<uint32_t, Target> targets_;
};

}  // namespace imt
