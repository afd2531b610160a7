// The anchors' calibration from the video: the gyro's turns read against
// the camera's, for the IMU-to-camera rotation, the gyro bias and the
// camera-IMU time offset (AnchorManager's private half; see its header).
#include "instant_motion_tracking/core/anchor/anchor_manager.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace imt {

void AnchorManager::clearTimeOffsetTurns() {
  // The offset found stays (it is the rig's); the turns of the old stream go.
  time_offset_.clear();
  next_offset_fit_ = time_offset_.options().min_turns;
}

void AnchorManager::fitTimeOffset() {
  next_offset_fit_ = time_offset_.turns() + kOffsetRefitTurns;
  const TimeOffsetFit fit = time_offset_.fit([this](double s0, double s1, double* angle) {
    Eigen::Matrix3d turn;
    if (!imu_.turnAtImuStamps(s0, s1, &turn)) return false;
    *angle = Eigen::AngleAxisd(turn).angle();
    return true;
  });
  if (fit.turns > 0) time_offset_fit_ = fit;
  // Applied from now on (the frames before keep what they had, live and
  // offline alike); a change under a millisecond is noise. Once the bias
  // fit reads the lateness sharply (imu.video_bias, frames the turn
  // explains) it refines any offset within its reach, and the correlation,
  // biased by the scene (+14 ms on the rendered floor walk with the IMU on
  // time), only moves one beyond it; until then the correlation's is used.
  const bool bias_fit_reads = offset_source_ == OffsetSource::kBiasFit || std::isfinite(last_implied_offset_);
  const double change = std::abs(fit.offset - imu_.timeOffset());
  const double least = bias_fit_reads ? kOffsetCorrelationReach : kOffsetMinChange;
  if (options_.estimate_imu_time_offset && fit.found && change >= least) {
    imu_.setTimeOffset(fit.offset);  // the bias's frames keep the offset they were read at
    offset_source_ = OffsetSource::kCorrelation;
  }
}

void AnchorManager::readTurns() {
  // The gyro's turn over each interval it covers now; the video's turns
  // wait for it (live, the IMU may lag the frames).
  // The features' epipolar frames are read in the same order, each after
  // the turns before it and before the turns after it (gyroCovers).
  while (!turns_.empty() && gyroCovers(turns_.front().t1)) {
    const Turn t = turns_.front();
    turns_.pop_front();
    readEpipolarFrames(t.t1);
    Eigen::Matrix3d turn;  // the IMU at t1 in the IMU at t0
    if (!imuTurn(t.t0, t.t1, &turn)) continue;
    // The turn over the floor, read once for both that want it.
    const bool reads_bias = readsVideoBias(t.t1);
    Eigen::Vector3d over_floor;
    const bool floor_ok = (rotation_source_ == RotationSource::kVideo || reads_bias) && floorTurn(t, &over_floor);
    addRotationTurn(t, turn, floor_ok && rotation_source_ == RotationSource::kVideo ? &over_floor : nullptr);
    // (No bias reading where neither the floor nor a turn explains the background.)
    if (floor_ok && reads_bias) addBiasTurn(t, turn, over_floor);
    if (++bias_turns_since_fit_ >= kVideoBiasRefitTurns) {
      bias_turns_since_fit_ = 0;
      fitVideoBias(t.t1);
    }
    const auto estimate = video_rotation_.estimate();
    if (!estimate) continue;
    const bool first = rotation_source_ == RotationSource::kNone;
    // Over the epipolar fit's only within kRotationDisagreementDeg of it:
    // the turns are what the travel biases, and once found the turns read
    // over the floor refine it (the rendered floor walk: 0.32 -> 0.06 deg).
    const bool agrees = !epipolar_used_ || epipolar_used_->angularDistance(*estimate) * 180 / M_PI <=
                                               kRotationDisagreementDeg;
    const bool moved = rotation_source_ == RotationSource::kVideo && agrees &&
                       rotations_.back().second.angularDistance(*estimate) * 180 / M_PI > kRotationUpdateDeg;
    if (first || moved) useRotation(*estimate, RotationSource::kVideo, t.t1);
  }
  // Bounded: turns the gyro never covers (an IMU that stopped) are dropped.
  while (turns_.size() > kMaxWaitingTurns) turns_.pop_front();
  readEpipolarFrames(std::numeric_limits<double>::infinity());
}

