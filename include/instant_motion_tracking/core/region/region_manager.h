// Many regions over a bounded cache of motion data (paper 3.2, "random access").
//
// The cache keeps the last `cache_seconds` of motion data. A region can be
// added at any cached stamp: it is tracked forward to the latest frame on
// the next update() (or when its states are asked for), and backwards on
// demand. statesAt() returns the regions' states at any
// cached stamp. Per-region work is proportional to the features inside it;
// the motion analysis is shared by all regions.
//
// Usage (live):
//   imt::RegionManager regions(options.region_tracking, options.cache_seconds);
//   for each frame: auto states = regions.update(motion_data);
//   regions.add(0, stamp_in_the_past, box, &id, &error);
//   regions.statesAt(stamp, {}, &states, &error);
// Offline (track_bag): cache_seconds <= 0 keeps everything; add every region
// after the motion analysis pass, then statesAt() each frame's stamp.
// A camera-motion fallback (setCameraFallback, e.g. the IMU rotation that
// AnchorManager installs) stands in for frames whose own camera model is
// invalid, so regions out of view stay predicted through them.
// Threading: not thread-safe; callers serialise (the nodelet holds a mutex).
// Inside, the regions stepping into the same frame step side by side on
// OpenCV's threads (cv::setNumThreads), with the states of one step after
// another to the bit.
#pragma once

#include "instant_motion_tracking/core/motion_cache.h"
#include "instant_motion_tracking/core/region/region_tracker.h"

#include <Eigen/Core>

#include <functional>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace imt {

class RegionManager {
 public:
  // Boxes add() accepts: sides from kMinBoxSide px to kMaxBoxImages times the image's.
  static constexpr double kMinBoxSide = 2.0;
  static constexpr double kMaxBoxImages = 4.0;
  // Throws std::invalid_argument on invalid options (validate()).
  RegionManager(const RegionTrackerOptions& options, double cache_seconds);

  // Appends the next frame's motion data and advances every region to it.
  // A stamp that does not increase, or a new image size, clears the cache and
  // every region (a bag loop or a camera change): `lastReset()` says so.
  // `image` (the frame's gray, optional) is what the regions' appearance
  // checks see; it is kept in the cache within its image budget (see
  // MotionCache), so regions added in the past and seeks see theirs too.
  std::vector<RegionState> update(const MotionData& md, const cv::Mat& image = cv::Mat());
  void setImageBudget(size_t bytes) { cache_.setImageBudget(bytes); }
  void setImageSource(MotionCache::ImageSource source) { cache_.setImageSource(std::move(source)); }

  // Adds a region whose box is given at `stamp` (nearest cached frame within
  // half a frame interval; 0 = the latest frame). id 0 chooses a free id.
  bool add(uint32_t id, double stamp, const cv::Rect2d& box, uint32_t* assigned_id,
           std::string* error);
  bool remove(uint32_t id, std::string* error);
  // The states of `ids` (empty = all) at a cached `stamp`.
  bool statesAt(double stamp, const std::vector<uint32_t>& ids, std::vector<RegionState>* states,
                std::string* error);
  // The states at the latest frame.
  std::vector<RegionState> latest();

  void clear();

  // Camera motion H (pixels at t_prev -> pixels at t) for frames whose model
  // is invalid; false when it does not know either. Used while tracking, so
  // a state computed before the fallback knew a frame keeps what it had.
  // nullptr (the default) turns it off.
  using CameraFallback = std::function<bool(double t_prev, double t, Eigen::Matrix3d* H)>;
  void setCameraFallback(CameraFallback fallback) { fallback_ = std::move(fallback); }
  const MotionCache& cache() const { return cache_; }
  size_t cachedFrames() const { return cache_.size(); }
  double oldestStamp() const { return cache_.oldestStamp(); }
  double newestStamp() const { return cache_.newestStamp(); }
  size_t size() const { return regions_.size(); }
  // Whole-frame pyramids built for the regions' own features so far.
  size_t pyramidsBuilt() const { return pyramids_built_; }
  std::vector<uint32_t> ids() const;  // in id order
  const std::string& lastReset() const { return last_reset_; }

