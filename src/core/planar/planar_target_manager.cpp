#include "instant_motion_tracking/core/planar/planar_target_manager.h"

#include "instant_motion_tracking/core/item_requests.h"

#include <algorithm>
#include <cmath>

#include "option_checker.h"
#include "planar_internal.h"

namespace imt {

PlanarTargetManager::PlanarTargetManager(const PlanarTargetOptions& options, const MotionCache* cache)
    : options_(validated(options)), cache_(cache) {}

const PlanarTargetState& PlanarTargetManager::advance(Target& t, uint64_t seq) {
  const MotionCache& cache = *cache_;
  Eigen::Matrix3d H;
  while (t.seq_fwd < seq) {
    const bool valid = cache.cameraMotion(t.seq_fwd, t.seq_fwd + 1, &H);
    ++t.seq_fwd;
    PlanarTargetState s = t.not_found;
    s.stamp = cache.at(t.seq_fwd).stamp;
    if (t.forward) s = t.forward->step(cache.at(t.seq_fwd), H, valid, cache.image(t.seq_fwd));
    t.unaligned = s.correlation > 0 ? 0 : t.unaligned + 1;
    if (t.picture) s = findImageTarget(t, t.seq_fwd, s);
    t.states[t.seq_fwd] = s;
  }
  if (seq < t.seq_bwd && t.image_target) {  // an image target is searched for forwards only
    for (; t.seq_bwd > seq && t.seq_bwd > cache.firstSeq(); --t.seq_bwd) {
      t.states[t.seq_bwd - 1] = t.not_found;
      t.states[t.seq_bwd - 1].stamp = cache.at(t.seq_bwd - 1).stamp;
    }
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
  const cv::Rect2d b = planar_detail::quadBounds(corners);
  if (!(b.br().x > 0 && b.br().y > 0 && b.x < size.width && b.y < size.height)) {
    *error = "corners lie entirely outside the " + std::to_string(size.width) + "x" + std::to_string(size.height) +
             " image";
    return false;
  }
  if (!checkNewTarget(&id, error)) return false;
  auto tracker =
      PlanarTargetTracker::create(options_, id, corners, width_m, height_m, k, cache.at(seq), error, cache.image(seq));
  if (!tracker) return false;
  Target t;
  // Found again by its look at placement when its tracker is in doubt (a
  // look the frame showed whole only: a part it did not show would be a
  // flat patch in the picture, which the found target's look would keep).
  if (options_.usesImages()) {
    std::string why;
    if (const cv::Mat look = tracker->lookAtPlacement(); !look.empty())
      t.picture = ImageTargetDetector::create(look, options_, &why);
    t.camera = k;
    t.not_found.id = id;
    t.not_found.width_m = width_m;
    t.not_found.height_m = height_m;
    t.next_search = seq + 1;
  }
  t.backward = std::make_unique<PlanarTargetTracker>(*tracker);
  t.forward = std::move(tracker);
  t.seq_fwd = t.seq_bwd = seq;
  t.states[seq] = t.forward->state();
  Target& stored = targets_[id] = std::move(t);
  advance(stored, cache.lastSeq());
  *assigned_id = id;
  return true;
}

bool PlanarTargetManager::checkNewTarget(uint32_t* id, std::string* error) const {
  if (targets_.size() >= static_cast<size_t>(options_.max_targets)) {
    *error = "already " + std::to_string(targets_.size()) +
             " planar targets (planar_tracking.max_targets): remove some first";
    return false;
  }
  if (*id == 0) {
    *id = 1;
    while (targets_.count(*id)) ++*id;
  }
  return true;
}

bool PlanarTargetManager::addImage(uint32_t id, double stamp, const cv::Mat& picture, double width_m,
                                   double height_m, const CameraModel& k, uint32_t* assigned_id, std::string* error) {
  const MotionCache& cache = *cache_;
  if (id != 0 && targets_.count(id)) {
    *error = alreadyTrackedError("planar target", id);
    return false;
  }
  if (std::string e = validateTargetSize(width_m, height_m); !e.empty()) {
    *error = e;
    return false;
  }
  if (!options_.usesImages()) {
    *error = "image targets need the frames' images (planar_tracking: refine true, model perspective, "
             "image_memory_mb > 0)";
    return false;
  }
  std::shared_ptr<const ImageTargetDetector> detector = ImageTargetDetector::create(picture, options_, error);
  if (!detector) return false;
  uint64_t seq;
  if (!cache.find(stamp, &seq, error)) return false;
  if (!checkNewTarget(&id, error)) return false;
  Target t;
  t.picture = std::move(detector);
  t.image_target = true;
  t.camera = k;
  t.not_found.id = id;
  t.not_found.width_m = width_m;
  t.not_found.height_m = height_m;
  t.not_found.status = TargetStatus::kNotFound;
  t.not_found.confidence = 0;
  t.not_found.reason = "not found in view yet";
  t.seq_fwd = t.seq_bwd = t.next_search = seq;
  PlanarTargetState s = t.not_found;
  s.stamp = cache.at(seq).stamp;
  t.states[seq] = findImageTarget(t, seq, s);
  Target& stored = targets_[id] = std::move(t);
  advance(stored, cache.lastSeq());
  *assigned_id = id;
  return true;
}

PlanarTargetState PlanarTargetManager::findImageTarget(Target& t, uint64_t seq, const PlanarTargetState& s) {
  const MotionCache& cache = *cache_;
  PlanarTargetState out = s;
  // Not tracked, or not confirmed by its look for detect_interval frames.
  const auto inDoubt = [&](const PlanarTargetState& state) {
    return state.status != TargetStatus::kTracked || t.unaligned >= options_.detect_interval;
  };
  const bool doubt = inDoubt(s);
  if (t.search.valid() && seq >= t.search_seq + options_.detect_interval) {
    const std::optional<ImageTargetDetector::Detection> found = t.search.get();
    const uint64_t from = t.search_seq;
    std::string why;
    if (found && doubt && from >= cache.firstSeq()) {
      auto tracker = PlanarTargetTracker::create(options_, t.not_found.id, found->corners, t.not_found.width_m,
                                                 t.not_found.height_m, t.camera, cache.at(from), &why,
                                                 cache.image(from), t.picture->picture());
      if (tracker) {
        Eigen::Matrix3d H;
        for (uint64_t q = from; q < seq; ++q) {
          const bool valid = cache.cameraMotion(q, q + 1, &H);
          tracker->step(cache.at(q + 1), H, valid, cache.image(q + 1));
        }
        t.forward = std::move(tracker);
        out = t.forward->state();
        t.unaligned = out.correlation > 0 ? 0 : 1;  // the new tracker's own count
      }
    }
    t.next_search = std::max(t.next_search, seq);
  }
  // In doubt now (after a find: the new tracker's state).
  if (!inDoubt(out) || t.search.valid() || seq < t.next_search) return out;
  const cv::Mat gray = cache.image(seq);
  if (gray.empty()) return out;  // a frame without its image: the next one is searched
  t.search_seq = seq;
  t.next_search = seq + options_.detect_interval;
  std::shared_future<ImageTargetDetector::Frame> frame = describedFrame(seq, gray);
  std::shared_ptr<const ImageTargetDetector> picture = t.picture;
  t.search = std::async(std::launch::async, [frame, picture]() -> std::optional<ImageTargetDetector::Detection> {
    ImageTargetDetector::Detection d;
    if (!picture->detect(frame.get(), &d)) return std::nullopt;
    return d;
  });
  return out;
}

std::shared_future<ImageTargetDetector::Frame> PlanarTargetManager::describedFrame(uint64_t seq,
                                                                                     const cv::Mat& gray) {
  // Frames of searches long answered are forgotten.
  while (!described_.empty() && described_.begin()->first + 2 * options_.detect_interval < seq)
    described_.erase(described_.begin());
  auto it = described_.find(seq);
  if (it != described_.end()) return it->second;
  const PlanarTargetOptions options = options_;
  std::shared_future<ImageTargetDetector::Frame> f =
      std::async(std::launch::async, [gray, options] { return ImageTargetDetector::describeFrame(gray, options); })
          .share();
  described_.emplace(seq, f);
  return f;
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
