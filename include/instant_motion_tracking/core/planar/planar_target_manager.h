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

#include <future>
#include <map>
#include <memory>
#include <optional>
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
  // the latest), seen through camera `k`; id 0 chooses a free id. With the
  // frames' images its look at placement also becomes a picture it is
  // searched for by (as an image target is, below) while its tracker is in
  // doubt: not tracked, or not confirmed by its look for detect_interval
  // frames; a find restarts its tracker there.
  bool add(uint32_t id, double stamp, const std::array<cv::Point2d, 4>& corners, double width_m,
           double height_m, const CameraModel& k, uint32_t* assigned_id, std::string* error);
  // An image target: known by its picture (CV_8UC1 or BGR; its corners are
  // the target's TL, TR, BR, BL), searched for from the cached frame nearest
  // `stamp` (0 = the latest) on while it is not tracked (status not_found
  // until found; lost, out of view or predicted: searched again, and a find
  // restarts its tracker), and tracked like any
  // target once found. Frames before that one are not_found. Needs the
  // frames' images (PlanarTargetOptions::usesImages()).
  //
  // A search runs on a thread of its own, so frames are not held up by it:
  // started at frame k, its answer is taken at frame k + detect_interval
  // (waiting for it there if it is not done), and a find starts the tracker
  // at frame k and steps it through the cached frames since. The next search
  // starts at that frame. Live and offline give the same states: what a
  // frame shows depends on the frame count, never on how fast a search ran.
  bool addImage(uint32_t id, double stamp, const cv::Mat& picture, double width_m, double height_m,
                const CameraModel& k, uint32_t* assigned_id, std::string* error);
  bool remove(uint32_t id, std::string* error);
  // The states of `ids` (empty = all, in id order) at the cached frame
  // nearest `stamp`; false for an unknown id or a stamp outside the cache.
  bool statesAt(double stamp, const std::vector<uint32_t>& ids, std::vector<PlanarTargetState>* states,
                std::string* error);
  void clear() {
    targets_.clear();
    described_.clear();
  }
  size_t size() const { return targets_.size(); }
  std::vector<uint32_t> ids() const;  // in id order

 private:
  struct Target {
    std::unique_ptr<PlanarTargetTracker> forward, backward;  // at seq_fwd / seq_bwd
    uint64_t seq_fwd = 0, seq_bwd = 0;
    std::map<uint64_t, PlanarTargetState> states;
    // The picture it is found by (an image target's own; a target given by
    // its corners: its look at placement, when that has the keypoints), and
    // what starting a tracker needs.
    std::shared_ptr<const ImageTargetDetector> picture;
    bool image_target = false;    // given by its picture (searched for forwards only)
    int unaligned = 0;            // frames since its look last confirmed it
    PlanarTargetState not_found;  // the state while no tracker follows it
    CameraModel camera;
    uint64_t next_search = 0;  // the next frame a search starts at
    uint64_t search_seq = 0;   // the frame the running search looks at
    std::future<std::optional<ImageTargetDetector::Detection>> search;  // valid while one runs
  };
  const PlanarTargetState& advance(Target& t, uint64_t seq);
  // A target with a picture at frame `seq` whose tracker (if any) gave `s`:
  // the answer of its search taken when due (found: a new tracker from the
  // searched frame, stepped to `seq`), and a new search started while it is
  // in doubt: not tracked, or its look has not confirmed it for
  // detect_interval frames.
  PlanarTargetState findImageTarget(Target& t, uint64_t seq, const PlanarTargetState& s);
  // The frame's keypoints, described once (on a search's thread) for every
  // image target searching it.
  std::shared_future<ImageTargetDetector::Frame> describedFrame(uint64_t seq, const cv::Mat& gray);
  bool checkNewTarget(uint32_t* id, std::string* error) const;

  PlanarTargetOptions options_;
  const MotionCache* cache_;
  std::map<uint32_t, Target> targets_;
  std::map<uint64_t, std::shared_future<ImageTargetDetector::Frame>> described_;
};

}  // namespace imt