 private:
  struct Region {
    uint32_t id = 0;
    uint64_t given_seq = 0;  // the frame it was given at
    cv::Rect2d given_box;
    std::map<uint64_t, RegionState> states;  // by frame sequence number, forward semantics
  };
  // Steps `r` to frame `seq` from its nearest known state (forward or
  // backward). What a step does depends on the other regions only through
  // those given at or before the frame stepped into (the look's turns, the
  // shared pyramids), not on the order of the adds and steps: live and
  // offline agree when the regions a frame counts were known when its steps
  // ran (given at the present frame, or added together). A region added
  // later with a past stamp does not redo the others' steps since then.
  const RegionState& stateAt(Region& r, uint64_t seq);
  // Steps `regions` to frame `seq` together, frame by frame (each frame's
  // shared pyramid built once for them all).
  void stepTogether(const std::vector<Region*>& regions, uint64_t seq);
  // What a step of `r` from frame `from` into `to` takes besides its state
  // and the two frames: the regions sharing `to`, the shared pyramids.
  struct StepInputs {
    size_t regions = 1;
    FramePyramids pyramids;
  };
  StepInputs stepInputs(const Region& r, uint64_t from, uint64_t to);
  // One step of `r` from its state at `from` into `to` (forward or
  // backward): `md` is the later frame's motion data, `image` the frame of
  // `to`, `state_image` that of `from`; `tracker` is made again only when
  // the regions sharing the frame change. Reads only `r` and the cache.
  RegionState step(const Region& r, uint64_t from, uint64_t to, const MotionData& md, const cv::Mat& image,
                   const cv::Mat& state_image, const StepInputs& in, std::optional<RegionTracker>* tracker) const;
  // Steps every region of `batch` (each with its state at `from`) into `to`,
  // side by side on OpenCV's threads when there are several of both.
  void stepBatch(const std::vector<Region*>& batch, uint64_t from, uint64_t to);
  std::vector<Region*> all();
  // How many regions share frame `seq` for `r`: r and the others given at
  // or before it.
  size_t sharing(const Region& r, uint64_t seq);
  // Whether a step of `r` into frame `seq` uses whole-frame pyramids for
  // its own features: the boxes (as given) of the regions sharing the frame
  // make crops dearer (wholeFramePyramidsPay()).
  bool sharesPyramids(const Region& r, uint64_t seq);
  // The regions given at or before a frame: how many, and their crops'
  // pixels (ownCropPixels()); kept by frame until a region is added or removed.
  struct Given {
    size_t regions = 0;
    double crop_pixels = 0;
  };
  const Given& givenUpTo(uint64_t seq);
  // Counts `r` in (sign +1) or out of (-1) the memo's frames from its given one.
  void countGiven(const Region& r, int sign);
  // The cached frame `seq`, its camera motion from the fallback when its own
  // model is invalid (`scratch` holds the patched copy).
  const MotionData& frame(uint64_t seq, MotionData* scratch) const;
  // The gray image of frame `seq` for the appearance checks (empty: none).
  cv::Mat imageOf(uint64_t seq) const;
  // Frame `seq`'s whole-frame pyramid for the regions' own features, built
  // once and shared by every region stepping into or out of it.
  const std::vector<cv::Mat>* pyramidOf(uint64_t seq);

  RegionTrackerOptions options_;
  MotionCache cache_;
  std::map<uint32_t, Region> regions_;
  std::string last_reset_;
  CameraFallback fallback_;
  cv::Mat newest_image_;  // the latest frame's image, also when the cache's budget keeps none
  std::map<uint64_t, std::vector<cv::Mat>> pyramids_;  // by frame sequence number, a few
  std::map<uint64_t, Given> given_;                    // givenUpTo() by frame sequence number
  size_t pyramids_built_ = 0;
};

}  // namespace imt
