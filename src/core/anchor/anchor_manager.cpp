#include "instant_motion_tracking/core/anchor/anchor_manager.h"

#include "instant_motion_tracking/core/anchor/anchor.h"
#include "instant_motion_tracking/core/item_requests.h"
#include "option_checker.h"

#include <algorithm>
#include <limits>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace imt {
namespace {

// The image's up as world z, for anchors without IMU orientation: the camera
// looks level along world y (optical x = world x, optical y = world -z).
const Eigen::Matrix3d kImageUpStandIn =
    (Eigen::Matrix3d() << 1, 0, 0, 0, 0, 1, 0, -1, 0).finished();

}  // namespace

const char* anchorStatusName(AnchorStatus s) {
  switch (s) {
    case AnchorStatus::kTracked:
      return "tracked";
    case AnchorStatus::kOutOfView:
      return "out_of_view";
    case AnchorStatus::kNoImu:
      return "no_imu";
    case AnchorStatus::kLost:
      return "lost";
    case AnchorStatus::kCalibrating:
      return "calibrating";
  }
  return "lost";
}

const char* AnchorManager::offsetSourceName(OffsetSource s) {
  switch (s) {
    case OffsetSource::kCorrelation: return "correlation";
    case OffsetSource::kBiasFit: return "bias_fit";
    case OffsetSource::kParameter: break;
  }
  return "parameter";
}

const char* AnchorManager::rotationSourceName(RotationSource s) {
  switch (s) {
    case RotationSource::kOptions: return "options";
    case RotationSource::kTf: return "tf";
    case RotationSource::kVideo: return "video";
    case RotationSource::kNone: break;
  }
  return "none";
}

bool AnchorOptions::rotationCamImu(Eigen::Quaterniond* q) const {
  if (rotation_cam_imu.empty()) return false;
  std::istringstream in(rotation_cam_imu);
  double x, y, z, w;
  std::string rest;
  if (!(in >> x >> y >> z >> w) || (in >> rest)) return false;
  const Eigen::Quaterniond r(w, x, y, z);
  const double n = r.norm();
  if (!r.coeffs().allFinite() || !(std::abs(n - 1) < 1e-3)) return false;
  *q = r.normalized();
  return true;
}

std::string AnchorOptions::validate() const {
  OptionChecker c("anchors");
  c.check(region_size > 0.01 && region_size <= 1.0, "region_size", "must be in (0.01, 1]", region_size);
  c.check(default_depth > 0 && default_depth <= AnchorManager::kMaxDepth, "default_depth", "must be in (0, 10000] m",
          default_depth);
  c.inRange("imu_wait_seconds", imu_wait_seconds, 0.0, 10.0);
  c.check(imu_reset_seconds > 0 && imu_reset_seconds <= 3600, "imu_reset_seconds", "must be in (0, 3600]",
          imu_reset_seconds);
  c.check(surface == "horizontal" || surface == "facing", "surface", "must be horizontal or facing",
          "\"" + surface + "\"");
  c.inRange("imu_time_offset", imu_time_offset, -1.0, 1.0);
  c.inRange("rolling_shutter_readout", rolling_shutter_readout, 0.0, 0.2);
  c.inRange("max_anchors", max_anchors, 1, 100000);
  Eigen::Quaterniond q;
  c.check(rotation_cam_imu.empty() || rotationCamImu(&q), "rotation_cam_imu",
          "must be empty or \"qx qy qz qw\", a unit quaternion", "\"" + rotation_cam_imu + "\"");
  return c.error();
}

