#include "instant_motion_tracking/core/planar/planar_target_manager.h"

#include "instant_motion_tracking/core/item_requests.h"

#include <algorithm>

#include "option_checker.h"

namespace imt {

PlanarTargetManager::PlanarTargetManager(const PlanarTargetOptions& options, const MotionCache* cache)
    : options_(validated(options)), cache_(cache) {}

const PlanarTargetState& PlanarTargetManager::advance(Target& t, uint64_t seq) {
  const MotionCache& cache = *cache_;
  Eigen::Matrix3d H;
  while (t.seq_fwd < seq) {
    const bool valid = cache.cameraMotion(t.seq_fwd, t.seq_fwd + 1, &H);
    ++t.seq_fwd;
    t.states[t.seq_fwd] = t.forward->step(cache.at(t.seq_fwd), H, valid, cache.image(t.seq_fwd));
  }
  if (seq < t.seq_bwd) {
    if (!t.backward) return t.states.at(t.seq_bwd);  // no backward copy: never happens
    while (t.seq_bwd > seq && t.seq_bwd > cache.firstSeq()) {
      const bool valid = cache.cameraMotion(t.seq_bwd, t.seq_bwd - 1, &H);
      --t.seq_bwd;
      t.states[t.seq_bwd] = t.backward->step(cache.at(t.seq_bwd), H, valid, cache.image(t.seq_bwd));
    }
  }
  return t.states.at(seq);
}

std::vector<PlanarTargetState> PlanarTargetManager::update() {
  const MotionCache& cache = *cache_;
  std::vector<PlanarTargetState> out;
  if (cache.empty()) return out;
  for (auto it = targets_.begin(); it != targets_.end();) {
    Target& t = it->second;
    if (t.seq_fwd < cache.firstSeq()) {  // the cache was cleared under it (time jump)
      it = targets_.erase(it);
      continue;
    }
    out.push_back(advance(t, cache.lastSeq()));
    while (!t.states.empty() && t.states.begin()->first < cache.firstSeq()) t.states.erase(t.states.begin());
    if (t.seq_bwd < cache.firstSeq()) t.seq_bwd = cache.firstSeq();
    ++it;
  }
  return out;
}

bool PlanarTargetManager::add(uint32_t id, double stamp, const std::array<cv::Point2d, 4>& corners,
                              double width_m, double height_m, const CameraModel& k, uint32_t* assigned_id,
                              std::string* error) {
  const MotionCache& cache = *cache_;
  if (id != 0 && targets_.count(id)) {
    *error = alreadyTrackedError("planar target", id);
    return false;
  }
  // The request itself first, so a bad quad is named even before any frame.
  if (std::string e = validateTargetRequest(corners, width_m, height_m); !e.empty()) {
    *error = e;
    return false;
  }
  uint64_t seq;
  if (!cache.find(stamp, &seq, error)) return false;
  // Given where it is seen: at least partly inside the image.
  const cv::Size size = cache.imageSize();
  double x0 = corners[0].x, x1 = x0, y0 = corners[0].y, y1 = y0;
  for (const cv::Point2d& c : corners) {
    x0 = std::min(x0, c.x);
    x1 = std::max(x1, c.x);
    y0 = std::min(y0, c.y);
    y1 = std::max(y1, c.y);
  }
  if (!(x1 > 0 && y1 > 0 && x0 < size.width && y0 < size.height)) {
    *error = "corners lie entirely outside the " + std::to_string(size.width) + "x" + std::to_string(size.height) +
             " image";
    return false;
  }
  if (targets_.size() >= static_cast<size_t>(options_.max_targets)) {
    *error = "already " + std::to_string(targets_.size()) +
             " planar targets (planar_tracking.max_targets): remove some first";
    return false;
  }
  if (id == 0) {
    id = 1;
    while (targets_.count(id)) ++id;
  }
  auto tracker =
      PlanarTargetTracker::create(options_, id, corners, width_m, height_m, k, cache.at(seq), error, cache.image(seq));
  if (!tracker) return false;
  Target t;
  t.backward = std::make_unique<PlanarTargetTracker>(*tracker);
  t.forward = std::move(tracker);
  t.seq_fwd = t.seq_bwd = seq;
  t.states[seq] = t.forward->state();
  Target& stored = targets_[id] = std::move(t);
  advance(stored, cache.lastSeq());
  *assigned_id = id;
  return true;
}

std::vector<uint32_t> PlanarTargetManager::ids() const {
  std::vector<uint32_t> out;
  for (const auto& [id, t] : targets_) out.push_back(id);
  return out;
}

bool PlanarTargetManager::remove(uint32_t id, std::string* error) {
  if (!targets_.erase(id)) {
    *error = "unknown planar target id " + std::to_string(id);
    return false;
  }
  return true;
}

bool PlanarTargetManager::statesAt(double stamp, const std::vector<uint32_t>& ids,
                                   std::vector<PlanarTargetState>* states, std::string* error) {
  for (uint32_t id : ids) {
    if (!targets_.count(id)) {
      *error = "unknown planar target id " + std::to_string(id);
      return false;
    }
  }
  uint64_t seq;
  if (!cache_->find(stamp, &seq, error)) return false;
  states->clear();
  for (uint32_t id : ids.empty() ? this->ids() : ids) states->push_back(advance(targets_.at(id), seq));
  return true;
}

}  // namespace imt
