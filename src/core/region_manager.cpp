#include "instant_motion_tracking/core/region_manager.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace imt {
namespace {

std::string fmtStamp(double s) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6f", s);
  return buf;
}

}  // namespace

RegionManager::RegionManager(const RegionTrackerOptions& options, double cache_seconds)
    : options_(options), cache_seconds_(cache_seconds) {}

void RegionManager::clear() {
  cache_.clear();
  regions_.clear();
  first_seq_ = 0;
}

std::vector<RegionState> RegionManager::update(const MotionData& md) {
  last_reset_.clear();
  const cv::Size size(md.width, md.height);
  if (!cache_.empty() && !(md.stamp > cache_.back().stamp)) {
    last_reset_ = "stamp " + fmtStamp(md.stamp) + " does not follow " + fmtStamp(cache_.back().stamp) +
                  ": cache and regions cleared";
    clear();
  } else if (!cache_.empty() && size != image_size_) {
    last_reset_ = "image size changed: cache and regions cleared";
    clear();
  }
  image_size_ = size;
  cache_.push_back(md);
  cache_.back().sortByX();
  const uint64_t seq = seqOf(cache_.size() - 1);
  std::vector<RegionState> out;
  out.reserve(regions_.size());
  for (auto& [id, r] : regions_) out.push_back(stateAt(r, seq));
  prune();
  return out;
}

void RegionManager::prune() {
  if (cache_seconds_ <= 0) return;
  while (cache_.size() > 1 && cache_.back().stamp - cache_.front().stamp > cache_seconds_) {
    cache_.pop_front();
    ++first_seq_;
  }
  for (auto& [id, r] : regions_) {
    while (!r.states.empty() && r.states.begin()->first < first_seq_) r.states.erase(r.states.begin());
  }
}

int RegionManager::findFrame(double stamp, std::string* error) const {
  if (cache_.empty()) {
    *error = "no motion data received yet";
    return -1;
  }
  if (stamp == 0) return static_cast<int>(cache_.size()) - 1;
  if (!std::isfinite(stamp)) {
    *error = "stamp is not a finite number";
    return -1;
  }
  const auto it = std::lower_bound(cache_.begin(), cache_.end(), stamp,
                                   [](const MotionData& m, double s) { return m.stamp < s; });
  int best = -1;
  double best_d = 1e300;
  for (auto c : {it - 1, it}) {
    if (c < cache_.begin() || c >= cache_.end()) continue;
    const double d = std::abs(c->stamp - stamp);
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(c - cache_.begin());
    }
  }
  // Half the mean frame interval around the nearest frame (one frame: exact only).
  const double interval =
      cache_.size() > 1 ? (cache_.back().stamp - cache_.front().stamp) / (cache_.size() - 1) : 0;
  if (best_d > 0.5 * interval + 1e-6) {
    *error = "stamp " + fmtStamp(stamp) + " is outside the motion-data cache (" +
             fmtStamp(cache_.front().stamp) + " .. " + fmtStamp(cache_.back().stamp) + ")";
    if (stamp >= cache_.front().stamp && stamp <= cache_.back().stamp)
      *error = "stamp " + fmtStamp(stamp) + " is not within half a frame of any cached frame";
    return -1;
  }
  return best;
}

const RegionState& RegionManager::stateAt(Region& r, uint64_t seq) {
  RegionTracker tracker(options_, image_size_);
  auto& st = r.states;
  // Forward from the newest known state.
  for (uint64_t s = st.rbegin()->first; s < seq; ++s) {
    const MotionData& md = cache_[s + 1 - first_seq_];
    st[s + 1] = tracker.step(st[s], md, Direction::kForward);
  }
  // Backward from the oldest known state.
  for (uint64_t s = st.begin()->first; s > seq; --s) {
    const MotionData& md = cache_[s - first_seq_];
    const double prev_stamp = cache_[s - 1 - first_seq_].stamp;
    st[s - 1] = tracker.step(st[s].reversed(), md, Direction::kBackward, prev_stamp).reversed();
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
  const int index = findFrame(stamp, error);
  if (index < 0) return false;
  if ((box & cv::Rect2d(0, 0, image_size_.width, image_size_.height)).area() <= 0) {
    *error = "box lies entirely outside the " + std::to_string(image_size_.width) + "x" +
             std::to_string(image_size_.height) + " image";
    return false;
  }
  if (id == 0) {
    id = 1;
    while (regions_.count(id)) ++id;
  }
  Region& r = regions_[id];
  r.id = id;
  const uint64_t seq = seqOf(index);
  r.states[seq] = RegionState::start(id, box, cache_[index].stamp);
  stateAt(r, seqOf(cache_.size() - 1));  // catch up to the present
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
  const int index = findFrame(stamp, error);
  if (index < 0) return false;
  states->clear();
  const uint64_t seq = seqOf(index);
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