AnchorManager::AnchorManager(const AnchorOptions& options, const ImuOptions& imu_options,
                             double default_hfov_deg, RegionManager* regions)
    : options_(validated(options)),
      default_hfov_deg_(default_hfov_deg),
      regions_(regions),
      imu_(imu_options),
      video_bias_(imu_.options().video_bias_seconds) {
  Eigen::Quaterniond q;
  if (options_.rotationCamImu(&q)) useRotation(q, RotationSource::kOptions);
  imu_.setTimeOffset(options_.imu_time_offset);
  // Frames without a usable camera model (blur, a featureless view): the
  // regions, the anchors' among them, move by the IMU rotation instead.
  // Through a distorting lens that motion is no homography between image
  // pixels; the region manager takes one, so it gets the best fit over the
  // image (CameraModel::imageHomography; see imu_orientation.h). Not while
  // the IMU -> camera rotation is unknown at t.
  regions_->setCameraFallback([this](double t_prev, double t, Eigen::Matrix3d* H) {
    const Eigen::Quaterniond* q = rotationAt(t);
    Eigen::Matrix3d turn;  // the IMU at t in the IMU at t_prev
    if (!q || !fallbackTurn(t_prev + imu_.timeOffset(), t + imu_.timeOffset(), &turn)) return false;
    const Eigen::Matrix3d R_ci = q->toRotationMatrix();
    // x_t ~ K R_cam(t)_cam(t_prev) K^-1 x_prev.
    const Eigen::Matrix3d R = R_ci * turn.transpose() * R_ci.transpose();
    const CameraModel k = intrinsics();
    const Eigen::Matrix3d h = k.K() * R * k.K().inverse();
    if (!h.allFinite() || !(std::abs(h(2, 2)) > 1e-12)) return false;
    *H = k.imageHomography(h / h(2, 2));
    return true;
  });
}

AnchorManager::~AnchorManager() { regions_->setCameraFallback(nullptr); }

bool AnchorManager::fallbackTurn(double s0, double s1, Eigen::Matrix3d* turn) const {
  if (imu_.turnAtImuStamps(s0, s1, turn)) return true;
  // The frame is stepped when it comes, and its IMU stamps (plus the time
  // offset) may lie ahead of the newest sample: the turn up to it, then its
  // last kFallbackRateSeconds' rate held over what is missing.
  const double newest = imu_.newestStamp();
  const double d = std::min(kFallbackRateSeconds, newest - imu_.oldestStamp());
  Eigen::Matrix3d known = Eigen::Matrix3d::Identity(), last;
  if (imu_.empty() || !(s1 > newest && s1 - newest <= kFallbackLeadSeconds) || !(s0 < s1) || !(d > 0) ||
      !imu_.turnAtImuStamps(newest - d, newest, &last))
    return false;
  if (s0 < newest && !imu_.turnAtImuStamps(s0, newest, &known)) return false;
  *turn = known * quaternionExp(rotationVector(last) * ((s1 - std::max(s0, newest)) / d)).toRotationMatrix();
  return true;
}

CameraModel AnchorManager::intrinsics() const {
  const cv::Size size = regions_->cache().imageSize();
  return CameraModel::forFrame(info_, size.width, size.height, default_hfov_deg_);
}

bool AnchorManager::setRotationCamImu(const Eigen::Quaterniond& q_cam_imu) {
  if (rotation_source_ == RotationSource::kOptions) return false;
  return useRotation(q_cam_imu, RotationSource::kTf);
}

bool AnchorManager::useRotation(const Eigen::Quaterniond& q, RotationSource source, double from) {
  if (!imu_.setRotationCamImu(q)) return false;
  const Eigen::Quaterniond unit = *imu_.rotationCamImu();
  if (source == RotationSource::kVideo) {
    // From the frame whose turn completed the estimate on: the frames before
    // it keep what they had (live and offline alike).
    rotations_.emplace_back(from, unit);
  } else {
    // Given (options, tf): the rig's rotation, for every frame.
    rotations_.assign(1, {-std::numeric_limits<double>::infinity(), unit});
  }
  const bool refined = source == RotationSource::kVideo && rotation_source_ == RotationSource::kVideo;
  rotation_source_ = source;
  // The video's bias readings keep the camera's turns in its own axes and
  // take the rotation at each fit (VideoGyroBias), so they stay while the
  // video's own estimate refines itself (it moves by tenths of a degree as
  // turns come in; dropping them each time left a slow walk's bias never
  // tracked; their floor normal is the old rotation's, a second-order
  // error). A rotation given (options, tf) is another rig: they go.
  if (!refined) clearVideoBias();
  return true;
}

const Eigen::Quaterniond* AnchorManager::rotationAt(double t) const {
  const Eigen::Quaterniond* q = nullptr;
  for (const auto& [from, r] : rotations_)
    if (from <= t) q = &r;
  return q;
}

