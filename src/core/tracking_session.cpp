#include "instant_motion_tracking/core/tracking_session.h"

#include "instant_motion_tracking/core/item_requests.h"
#include "option_checker.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

namespace imt {
namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// Offline the IMU orientation spans the stream (up to the option's bound).
ImuOptions imuOptionsFor(ImuOptions o, TrackingSession::Mode mode) {
  if (mode == TrackingSession::Mode::kOffline) o.window_seconds = 3600.0;
  return o;
}

// The region manager holds the user's regions and each anchor's own (an
// anchor tracks a region): its cap is max_regions plus one region per anchor
// (anchors.max_anchors), while addRegion() caps the user's regions at
// max_regions. Each kind has its own cap: anchors do not use up regions, nor
// regions anchors.
RegionTrackerOptions regionManagerOptions(RegionTrackerOptions o, int max_anchors) {
  o.max_regions = static_cast<int>(std::min<long long>(std::numeric_limits<int>::max(),
                                                       static_cast<long long>(o.max_regions) + max_anchors));
  return o;
}

}  // namespace

TrackingSession::TrackingSession(const PipelineOptions& options, Mode mode)
    : options_(validated(options)),
      mode_(mode),
      analyzer_(options.motion_analysis),
      regions_(regionManagerOptions(options.region_tracking, options.anchors.max_anchors), mode == Mode::kOffline ? 0.0 : options.cache_seconds),
      targets_(options.planar_tracking, &regions_.cache()),
      anchors_(std::make_unique<AnchorManager>(options.anchors, imuOptionsFor(options.imu, mode),
                                               options.default_hfov_deg, &regions_)) {
  regions_.setImageBudget(imageBudget());
}

void TrackingSession::setCameraInfo(const CameraModel& info) {
  info_ = info;
  anchors_->setIntrinsics(info);
}

CameraModel TrackingSession::camera() const {
  const cv::Size size = regions_.cache().imageSize();
  return CameraModel::forFrame(info_, size.width, size.height, options_.default_hfov_deg);
}

const char* TrackingSession::cameraSource() const {
  if (regions_.cache().imageSize().width <= 0) return "none";
  const CameraModel k = camera();  // the one rule decides; this only tells which way it went
  return info_.valid && k.K() == info_.K() && k.D == info_.D ? "camera_info" : "field_of_view";
}

bool TrackingSession::setRotationCamImu(const Eigen::Quaterniond& q_cam_imu) {
  return anchors_->setRotationCamImu(q_cam_imu);
}

ImuInput TrackingSession::addImu(const ImuSample& s, std::string* why) {
  const auto t0 = Clock::now();
  const ImuInput r = anchors_->addImu(s, why);
  addTime("imu", secondsSince(t0));
  advance(false);
  return r;
}

bool TrackingSession::trackersUseImages() const {
  return keep_images_ || options_.region_tracking.usesImages();
}

size_t TrackingSession::imageBudget() const {
  return trackersUseImages() ? static_cast<size_t>(options_.planar_tracking.image_memory_mb * 1024 * 1024) : 0;
}

void TrackingSession::setKeepImages(bool keep) {
  keep_images_ = keep && options_.planar_tracking.usesImages();
  regions_.setImageBudget(imageBudget());
}

bool TrackingSession::dropByTime(double stamp) {
  last_drop_.clear();
  last_gap_.clear();
  const double newest = newest_stamp_;
  if (!std::isfinite(stamp)) return false;  // the analysis and the cache refuse it
  if (stamp > newest || stamp <= newest - options_.time_jump_reset_seconds) {
    if (std::isfinite(newest) && stamp - newest > options_.cache_seconds) {
      // Beyond the cache: nothing before it can be asked for any more, but
      // the tracks go on across it (counted, not a reset).
      ++time_gaps_;
      char text[160];
      std::snprintf(text, sizeof(text),
                    "frame stamp %.6f is %.3f s after the newest %.6f (over cache_seconds %.3g): a gap, tracked across",
                    stamp, stamp - newest, newest, options_.cache_seconds);
      last_gap_ = text;
    }
    newest_stamp_ = stamp;  // the next frame, a gap, or a jump back (a restart)
    return false;
  }
  char text[192];
  if (stamp == newest) {
    ++time_drops_.duplicate;
    std::snprintf(text, sizeof(text), "frame stamp %.6f repeats the previous frame's: dropped", stamp);
  } else {
    ++time_drops_.behind;
    std::snprintf(text, sizeof(text),
                  "frame stamp %.6f is %.3f s behind the newest %.6f (under time_jump_reset_seconds %.3g, so not "
                  "a restart): dropped",
                  stamp, newest - stamp, newest, options_.time_jump_reset_seconds);
  }
  last_drop_ = text;
  return true;
}

