#include "instant_motion_tracking/core/region_manager.h"

#include <cmath>

namespace imt {

RegionManager::RegionManager(const RegionTrackerOptions& options, double cache_seconds)
    : options_(options), cache_(cache_seconds) {}

void RegionManager::clear() {
  cache_.clear();
  regions_.clear();
}

std::vector<RegionState> RegionManager::update(const MotionData& md, const cv::Mat& image) {
  last_reset_.clear();
  if (!cache_.push(md, &last_reset_, image)) {
    regions_.clear();
    last_reset_ += "; regions cleared";
  }
  const uint64_t seq = cache_.lastSeq();
  std::vector<RegionState> out;
  out.reserve(regions_.size());
  for (auto& [id, r] : regions_) {
    out.push_back(stateAt(r, seq));
    // Forget states of frames that left the cache.
    while (!r.states.empty() && r.states.begin()->first < cache_.firstSeq()) r.states.erase(r.states.begin());
  }
  return out;
}

const RegionState& RegionManager::stateAt(Region& r, uint64_t seq) {
  RegionTracker tracker(options_, cache_.imageSize());
  auto& st = r.states;
  // Forward from the newest known state.
  for (uint64_t s = st.rbegin()->first; s < seq; ++s) {
    st[s + 1] = tracker.step(st[s], cache_.at(s + 1), Direction::kForward);
  }
  // Backward from the oldest known state.
  for (uint64_t s = st.begin()->first; s > seq; --s) {
    st[s - 1] = tracker.step(st[s].reversed(), cache_.at(s), Direction::kBackward, cache_.at(s - 1).stamp)
                    .reversed();
  }
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
    *error = "region id " + std::to_string(id) + " is already tracked";
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
  if (id == 0) {
    id = 1;
    while (regions_.count(id)) ++id;
  }
  Region& r = regions_[id];
  r.id = id;
  r.states[seq] = RegionState::start(id, box, cache_.at(seq).stamp);
  stateAt(r, cache_.lastSeq());  // catch up to the present
  *assigned_id = id;
  return true;
}

bool RegionManager::remove(uint32_t id, std::string* error) {
  if (!regions_.erase(id)) {
    *error = "unknown region id " + std::to_string(id);
    return false;
  }
  return true;
}

bool RegionManager::seek(double stamp, const std::vector<uint32_t>& ids,
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
  if (ids.empty()) {
    for (auto& [id, r] : regions_) states->push_back(stateAt(r, seq));
  } else {
    for (uint32_t id : ids) states->push_back(stateAt(regions_.at(id), seq));
  }
  return true;
}

std::vector<RegionState> RegionManager::latest() const {
  std::vector<RegionState> out;
  for (const auto& [id, r] : regions_) out.push_back(r.states.rbegin()->second);
  return out;
}

}  // namespace imt