std::string AnchorManager::rotationDisagreement() const {
  const auto video = video_rotation_.estimate();
  if (!video || rotations_.empty() || rotation_source_ == RotationSource::kVideo ||
      rotation_source_ == RotationSource::kNone)
    return "";
  const Eigen::Quaterniond& used = rotations_.back().second;
  const double deg = used.angularDistance(*video) * 180 / M_PI;
  if (!(deg > kRotationDisagreementDeg)) return "";
  char text[320];
  std::snprintf(text, sizeof(text),
                "the IMU-to-camera rotation from %s (qx qy qz qw [%.3f %.3f %.3f %.3f]) and the one the video shows "
                "([%.3f %.3f %.3f %.3f]) differ by %.1f deg: check the IMU's frame_id and the tf between it and the "
                "camera's optical frame",
                rotationSourceName(rotation_source_), used.x(), used.y(), used.z(), used.w(), video->x(), video->y(),
                video->z(), video->w(), deg);
  return text;
}

ImuInput AnchorManager::addImu(const ImuSample& s, std::string* why) {
  if (!imu_.empty() && std::isfinite(s.stamp) &&
      s.stamp < imu_.newestStamp() - options_.imu_reset_seconds) {
    if (why)
      *why = "IMU stamp " + messageNumber(s.stamp) + " is " + messageNumber(imu_.newestStamp() - s.stamp) +
             " s behind the previous one: IMU orientation restarted";
    resetImu();
    imu_.add(s);
    return ImuInput::kReset;
  }
  const size_t gaps = imu_.gaps();
  if (!imu_.add(s, why)) return ImuInput::kDropped;
  // Turns that waited for the gyro are read as soon as it covers them, not
  // at the next frame: what they teach (the IMU-to-camera rotation, the
  // bias) then depends on the data alone, not on when frames were tracked.
  readTurns();
  if (imu_.gaps() == gaps) return ImuInput::kAccepted;
  if (why)
    *why = "IMU gap of " + messageNumber(imu_.lastGapSeconds()) + " s before stamp " + messageNumber(s.stamp) +
           ": no orientation inside it; roll and pitch re-levelled from the accelerometer, yaw carried over";
  return ImuInput::kGap;
}

void AnchorManager::resetImu() {
  imu_.reset();
  turns_.clear();
  clearEpipolarFrames();
  slow_turn_ = SlowTurn();
  clearVideoBias();
  bias_applied_at_ = -std::numeric_limits<double>::infinity();
  clearTimeOffsetTurns();
  for (auto& [id, a] : anchors_) a.bound = false;
}

void AnchorManager::update() {
  if (!regions_->lastReset().empty()) {
    anchors_.clear();  // the region manager dropped their regions
    turns_.clear();
    clearEpipolarFrames();
    slow_turn_ = SlowTurn();
    clearVideoBias();  // the new stream's stamps start before the old one's
    bias_applied_at_ = -std::numeric_limits<double>::infinity();
    clearTimeOffsetTurns();
    // A rotation the video showed belongs to the rig, not to the stream: the
    // new stream (a bag loop: stamps from before it was found) has it from
    // its first frame.
    if (rotation_source_ == RotationSource::kVideo)
      rotations_.assign(1, {-std::numeric_limits<double>::infinity(), rotations_.back().second});
  }
  // The newest frame's camera motion, read as a turn of the camera.
  const MotionCache& cache = regions_->cache();
  if (cache.size() >= 2) {
    const MotionData& md = cache.at(cache.lastSeq());
    const double t0 = cache.at(cache.lastSeq() - 1).stamp;
    Eigen::Vector3d theta = Eigen::Vector3d::Zero();
    double rms = 0;
    const bool known = cameraTurn(intrinsics(), md.camera, &theta, &rms);
    if (known) {
      turns_.push_back({t0, md.stamp, theta, rms, md.camera.H});
      time_offset_.add(t0, md.stamp, theta.norm());
    }
    // The IMU's stillness needs the video's agreement (a slow turn feels still).
    imu_.addVideoTurn(t0, md.stamp, theta, known);
    if (epipolarWanted()) addEpipolarFrame(md, t0);
  }
  readTurns();
  if (time_offset_.turns() >= next_offset_fit_) fitTimeOffset();
}