const MotionData& TrackingSession::analyze(const cv::Mat& gray, double stamp) {
  if (dropByTime(stamp)) return last_motion_;
  const auto t0 = Clock::now();
  last_motion_ = analyzer_.process(gray, stamp);
  addTime("motion_analysis", secondsSince(t0));
  ++times_.frames;
  dropStaleFrames(stamp);
  // The image goes along for the trackers that read it (kept within its
  // budget) and, live, for the overlays of the frame's results.
  queue(last_motion_, trackersUseImages() || mode_ == Mode::kLive ? gray : cv::Mat());
  return last_motion_;
}

void TrackingSession::dropStaleFrames(double stamp) {
  // Time went back (a looping bag): the old stream's frames still waiting
  // for the IMU are dropped, not tracked late into the new one.
  if (!pending_.empty() && !(stamp > pending_.back().md.stamp)) pending_.clear();
}

void TrackingSession::pushMotion(const MotionData& md, const cv::Mat& gray) {
  if (dropByTime(md.stamp)) return;
  dropStaleFrames(md.stamp);
  queue(md, gray);
}

void TrackingSession::queue(const MotionData& md, const cv::Mat& gray) {
  pending_.push_back({md, gray});
  advance(false);
  // Still waiting for the IMU: its own copy of the image, as the caller may
  // write into its buffer meanwhile (a capture loop reusing one).
  if (!pending_.empty() && !pending_.back().gray.empty()) pending_.back().gray = ownImage(pending_.back().gray);
}

cv::Mat TrackingSession::ownImage(const cv::Mat& gray) {
  // Only this session holds its pixels (a copy it made, or a buffer no one
  // else refers to; never the caller's memory wrapped): kept as it is.
  if (gray.u != nullptr && gray.u->refcount == 1) return gray;
  return gray.clone();
}

void TrackingSession::advance(bool all) {
  while (!pending_.empty() &&
         (all || anchors_->ready(pending_.front().md.stamp, pending_.back().md.stamp))) {
    trackOldest();
  }
}

void TrackingSession::trackOldest() {
  Pending frame = std::move(pending_.front());
  pending_.pop_front();
  const auto t0 = Clock::now();
  FrameResult r;
  // The trackers' copy serves the overlays as well.
  if (trackersUseImages() && !frame.gray.empty()) frame.gray = ownImage(frame.gray);
  r.regions = userRegions(regions_.update(frame.md, trackersUseImages() ? frame.gray : cv::Mat()));
  r.reset = regions_.lastReset();
  anchors_->update();
  const auto t1 = Clock::now();
  addTime("region_tracking", std::chrono::duration<double>(t1 - t0).count());
  r.targets = targets_.update();
  const auto t2 = Clock::now();
  addTime("planar_tracking", std::chrono::duration<double>(t2 - t1).count());
  if (anchors_->size() > 0) {
    std::string error;  // the frame was just cached: its stamp is always found
    anchors_->statesAt(frame.md.stamp, {}, &r.anchors, &error);
  }
  addTime("anchors", secondsSince(t2));
  if (mode_ == Mode::kLive) {
    r.motion = std::move(frame.md);
    r.gray = frame.gray;
    r.camera = camera();
    results_.push_back(std::move(r));
  }
}

std::vector<FrameResult> TrackingSession::takeResults() {
  std::vector<FrameResult> out;
  out.swap(results_);
  return out;
}

std::vector<RegionState> TrackingSession::userRegions(std::vector<RegionState> states) {
  states.erase(std::remove_if(states.begin(), states.end(),
                              [](const RegionState& s) { return s.id >= AnchorManager::kAnchorRegionBase; }),
               states.end());
  return states;
}

