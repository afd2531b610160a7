#include "instant_motion_tracking/core/region/region_manager.h"

#include "instant_motion_tracking/core/item_requests.h"

#include "option_checker.h"
#include "region_features.h"
#include "region_fit.h"

#include <opencv2/core/utility.hpp>

#include <algorithm>
#include <cmath>
#include <optional>

namespace imt {

RegionManager::RegionManager(const RegionTrackerOptions& options, double cache_seconds)
    : options_(validated(options)), cache_(cache_seconds) {}

void RegionManager::clear() {
  newest_image_.release();
  cache_.clear();
  regions_.clear();
  pyramids_.clear();
  given_.clear();
}

std::vector<RegionState> RegionManager::update(const MotionData& md, const cv::Mat& image) {
  last_reset_.clear();
  // Regions added since the last frame are tracked to it first: the new
  // frame may push the one they were given at out of the cache.
  if (!cache_.empty()) stepTogether(all(), cache_.lastSeq());
  newest_image_ = options_.usesImages() ? image : cv::Mat();
  if (!cache_.push(md, &last_reset_, image)) {
    regions_.clear();
    given_.clear();
    last_reset_ += "; regions cleared";
  }
  const uint64_t seq = cache_.lastSeq();
  stepTogether(all(), seq);
  std::vector<RegionState> out;
  out.reserve(regions_.size());
  for (auto& [id, r] : regions_) {
    out.push_back(stateAt(r, seq));
    // Forget states of frames that left the cache.
    while (!r.states.empty() && r.states.begin()->first < cache_.firstSeq()) r.states.erase(r.states.begin());
  }
  // The newest frame's pyramid serves the next frame's steps.
  for (auto it = pyramids_.begin(); it != pyramids_.end();) it = it->first == seq ? std::next(it) : pyramids_.erase(it);
  given_.erase(given_.begin(), given_.lower_bound(cache_.firstSeq()));
  return out;
}

using region_fit::applyH;

const MotionData& RegionManager::frame(uint64_t seq, MotionData* scratch) const {
  const MotionData& md = cache_.at(seq);
  if (md.camera.model != MotionModel::kInvalid || !fallback_ || seq == cache_.firstSeq()) return md;
  Eigen::Matrix3d H;
  if (!fallback_(cache_.at(seq - 1).stamp, md.stamp, &H) || !H.allFinite()) return md;
  *scratch = md;
  scratch->camera.model = MotionModel::kHomography;
  scratch->camera.H = H;
  // Residuals against the new camera motion: the previous position is where
  // the old model's prediction came from.
  const Eigen::Matrix3d H_old_inv = md.camera.H.inverse();
  std::vector<float> rx, ry;
  for (FeatureMotion& f : scratch->features) {
    if (f.age == 0) continue;  // new: no motion yet
    const Eigen::Vector2d prev = applyH(H_old_inv, Eigen::Vector2d(f.x - f.dx, f.y - f.dy));
    const Eigen::Vector2d predicted = applyH(H, prev);
    f.dx = static_cast<float>(f.x - predicted.x());
    f.dy = static_cast<float>(f.y - predicted.y());
    rx.push_back(f.dx);
    ry.push_back(f.dy);
  }
  // What the rotation leaves (the camera's translation), when enough features
  // agree on it: their median residual, taken out of every residual.
  if (static_cast<int>(rx.size()) >= options_.fallback_min_features) {
    auto median = [](std::vector<float>& v) {
      std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
      return v[v.size() / 2];
    };
    const float mx = median(rx), my = median(ry);
    Eigen::Matrix3d T = Eigen::Matrix3d::Identity();
    T(0, 2) = mx;
    T(1, 2) = my;
    scratch->camera.H = T * H;
    for (FeatureMotion& f : scratch->features) {
      if (f.age == 0) continue;
      f.dx -= mx;
      f.dy -= my;
    }
  }
  return *scratch;
}

cv::Mat RegionManager::imageOf(uint64_t seq) const {
  if (!options_.usesImages()) return cv::Mat();
  if (seq == cache_.lastSeq() && !newest_image_.empty()) return newest_image_;
  return cache_.image(seq);
}

std::vector<RegionManager::Region*> RegionManager::all() {
  std::vector<Region*> out;
  out.reserve(regions_.size());
  for (auto& [id, r] : regions_) out.push_back(&r);
  return out;
}

void RegionManager::stepTogether(const std::vector<Region*>& regions, uint64_t seq) {
  // Frame by frame, every region whose newest (oldest) state is that frame:
  // a frame's shared pyramid is built once for all of them.
  uint64_t lo = seq, hi = seq;
  for (const Region* r : regions) {
    lo = std::min(lo, r->states.rbegin()->first);
    hi = std::max(hi, r->states.begin()->first);
  }
  std::vector<Region*> batch;
  for (uint64_t s = lo; s < seq; ++s) {
    batch.clear();
    for (Region* r : regions)
      if (r->states.rbegin()->first == s) batch.push_back(r);
    stepBatch(batch, s, s + 1);
  }
  for (uint64_t s = hi; s > seq; --s) {
    batch.clear();
    for (Region* r : regions)
      if (r->states.begin()->first == s) batch.push_back(r);
    stepBatch(batch, s, s - 1);
  }
}

RegionManager::StepInputs RegionManager::stepInputs(const Region& r, uint64_t from, uint64_t to) {
  StepInputs in;
  in.regions = sharing(r, to);
  // The two frames' shared pyramids, for a region with own features the
  // pyramids serve (those in a large box use a downscaled crop of their own).
  const RegionState& state = r.states.at(from);
  if (!state.own_points.empty() && ownFeaturesAtFullResolution(state.box, options_.region_feature_px) &&
      sharesPyramids(r, to)) {
    in.pyramids.image = pyramidOf(to);
    in.pyramids.state_image = pyramidOf(from);
  }
  return in;
}

RegionState RegionManager::step(const Region& r, uint64_t from, uint64_t to, const MotionData& md,
                                const cv::Mat& image, const cv::Mat& state_image, const StepInputs& in,
                                std::optional<RegionTracker>* tracker) const {
  // The tracker for a step into frame `to`: its look's turns come as often
  // as the regions sharing that frame make them.
  if (!*tracker || (*tracker)->regions() != in.regions) tracker->emplace(options_, cache_.imageSize(), in.regions);
  const RegionState& state = r.states.at(from);
  if (to > from) return (*tracker)->step(state, md, Direction::kForward, 0, image, state_image, in.pyramids);
  return (*tracker)
      ->step(state.reversed(), md, Direction::kBackward, cache_.at(to).stamp, image, state_image, in.pyramids)
      .reversed();
}

void RegionManager::stepBatch(const std::vector<Region*>& batch, uint64_t from, uint64_t to) {
  if (batch.empty()) return;
  // What the steps share is gathered here, on this thread: the memo of the
  // regions given, the pyramids, the images (a source may read them again),
  // the fallback's camera motion. Then each region steps on its own: a step
  // reads only its region's state and these, so the regions step side by
  // side on OpenCV's threads with the same results as one after another.
  MotionData scratch;
  const MotionData& md = frame(std::max(from, to), &scratch);
  const cv::Mat image = imageOf(to), state_image = imageOf(from);
  std::vector<StepInputs> inputs;
  inputs.reserve(batch.size());
  for (const Region* r : batch) inputs.push_back(stepInputs(*r, from, to));
  std::vector<RegionState> next(batch.size());
  const auto run = [&](const cv::Range& range) {
    std::optional<RegionTracker> tracker;
    for (int i = range.start; i < range.end; ++i)
      next[i] = step(*batch[i], from, to, md, image, state_image, inputs[i], &tracker);
  };
  const cv::Range all(0, static_cast<int>(batch.size()));
  if (batch.size() > 1 && cv::getNumThreads() > 1)
    cv::parallel_for_(all, run);
  else
    run(all);
  for (size_t i = 0; i < batch.size(); ++i) batch[i]->states[to] = std::move(next[i]);
}

void RegionManager::countGiven(const Region& r, int sign) {
  // The memo's frames from the region's on: one more (or fewer) given by then.
  const double pixels = ownCropPixels(r.given_box, options_.region_feature_px);
  for (auto it = given_.lower_bound(r.given_seq); it != given_.end(); ++it) {
    it->second.regions = sign > 0 ? it->second.regions + 1 : it->second.regions - 1;
    it->second.crop_pixels += sign * pixels;
  }
}

const RegionManager::Given& RegionManager::givenUpTo(uint64_t seq) {
  auto it = given_.find(seq);
  if (it == given_.end()) {
    Given g;
    for (const auto& [id, r] : regions_) {
      if (r.given_seq > seq) continue;
      ++g.regions;
      g.crop_pixels += ownCropPixels(r.given_box, options_.region_feature_px);
    }
    it = given_.emplace(seq, g).first;
  }
  return it->second;
}

size_t RegionManager::sharing(const Region& r, uint64_t seq) {
  return givenUpTo(seq).regions + (r.given_seq > seq ? 1 : 0);
}

bool RegionManager::sharesPyramids(const Region& r, uint64_t seq) {
  double pixels = givenUpTo(seq).crop_pixels;
  if (r.given_seq > seq) pixels += ownCropPixels(r.given_box, options_.region_feature_px);
  return wholeFramePyramidsPay(pixels, cache_.imageSize());
}

const std::vector<cv::Mat>* RegionManager::pyramidOf(uint64_t seq) {
  auto it = pyramids_.find(seq);
  if (it == pyramids_.end()) {
    const cv::Mat image = imageOf(seq);
    if (image.empty()) return nullptr;
    // A few kept (a region catching up over many frames walks them in
    // order): the one farthest from this frame makes room (never the other
    // frame of the step, one away: of four kept, an end is two or more away).
    constexpr size_t kKept = 4;
    if (pyramids_.size() >= kKept) {
      const auto distance = [seq](uint64_t other) { return other > seq ? other - seq : seq - other; };
      pyramids_.erase(distance(pyramids_.begin()->first) > distance(pyramids_.rbegin()->first)
                          ? pyramids_.begin()
                          : std::prev(pyramids_.end()));
    }
    it = pyramids_.emplace(seq, ownFeaturePyramid(image)).first;
    ++pyramids_built_;
  }
  return &it->second;
}

const RegionState& RegionManager::stateAt(Region& r, uint64_t seq) {
  auto& st = r.states;
  MotionData scratch;
  std::optional<RegionTracker> tracker;
  const auto stepTo = [&](uint64_t from, uint64_t to) {
    st[to] = step(r, from, to, frame(std::max(from, to), &scratch), imageOf(to), imageOf(from),
                  stepInputs(r, from, to), &tracker);
  };
  // Forward from the newest known state.
  for (uint64_t s = st.rbegin()->first; s < seq; ++s) stepTo(s, s + 1);
  // Backward from the oldest known state.
  for (uint64_t s = st.begin()->first; s > seq; --s) stepTo(s, s - 1);
  return st.at(seq);
}

bool RegionManager::add(uint32_t id, double stamp, const cv::Rect2d& box, uint32_t* assigned_id,
                        std::string* error) {
  if (!(std::isfinite(box.x) && std::isfinite(box.y) && std::isfinite(box.width) &&
        std::isfinite(box.height))) {
    *error = "box has a NaN or infinite value";
    return false;
  }
  if (box.width <= 0 || box.height <= 0) {
    *error = "box width and height must be positive (got " + std::to_string(box.width) + " x " +
             std::to_string(box.height) + ")";
    return false;
  }
  if (id != 0 && regions_.count(id)) {
    *error = alreadyTrackedError("region", id);
    return false;
  }
  uint64_t seq;
  if (!cache_.find(stamp, &seq, error)) return false;
  const cv::Size size = cache_.imageSize();
  if ((box & cv::Rect2d(0, 0, size.width, size.height)).area() <= 0) {
    *error = "box lies entirely outside the " + std::to_string(size.width) + "x" +
             std::to_string(size.height) + " image";
    return false;
  }
  // Sizes a tracker can follow: a few pixels to a few image sizes.
  if (box.width < kMinBoxSide || box.height < kMinBoxSide || box.width > kMaxBoxImages * size.width ||
      box.height > kMaxBoxImages * size.height) {
    *error = "box size " + std::to_string(box.width) + " x " + std::to_string(box.height) + " px is outside " +
             std::to_string(kMinBoxSide) + " px .. " + std::to_string(kMaxBoxImages) + " times the " +
             std::to_string(size.width) + "x" + std::to_string(size.height) + " image";
    return false;
  }
  if (regions_.size() >= static_cast<size_t>(options_.max_regions)) {
    *error = "already " + std::to_string(regions_.size()) + " regions (region_tracking.max_regions): remove some first";
    return false;
  }
  if (id == 0) {
    id = 1;
    while (regions_.count(id)) ++id;
  }
  Region& r = regions_[id];
  r.id = id;
  r.given_seq = seq;
  r.given_box = box;
  countGiven(r, +1);
  RegionState start = RegionState::start(id, box, cache_.at(seq).stamp);
  RegionTracker(options_, cache_.imageSize()).initFromImage(&start, imageOf(seq), cache_.at(seq));
  r.states[seq] = start;
  // Tracked to the present on the next update() or request, with every
  // region given by then: a step does not depend on the order of the adds.
  *assigned_id = id;
  return true;
}

bool RegionManager::remove(uint32_t id, std::string* error) {
  const auto it = regions_.find(id);
  if (it == regions_.end()) {
    *error = "unknown region id " + std::to_string(id);
    return false;
  }
  countGiven(it->second, -1);
  regions_.erase(it);
  return true;
}

std::vector<uint32_t> RegionManager::ids() const {
  std::vector<uint32_t> out;
  for (const auto& [id, r] : regions_) out.push_back(id);
  return out;
}

bool RegionManager::statesAt(double stamp, const std::vector<uint32_t>& ids,
                         std::vector<RegionState>* states, std::string* error) {
  for (uint32_t id : ids) {
    if (!regions_.count(id)) {
      *error = "unknown region id " + std::to_string(id);
      return false;
    }
  }
  uint64_t seq;
  if (!cache_.find(stamp, &seq, error)) return false;
  states->clear();
  std::vector<Region*> which;
  if (ids.empty()) {
    which = all();
  } else {
    for (uint32_t id : ids) which.push_back(&regions_.at(id));
  }
  stepTogether(which, seq);
  for (Region* r : which) states->push_back(stateAt(*r, seq));
  return true;
}

std::vector<RegionState> RegionManager::latest() {
  std::vector<RegionState> out;
  if (cache_.empty()) return out;
  stepTogether(all(), cache_.lastSeq());
  for (auto& [id, r] : regions_) out.push_back(stateAt(r, cache_.lastSeq()));
  return out;
}

}  // namespace imt