// The world orientation of the anchor: from the IMU at placement, or, when
// the IMU began after placement, at the first frame it covers.
void AnchorManager::tryBind(Anchor& a, double stamp) {
  if (a.bound || imu_.empty()) return;
  Eigen::Matrix3d R;
  if (!imu_.R_world_imu(a.stamp, &R)) {
    if (!(a.stamp + imu_.timeOffset() < imu_.oldestStamp() && imu_.R_world_imu(stamp, &R))) return;
  }
  a.bound = true;
  a.R_world_imu0 = R;
}

bool AnchorManager::add(uint32_t id, double stamp, const cv::Point2d& uv, double depth,
                        uint32_t* assigned_id, std::string* error) {
  if (id != 0 && anchors_.count(id)) {
    *error = alreadyTrackedError("anchor", id);
    return false;
  }
  if (std::string e = validateAnchorRequest(uv, depth); !e.empty()) {  // the one check every door runs
    *error = e;
    return false;
  }
  if (anchors_.size() >= static_cast<size_t>(options_.max_anchors)) {
    *error = "already " + std::to_string(anchors_.size()) + " anchors (anchors.max_anchors): remove some first";
    return false;
  }
  if (!std::isfinite(stamp)) {
    *error = "stamp is not finite";
    return false;
  }
  uint64_t seq;
  if (!regions_->cache().find(stamp, &seq, error)) return false;
  const cv::Size size = regions_->cache().imageSize();
  if (!(uv.x >= 0 && uv.y >= 0 && uv.x <= size.width && uv.y <= size.height)) {
    *error = "pixel (" + messageNumber(uv.x) + ", " + messageNumber(uv.y) + ") is outside the " +
             std::to_string(size.width) + "x" + std::to_string(size.height) + " image";
    return false;
  }
  if (id == 0) {
    id = 1;
    while (anchors_.count(id)) ++id;
  }
  Anchor a;
  a.id = id;
  a.stamp = regions_->cache().at(seq).stamp;
  a.depth = depth > 0 ? depth : options_.default_depth;
  a.side = options_.region_size * std::min(size.width, size.height);
  a.uv0 = uv;
  const cv::Rect2d box(uv.x - a.side / 2, uv.y - a.side / 2, a.side, a.side);
  // A region id the region manager does not hold yet (ids of removed anchors are not reused).
  uint32_t region_id = 0;
  std::string why;
  for (int tries = 0; tries < 1000 && region_id == 0; ++tries) {
    const uint32_t candidate = next_region_id_++;
    if (next_region_id_ < kAnchorRegionBase) next_region_id_ = kAnchorRegionBase;  // wrapped
    if (!regions_->add(candidate, a.stamp, box, &region_id, &why)) {
      if (why.find("already tracked") == std::string::npos) {
        *error = why;
        return false;
      }
      region_id = 0;
    }
  }
  if (region_id == 0) {
    *error = "no free internal region id for the anchor";
    return false;
  }
  a.region_id = region_id;
  tryBind(a, a.stamp);
  anchors_[id] = a;
  *assigned_id = id;
  return true;
}

bool AnchorManager::remove(uint32_t id, std::string* error) {
  const auto it = anchors_.find(id);
  if (it == anchors_.end()) {
    *error = "unknown anchor id " + std::to_string(id);
    return false;
  }
  std::string ignored;  // gone already when a reset cleared the regions
  regions_->remove(it->second.region_id, &ignored);
  anchors_.erase(it);
  return true;
}

void AnchorManager::clear() {
  std::string ignored;
  for (const auto& [id, a] : anchors_) regions_->remove(a.region_id, &ignored);
  anchors_.clear();
}