void TrackingSession::flushFor(double stamp) {
  if (pending_.empty()) return;
  if (stamp == 0) {
    // "Now" is the newest frame through the trackers: frames still waiting
    // for their IMU are left to it (forced through, they would go without
    // it: anchors no_imu there). Before any frame went through, they go.
    if (regions_.cache().empty()) advance(true);
    return;
  }
  if (!regions_.cache().empty() && stamp <= regions_.newestStamp()) return;  // already through
  // Asked for by its stamp: the waiting frames up to the first at or after
  // it go through, the later ones wait on.
  while (!pending_.empty()) {
    const bool reached = pending_.front().md.stamp >= stamp;
    trackOldest();
    if (reached) break;
  }
}

bool TrackingSession::addRegion(uint32_t id, double stamp, const cv::Rect2d& box, uint32_t* assigned_id,
                                std::string* error) {
  // The request itself first (the one check every door runs), then the
  // user's regions against max_regions (the anchors' own not counted: see
  // regionManagerOptions()), then what needs the frame: the region manager's.
  if (std::string e = validateRegionRequest(id, box); !e.empty()) {
    *error = e;
    return false;
  }
  if (regionCount() >= static_cast<size_t>(options_.region_tracking.max_regions)) {
    *error = "already " + std::to_string(regionCount()) +
             " regions (region_tracking.max_regions): remove some first";
    return false;
  }
  flushFor(stamp);
  return regions_.add(id, stamp, box, assigned_id, error);
}

bool TrackingSession::removeRegion(uint32_t id, std::string* error) {
  if (id >= AnchorManager::kAnchorRegionBase) {
    *error = "unknown region id " + std::to_string(id);
    return false;
  }
  return regions_.remove(id, error);
}

bool TrackingSession::seekRegions(double stamp, const std::vector<uint32_t>& ids,
                                  std::vector<RegionState>* states, std::string* error) {
  for (uint32_t id : ids) {
    if (id >= AnchorManager::kAnchorRegionBase) {
      *error = "unknown region id " + std::to_string(id);
      return false;
    }
  }
  std::vector<RegionState> all;
  if (!regions_.statesAt(stamp, ids, &all, error)) return false;
  *states = ids.empty() ? userRegions(std::move(all)) : std::move(all);
  return true;
}

size_t TrackingSession::regionCount() const {
  // The anchors' own regions are counted by the region manager too.
  return regions_.size() - anchors_->size();
}

bool TrackingSession::addPlanarTarget(uint32_t id, double stamp, const std::array<cv::Point2d, 4>& corners,
                                      double width_m, double height_m, uint32_t* assigned_id, std::string* error) {
  flushFor(stamp);
  return targets_.add(id, stamp, corners, width_m, height_m, camera(), assigned_id, error);
}

bool TrackingSession::addImageTarget(uint32_t id, double stamp, const cv::Mat& picture, double width_m,
                                     double height_m, uint32_t* assigned_id, std::string* error) {
  flushFor(stamp);
  return targets_.addImage(id, stamp, picture, width_m, height_m, camera(), assigned_id, error);
}

bool TrackingSession::removePlanarTarget(uint32_t id, std::string* error) { return targets_.remove(id, error); }

bool TrackingSession::addAnchor(uint32_t id, double stamp, const cv::Point2d& uv, double depth,
                                uint32_t* assigned_id, std::string* error) {
  flushFor(stamp);
  return anchors_->add(id, stamp, uv, depth, assigned_id, error);
}

bool TrackingSession::removeAnchor(uint32_t id, std::string* error) { return anchors_->remove(id, error); }

bool TrackingSession::statesAt(double stamp, FrameResult* result, std::string* error) {
  const MotionCache& cache = regions_.cache();
  uint64_t seq;
  if (!cache.find(stamp, &seq, error)) return false;
  FrameResult r;
  r.motion = cache.at(seq);
  r.camera = camera();
  if (regionCount() > 0 && !seekRegions(r.motion.stamp, {}, &r.regions, error)) return false;
  if (targets_.size() > 0 && !targets_.statesAt(r.motion.stamp, {}, &r.targets, error)) return false;
  if (anchors_->size() > 0 && !anchors_->statesAt(r.motion.stamp, {}, &r.anchors, error)) return false;
  *result = std::move(r);
  return true;
}

}  // namespace imt