void AnchorManager::addEpipolarFrame(const MotionData& md, double t0) {
  const CameraModel k = intrinsics();
  if (!k.valid || md.camera.model == MotionModel::kInvalid || !md.camera.H.allFinite()) return;
  const Eigen::Matrix3d H_inv = md.camera.H.inverse(), K_inv = k.K().inverse();
  if (!H_inv.allFinite()) return;
  // A row is read readout * (y / height - 0.5) after the middle row, which
  // the image's stamp (plus the time offset) stands for (rows top to bottom).
  const double readout = options_.rolling_shutter_readout;
  const auto rowTime = [&](double stamp, double y) { return stamp + readout * (y / k.height - 0.5); };
  std::vector<const FeatureMotion*> moving;  // new this frame: no motion yet
  for (const FeatureMotion& f : md.features)
    if (f.age > 0) moving.push_back(&f);
  EpipolarFrame frame;
  frame.t1 = md.stamp;
  frame.focal_px = k.fx;
  const size_t keep = std::min(moving.size(), static_cast<size_t>(epipolar_rotation_.options().max_pairs_per_frame));
  for (size_t i = 0; i < keep; ++i) {
    const FeatureMotion& f = *moving[i * moving.size() / keep];  // evenly over the list
    // Where it was: the camera motion's preimage of where it would be without its own motion.
    const Eigen::Vector3d q = H_inv * Eigen::Vector3d(f.x - f.dx, f.y - f.dy, 1);
    if (!(q.z() > 0)) continue;
    const cv::Point2d p0 = k.undistort(cv::Point2d(q.x() / q.z(), q.y() / q.z())), p1 = k.undistort(cv::Point2d(f.x, f.y));
    EpipolarPair pair;
    pair.ray0 = K_inv * Eigen::Vector3d(p0.x, p0.y, 1);
    pair.ray1 = K_inv * Eigen::Vector3d(p1.x, p1.y, 1);
    frame.pairs.push_back(pair);
    frame.times.emplace_back(rowTime(t0, q.y() / q.z()), rowTime(md.stamp, f.y));
  }
  epipolar_frames_.push_back(std::move(frame));
  while (epipolar_frames_.size() > kMaxWaitingTurns) epipolar_frames_.pop_front();
}

void AnchorManager::readEpipolarFrames(double before) {
  while (!epipolar_frames_.empty() && epipolar_frames_.front().t1 < before && gyroCovers(epipolar_frames_.front().t1)) {
    EpipolarFrame frame = std::move(epipolar_frames_.front());
    epipolar_frames_.pop_front();
    if (!epipolarWanted()) continue;
    // Each pair's gyro turn over its own rows' times, read once, now.
    std::vector<EpipolarPair> pairs;
    for (size_t i = 0; i < frame.pairs.size(); ++i) {
      Eigen::Matrix3d turn;
      if (!imuTurn(frame.times[i].first, frame.times[i].second, &turn)) continue;
      pairs.push_back(frame.pairs[i]);
      pairs.back().theta_imu = rotationVector(turn);
    }
    epipolar_rotation_.addFrame(pairs, frame.focal_px);
    if (++epipolar_since_fit_ < epipolar_interval_) continue;
    const auto start = video_rotation_.bestFit();
    if (!start) continue;
    epipolar_since_fit_ = 0;
    const auto fit = epipolar_rotation_.fit(*start);
    if (!fit) continue;
    epipolar_fit_ = fit;
    if (fit->sharp) {
      // Used where no rotation is known, or where it disagrees with the
      // turns' (which the travel biases) by more than kRotationDisagreementDeg;
      // a sharp fit that agrees confirms the turns'. Either way the
      // epipolar fits end here.
      const bool disagrees = rotation_source_ == RotationSource::kVideo &&
                             rotations_.back().second.angularDistance(fit->R_cam_imu) * 180 / M_PI >
                                 kRotationDisagreementDeg;
      if (rotation_source_ == RotationSource::kNone || disagrees) {
        useRotation(fit->R_cam_imu, RotationSource::kVideo, frame.t1);
        epipolar_used_ = fit->R_cam_imu;
      }
      epipolar_done_ = true;
      epipolar_frames_.clear();
      epipolar_rotation_.clear();
    } else {
      // Not sharp three times (a straight drive): wait longer before the next, up to 8 times.
      if (++epipolar_refused_ >= 3) epipolar_interval_ = std::min(2 * epipolar_interval_, 8 * kEpipolarRefitFrames);
    }
  }
}