AnchorState AnchorManager::stateOf(Anchor& a, const RegionState& r, double stamp) {
  tryBind(a, stamp);
  AnchorState s;
  s.id = a.id;
  s.stamp = stamp;
  s.pixel = cv::Point2d(r.box.x + r.box.width / 2, r.box.y + r.box.height / 2);
  s.confidence = r.status == RegionStatus::kLost ? 0.0 : r.confidence;
  // The camera in the world at binding and now, through the IMU -> camera
  // rotation in use at this frame; without the IMU or the rotation, the
  // image's up stands in for the world's (orientation relative to placement).
  const Eigen::Quaterniond* q = rotationAt(stamp);
  Eigen::Matrix3d R_wi;
  const bool imu_ok = a.bound && imu_.R_world_imu(stamp, &R_wi);
  const bool oriented = imu_ok && q;
  const Eigen::Matrix3d R_ic = q ? Eigen::Matrix3d(q->toRotationMatrix().transpose()) : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d R_world_cam0 = oriented ? Eigen::Matrix3d(a.R_world_imu0 * R_ic) : kImageUpStandIn;
  const Eigen::Matrix3d R_wc = oriented ? Eigen::Matrix3d(R_wi * R_ic) : R_world_cam0;
  const bool estimate = r.status != RegionStatus::kLost && r.box.width > 0;
  double scale_ratio = 1.0;
  if (estimate) {
    // The surface's normal (world up) in the camera at placement and now,
    // when the IMU gives both; else the patch is taken as facing the camera.
    const CameraModel K = intrinsics();
    const bool tilt = options_.surface == "horizontal" && oriented;
    const Eigen::Vector3d up0 = R_world_cam0.transpose() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d up = R_wc.transpose() * Eigen::Vector3d::UnitZ();
    scale_ratio = a.side / r.box.width * patchSizeFactor(s.pixel, K, tilt ? &up : nullptr) /
                  patchSizeFactor(a.uv0, K, tilt ? &up0 : nullptr);
  }
  s.T_cam_anchor = anchorPose(s.pixel, scale_ratio, a.depth, intrinsics(), R_wc, anchorOrientation(R_world_cam0));
  if (!estimate) {
    s.status = AnchorStatus::kLost;
    s.reason = r.reason.empty() ? "its region is lost" : "region lost: " + r.reason;
  } else if (!imu_ok) {
    s.status = AnchorStatus::kNoImu;
    if (imu_.empty())
      s.reason = "no IMU sample";
    else if (!a.bound)
      s.reason = "the IMU has not covered the anchor's frame yet";
    else
      s.reason = "no IMU orientation at stamp " + messageNumber(stamp) + " (IMU spans " +
                 messageNumber(imu_.oldestStamp()) + " .. " + messageNumber(imu_.newestStamp()) +
                 (imu_.timeOffset() != 0
                      ? ", read at image stamp + " + messageNumber(imu_.timeOffset()) + " s)"
                      : ")");
  } else if (!q) {
    s.status = AnchorStatus::kCalibrating;
    s.reason = "the IMU-to-camera rotation is not known yet: no tf between the IMU and the camera, no "
               "anchors.rotation_cam_imu, and the video has not shown enough turns about two axes (" +
               std::to_string(video_rotation_.pairs()) + " turns so far)";
  } else {
    s.status =
        r.status == RegionStatus::kOutOfView ? AnchorStatus::kOutOfView : AnchorStatus::kTracked;
  }
  return s;
}

std::vector<uint32_t> AnchorManager::ids() const {
  std::vector<uint32_t> out;
  for (const auto& [id, a] : anchors_) out.push_back(id);
  return out;
}

bool AnchorManager::statesAt(double stamp, const std::vector<uint32_t>& ids,
                            std::vector<AnchorState>* states, std::string* error) {
  std::vector<Anchor*> wanted;
  if (ids.empty()) {
    for (auto& [id, a] : anchors_) wanted.push_back(&a);
  } else {
    for (uint32_t id : ids) {
      const auto it = anchors_.find(id);
      if (it == anchors_.end()) {
        *error = "unknown anchor id " + std::to_string(id);
        return false;
      }
      wanted.push_back(&it->second);
    }
  }
  if (!std::isfinite(stamp)) {
    *error = "stamp is not finite";
    return false;
  }
  uint64_t seq;
  if (!regions_->cache().find(stamp, &seq, error)) return false;
  const double frame_stamp = regions_->cache().at(seq).stamp;
  states->clear();
  for (Anchor* a : wanted) {
    std::vector<RegionState> r;
    if (!regions_->statesAt(frame_stamp, {a->region_id}, &r, error)) {
      *error = "anchor " + std::to_string(a->id) + ": " + *error;
      return false;
    }
    states->push_back(stateOf(*a, r[0], frame_stamp));
  }
  return true;
}

bool AnchorManager::ready(double stamp, double newest_frame_stamp) const {
  if (anchors_.empty() || imu_.empty() || imu_.newestStamp() >= stamp + imu_.timeOffset()) return true;
  return newest_frame_stamp - stamp >= options_.imu_wait_seconds;
}

}  // namespace imt