bool AnchorManager::epipolarWanted() const {
  return !epipolar_done_ && (rotation_source_ == RotationSource::kNone || rotation_source_ == RotationSource::kVideo);
}

void AnchorManager::clearEpipolarFrames() {
  epipolar_frames_.clear();
  epipolar_rotation_.clear();
  epipolar_since_fit_ = 0;
  epipolar_interval_ = kEpipolarRefitFrames;
  epipolar_refused_ = 0;
}

bool AnchorManager::gyroCovers(double t1) const {
  // The rows' latest, with a rolling shutter: one wait for the turns and the
  // epipolar frames, so they are read in the same order however late the gyro comes.
  return !imu_.empty() && t1 + options_.rolling_shutter_readout / 2 + imu_.timeOffset() <= imu_.newestStamp();
}

bool AnchorManager::imuTurn(double t0, double t1, Eigen::Matrix3d* turn) const {
  // Not before the IMU began, nor across a gap.
  return !imu_.acrossGap(t0, t1) && imu_.turnAtImuStamps(t0 + imu_.timeOffset(), t1 + imu_.timeOffset(), turn);
}

void AnchorManager::addRotationTurn(const Turn& frame_turn, const Eigen::Matrix3d& R_imu0_imu1,
                                    const Eigen::Vector3d* over_floor) {
  // Once the video has found a rotation, its turns are read over the floor
  // where that explains the background better (`over_floor`, floorTurn()
  // with the IMU's up from that rotation): a turn-and-zoom fit reads a walk over the floor
  // as a turn about the camera's x axis, which on a slow walk is as large as
  // the turns themselves (the rotation 0.46 deg off at the end of a 30-s
  // slow walk against 0.06 deg over the floor, and 0.34 against 0.06 on the
  // ordinary walk).
  Turn t = frame_turn;
  if (over_floor) t.theta_cam = *over_floor;
  const double min_angle = video_rotation_.options().min_angle;
  const Eigen::Vector3d theta_imu = rotationVector(R_imu0_imu1);
  if (t.theta_cam.norm() >= min_angle && theta_imu.norm() >= min_angle) {
    video_rotation_.add(t.theta_cam, theta_imu);
    slow_turn_ = SlowTurn();
    return;
  }
  // A slow turn: composed with the slow ones just before it.
  if (slow_turn_.frames > 0 && (t.t0 != slow_turn_.t1 || slow_turn_.frames >= kMaxSlowTurns)) slow_turn_ = SlowTurn();
  if (slow_turn_.frames == 0) slow_turn_.t0 = t.t0;
  slow_turn_.R_cam = slow_turn_.R_cam * quaternionExp(t.theta_cam).toRotationMatrix();
  slow_turn_.t1 = t.t1;
  ++slow_turn_.frames;
  const Eigen::Vector3d theta_cam = rotationVector(slow_turn_.R_cam);
  if (theta_cam.norm() < min_angle) return;
  Eigen::Matrix3d turn;
  if (imuTurn(slow_turn_.t0, slow_turn_.t1, &turn)) video_rotation_.add(theta_cam, rotationVector(turn));
  slow_turn_ = SlowTurn();
}

bool AnchorManager::floorTurn(const Turn& t, Eigen::Vector3d* theta_cam) const {
  // Over the floor (the IMU's up as the plane's normal) or as a turn and a
  // zoom (the turn's own, cameraTurn), whichever explains the background's
  // motion better; neither within kVideoBiasMaxRmsPx: false.
  Eigen::Matrix3d R_plane;
  double rms_plane = std::numeric_limits<double>::infinity();
  if (!rotationFromPlaneHomography(intrinsics(), t.H, imu_.upInCamera(t.t0), &R_plane, &rms_plane))
    rms_plane = std::numeric_limits<double>::infinity();
  if (!(std::min(rms_plane, t.rms_px) <= kVideoBiasMaxRmsPx)) return false;
  // R maps rays at t0 to rays at t1: the camera at t1 in the camera at t0 is R^T.
  *theta_cam = rms_plane <= t.rms_px ? rotationVector(R_plane.transpose()) : t.theta_cam;
  return true;
}

bool AnchorManager::readsVideoBias(double t1) const {
  const ImuOptions& o = imu_.options();
  return o.video_bias && o.estimate_gyro_bias && !o.use_fused_orientation && rotationAt(t1);
}

void AnchorManager::addBiasTurn(const Turn& t, const Eigen::Matrix3d& R_imu0_imu1, const Eigen::Vector3d& theta_cam) {
  const double dt = t.t1 - t.t0;
  // The gyro's turn with the bias in use put back (the window was integrated with it).
  video_bias_.add(t.t1, dt, rotationVector(R_imu0_imu1) + imu_.gyroBias() * dt, theta_cam, imu_.timeOffset());
}

void AnchorManager::fitVideoBias(double t1) {
  const Eigen::Quaterniond* q = rotationAt(t1);
  if (!q) return;
  video_bias_estimate_ = video_bias_.estimate(q->toRotationMatrix().transpose(),
                                              rotation_source_ == RotationSource::kVideo);
  if (!video_bias_estimate_) return;
  const VideoGyroBias::Estimate& e = *video_bias_estimate_;
  if (e.sigma.maxCoeff() <= kVideoBiasMaxSigma) {
    const double at = t1 + imu_.timeOffset();
    const double from = std::max(bias_applied_at_, at - kVideoBiasReach * imu_.options().window_seconds);
    if (imu_.setVideoGyroBias(e.bias, from, at)) bias_applied_at_ = at;
  }
  // Its lateness: the newest frame's offset less the true one. Where the
  // video found the rotation, only once the last two sharp fits agree on
  // the offset they imply: there the lateness and a correction of the rotation
  // are fitted together, and while the rotation is young the one passes for
  // the other (the rendered walk, IMU on time: -6 +- 1.8 ms 3 s in, then
  // +1.7); an offset applied then mistimes the rotation's own pairs.
  const double implied = video_bias_.newestOffset() - e.lateness;
  const bool sharp = e.lateness_sigma <= kOffsetMaxLatenessSigma;
  const bool agrees = std::abs(implied - last_implied_offset_) <= std::max(kOffsetMinChange, 3 * e.lateness_sigma);
  if (sharp) last_implied_offset_ = implied;
  if (options_.estimate_imu_time_offset && sharp && (rotation_source_ != RotationSource::kVideo || agrees) &&
      std::abs(e.lateness) >= kOffsetMinChange && imu_.setTimeOffset(implied))
    offset_source_ = OffsetSource::kBiasFit;
}

void AnchorManager::clearVideoBias() {
  video_bias_.clear();
  last_implied_offset_ = std::numeric_limits<double>::quiet_NaN();
  bias_turns_since_fit_ = 0;
}

}  // namespace imt
