#include "instant_motion_tracking/core/anchor/imu_orientation.h"

#include "option_checker.h"

#include <algorithm>
#include <cmath>
#include <sstream>

namespace imt {
namespace {

std::string vec(const Eigen::Vector3d& v) {
  std::ostringstream os;
  os << "(" << v.x() << ", " << v.y() << ", " << v.z() << ")";
  return os.str();
}

}  // namespace

Eigen::Vector3d rotationVector(const Eigen::Matrix3d& R) {
  const Eigen::AngleAxisd a(R);
  return a.angle() * a.axis();
}

Eigen::Quaterniond quaternionExp(const Eigen::Vector3d& w) {
  const double theta = w.norm();
  const double half = 0.5 * theta;
  double k;  // sin(theta/2) / theta
  if (theta < 1e-6)
    k = 0.5 - theta * theta / 48.0;  // Taylor, error O(theta^4)
  else
    k = std::sin(half) / theta;
  Eigen::Quaterniond q(std::cos(half), k * w.x(), k * w.y(), k * w.z());
  q.normalize();
  return q;
}

std::string ImuOptions::validate() const {
  OptionChecker c("imu");
  for (const auto& [name, v] : {std::pair<const char*, double>{"gyro_bias_x", gyro_bias_x},
                                {"gyro_bias_y", gyro_bias_y},
                                {"gyro_bias_z", gyro_bias_z}})
    c.check(std::isfinite(v) && std::abs(v) < 10, name, "must be finite and |.| < 10 rad/s", v);
  c.inRange("still_seconds", still_seconds, 0.05, 3600.0);
  c.inRange("still_block_seconds", still_block_seconds, 0.0, still_seconds);
  c.check(still_gyro_max > 0 && still_gyro_max <= 10, "still_gyro_max", "must be in (0, 10]", still_gyro_max);
  c.check(still_gyro_tight > 0 && still_gyro_tight <= still_gyro_max, "still_gyro_tight",
          "must be in (0, still_gyro_max]", still_gyro_tight);
  c.inRange("still_replace_seconds", still_replace_seconds, still_seconds, 3600.0);
  c.check(still_accel_max > 0 && still_accel_max <= 100, "still_accel_max", "must be in (0, 100]", still_accel_max);
  c.check(still_video_rate > 0 && still_video_rate <= 1, "still_video_rate", "must be in (0, 1]", still_video_rate);
  c.inRange("video_bias_seconds", video_bias_seconds, 1.0, 3600.0);
  c.inRange("gravity", gravity, 1.0, 100.0);
  c.check(max_gyro > 0 && max_gyro <= 1000, "max_gyro", "must be in (0, 1000] rad/s", max_gyro);
  c.check(max_accel > gravity && max_accel <= 10000, "max_accel", "must be in (gravity, 10000] m/s^2", max_accel);
  c.inRange("window_seconds", window_seconds, 0.1, 3600.0);
  c.check(max_gap_seconds > 0 && max_gap_seconds <= 10, "max_gap_seconds", "must be in (0, 10]", max_gap_seconds);
  return c.error();
}

ImuOrientation::ImuOrientation(const ImuOptions& options) : options_(validated(options)) {
  bias_ = options_.gyroBias();
}

void ImuOrientation::reset() {
  window_.clear();
  bias_ = options_.gyroBias();
  bias_source_ = BiasSource::kFixed;
  estimate_seconds_ = 0;
  still_count_ = 0;
  block_count_ = 0;
  still_confirmed_ = false;
  initial_stretch_ = false;
  gaps_ = 0;
  gap_stamps_.clear();
  jumps_.clear();
  last_gap_ = 0;
  video_.clear();
}

void ImuOrientation::endStretch() {
  still_count_ = 0;
  still_confirmed_ = false;
  initial_stretch_ = false;
}

void ImuOrientation::addVideoTurn(double t0, double t1, const Eigen::Vector3d& theta, bool known) {
  if (!options_.still_needs_video || !std::isfinite(t0) || !std::isfinite(t1) || !(t1 > t0)) return;
  VideoTurn v;  // on the IMU's clock
  v.t0 = t0 + offset_;
  v.t1 = t1 + offset_;
  v.theta = known && theta.allFinite() ? theta : Eigen::Vector3d::Zero();
  v.turned = !known || !theta.allFinite() || theta.norm() / (t1 - t0) >= 4 * options_.still_video_rate;
  video_.push_back(v);
  // Kept as long as the IMU's window (and bounded if the IMU stopped).
  const double oldest = (window_.empty() ? v.t1 : std::max(v.t1, window_.back().stamp)) - options_.window_seconds;
  while (!video_.empty() && (video_.front().t1 < oldest || video_.size() > 100000)) video_.pop_front();
}

ImuOrientation::Video ImuOrientation::videoOnStretch(double needed) const {
  // The frames inside the stretch (the video may have reported them before
  // or after the IMU's samples): any that turned ends it; else it is still
  // once they cover `needed` seconds of it, with at most a fifth missing,
  // and turn under still_video_rate on average.
  double covered = 0, until = still_start_;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const VideoTurn& v : video_) {
    if (v.t1 <= still_start_) continue;
    if (v.turned) return Video::kTurned;
    const double part = v.t1 - std::max(v.t0, still_start_);
    covered += part;
    sum += v.theta * (part / (v.t1 - v.t0));
    until = std::max(until, v.t1);
  }
  const double span = until - still_start_;
  if (span < needed || covered < 0.8 * span) return Video::kWait;
  return sum.norm() / covered < options_.still_video_rate ? Video::kStill : Video::kTurned;
}

bool ImuOrientation::setRotationCamImu(const Eigen::Quaterniond& R_cam_imu) {
  const double n = R_cam_imu.norm();
  if (!R_cam_imu.coeffs().allFinite() || !(n > 0.5 && n < 1.5)) return false;
  q_cam_imu_ = R_cam_imu.normalized();
  return true;
}

Eigen::Quaterniond ImuOrientation::levelFromAccel(const Eigen::Vector3d& accel) const {
  // The smallest rotation taking measured "up" onto world +z (yaw arbitrary).
  return Eigen::Quaterniond::FromTwoVectors(accel, Eigen::Vector3d::UnitZ()).normalized();
}

Eigen::Quaterniond ImuOrientation::integrate(const Entry& prev, const Eigen::Vector3d& gyro,
                                             double stamp) const {
  const double dt = stamp - prev.stamp;
  const Eigen::Vector3d w = 0.5 * (prev.gyro + gyro) - bias_;
  return (prev.q_world_imu * quaternionExp(w * dt)).normalized();
}

bool ImuOrientation::add(const ImuSample& s, std::string* why) {
  auto fail = [&](const std::string& msg) {
    if (why) *why = msg;
    return false;
  };
  if (!std::isfinite(s.stamp)) return fail("IMU sample dropped: stamp is not finite");
  if (!s.gyro.allFinite()) return fail("IMU sample dropped: gyro " + vec(s.gyro) + " is not finite");
  if (!s.accel.allFinite()) return fail("IMU sample dropped: accel " + vec(s.accel) + " is not finite");
  // Finite but beyond any sensor's range: a broken reading, which would tilt
  // "up" or turn the orientation at once.
  if (s.gyro.norm() > options_.max_gyro)
    return fail("IMU sample dropped: gyro " + vec(s.gyro) + " is over imu.max_gyro (" +
                std::to_string(options_.max_gyro) + " rad/s)");
  if (s.accel.norm() > options_.max_accel)
    return fail("IMU sample dropped: accel " + vec(s.accel) + " is over imu.max_accel (" +
                std::to_string(options_.max_accel) + " m/s^2)");
  const bool fused = options_.use_fused_orientation && s.has_orientation;
  if (s.has_orientation) {
    const double n = s.orientation.norm();
    if (!s.orientation.coeffs().allFinite() || !(n > 0.5 && n < 1.5)) {
      if (fused) return fail("IMU sample dropped: orientation is not a finite unit quaternion");
    }
  }
  if (!window_.empty() && !(s.stamp > window_.back().stamp)) {
    std::ostringstream os;
    os.precision(17);
    os << "IMU sample dropped: stamp " << s.stamp << " is not after the previous one "
       << window_.back().stamp;
    return fail(os.str());
  }

  Entry e;
  e.stamp = s.stamp;
  e.gyro = s.gyro;
  e.fused = fused;
  if (fused) {
    e.q_world_imu = s.orientation.normalized();
  } else if (window_.empty()) {
    if (!(s.accel.norm() > 1e-3 * options_.gravity))
      return fail("IMU sample dropped: zero accelerometer reading, cannot level the first orientation");
    e.q_world_imu = levelFromAccel(s.accel);
  } else if (s.stamp - window_.back().stamp > options_.max_gap_seconds) {
    // A gap: the orientation before it, re-levelled onto this reading.
    const Eigen::Quaterniond& q = window_.back().q_world_imu;
    e.after_gap = true;
    e.q_world_imu = q;
    if (s.accel.norm() > 1e-3 * options_.gravity)
      e.q_world_imu = (Eigen::Quaterniond::FromTwoVectors(q * s.accel, Eigen::Vector3d::UnitZ()) * q).normalized();
    ++gaps_;
    gap_stamps_.push_back(s.stamp);
    last_gap_ = s.stamp - window_.back().stamp;
    block_count_ = 0;  // stillness starts over
    endStretch();
  } else {
    e.q_world_imu = integrate(window_.back(), s.gyro, s.stamp);
  }
  const bool first = window_.empty();
  window_.push_back(e);
  if (first) initial_stretch_ = true;
  updateStill(s);
  prune();
  return true;
}

void ImuOrientation::updateStill(const ImuSample& s) {
  // Stillness is judged on block means: vibration (motors, hand tremor)
  // averages out, slow rotation does not.
  if (block_count_ == 0) {
    block_start_ = s.stamp;
    block_gyro_sum_.setZero();
    block_accel_sum_.setZero();
  }
  ++block_count_;
  block_gyro_sum_ += s.gyro;
  block_accel_sum_ += s.accel;
  if (s.stamp - block_start_ < options_.still_block_seconds) return;

  const double n = static_cast<double>(block_count_);
  const Eigen::Vector3d mg = block_gyro_sum_ / n, ma = block_accel_sum_ / n;
  block_count_ = 0;
  // Once a bias is known, only small deviations from it count as still.
  const double gmax = biasEstimated() ? options_.still_gyro_tight : options_.still_gyro_max;
  const bool quiet = (mg - bias_).norm() < gmax &&
                     std::abs(ma.norm() - options_.gravity) < options_.still_accel_max;
  if (!quiet) {
    endStretch();
    return;
  }
  if (still_count_ == 0 || (ma - still_accel_first_).norm() >= options_.still_accel_max) {
    // (Re)start a stretch with this block.
    if (still_count_ > 0) initial_stretch_ = false;
    still_count_ = 0;
    still_confirmed_ = false;
    still_start_ = block_start_;
    still_gyro_sum_.setZero();
    still_accel_sum_.setZero();
    still_accel_first_ = ma;
  }
  still_count_ += static_cast<size_t>(n);
  still_gyro_sum_ += n * mg;
  still_accel_sum_ += n * ma;
  if (!options_.estimate_gyro_bias) return;
  // A new stretch replaces an earlier estimate only once it is about as long
  // as the one behind it (a short hover or a slow turn must not undo it).
  double needed = options_.still_seconds;
  if (biasEstimated() && !still_confirmed_)
    needed = std::max(needed, std::min(estimate_seconds_, options_.still_replace_seconds));
  const double lasted = s.stamp - still_start_;
  if (lasted < needed) return;
  if (options_.still_needs_video) {
    const Video v = videoOnStretch(needed);
    if (v == Video::kTurned) endStretch();  // the next quiet block begins another
    if (v != Video::kStill) return;
  }
  bias_ = still_gyro_sum_ / static_cast<double>(still_count_);
  bias_source_ = BiasSource::kStill;
  estimate_seconds_ = lasted;
  if (!still_confirmed_) {
    still_confirmed_ = true;
    // The stretch so far was integrated with the old bias: redo it.
    if (initial_stretch_ && !window_.front().fused && window_.front().stamp == still_start_)
      window_.front().q_world_imu = levelFromAccel(still_accel_sum_);
    reintegrateFrom(still_start_);
  }
}

const char* ImuOrientation::biasSourceName(BiasSource s) {
  switch (s) {
    case BiasSource::kStill: return "still";
    case BiasSource::kVideo: return "video";
    case BiasSource::kFixed: break;
  }
  return "fixed";
}

bool ImuOrientation::setVideoGyroBias(const Eigen::Vector3d& bias, double from, double at) {
  if (!options_.estimate_gyro_bias || biasEstimated() || !bias.allFinite() || !(bias.norm() <= options_.max_gyro))
    return false;
  bias_ = bias;
  bias_source_ = BiasSource::kVideo;
  if (window_.empty() || !std::isfinite(at)) return true;
  // The last sample at or before `at`: its orientation is the one the new
  // bias gives from `from` (when the samples in between allow it); the
  // samples after it are integrated again.
  auto last = std::upper_bound(window_.begin(), window_.end(), at,
                               [](double t, const Entry& e) { return t < e.stamp; });
  if (last == window_.begin()) {
    // Every sample is after `at`: all of them take the new bias.
    reintegrateFrom(window_.front().stamp);
    return true;
  }
  --last;
  auto first = std::lower_bound(window_.begin(), window_.end(), std::isfinite(from) ? from : at,
                                [](const Entry& e, double t) { return e.stamp < t; });
  if (first < last) {
    Eigen::Quaterniond q = first->q_world_imu;
    bool usable = true;
    for (auto cur = std::next(first); cur <= last && usable; ++cur) {
      usable = !cur->fused && !cur->after_gap;
      Entry prev = *std::prev(cur);
      prev.q_world_imu = q;
      q = integrate(prev, cur->gyro, cur->stamp);
    }
    if (usable) {
      jumps_.emplace_back(last->stamp, (q * last->q_world_imu.inverse()).normalized());
      last->q_world_imu = q;
    }
  }
  reintegrateFrom(last->stamp);
  return true;
}

void ImuOrientation::reintegrateFrom(double stamp) {
  auto it = std::lower_bound(window_.begin(), window_.end(), stamp,
                             [](const Entry& e, double t) { return e.stamp < t; });
  if (it == window_.end()) return;
  for (auto cur = std::next(it); cur != window_.end(); ++cur) {
    if (cur->fused || cur->after_gap) continue;
    cur->q_world_imu = integrate(*std::prev(cur), cur->gyro, cur->stamp);
  }
}

void ImuOrientation::prune() {
  const double oldest = window_.back().stamp - options_.window_seconds;
  // Keep the last entry at or before `oldest`, so [newest - window_seconds,
  // newest] stays answerable.
  while (window_.size() > 2 && window_[1].stamp <= oldest) window_.pop_front();
  while (!gap_stamps_.empty() && gap_stamps_.front() <= window_.front().stamp) gap_stamps_.pop_front();
  while (!jumps_.empty() && jumps_.front().first <= window_.front().stamp) jumps_.pop_front();
}

bool ImuOrientation::setTimeOffset(double seconds) {
  if (!std::isfinite(seconds) || std::abs(seconds) > 1) return false;
  offset_ = seconds;
  return true;
}

bool ImuOrientation::atImuStamp(double t, Eigen::Matrix3d* R) const {
  if (window_.empty() || !std::isfinite(t) || t < window_.front().stamp || t > window_.back().stamp)
    return false;
  auto it = std::lower_bound(window_.begin(), window_.end(), t,
                             [](const Entry& e, double x) { return e.stamp < x; });
  if (it->stamp == t || it == window_.begin()) {
    if (R) *R = it->q_world_imu.toRotationMatrix();
    return true;
  }
  const Entry& b = *it;
  const Entry& a = *std::prev(it);
  if (b.after_gap) return false;  // inside a gap: unknown
  const double u = (t - a.stamp) / (b.stamp - a.stamp);
  if (R) *R = a.q_world_imu.slerp(u, b.q_world_imu).toRotationMatrix();
  return true;
}

bool ImuOrientation::R_world_cam(double t, Eigen::Matrix3d* R) const {
  Eigen::Matrix3d R_wi;
  if (!R_world_imu(t, &R_wi)) return false;
  if (R) *R = q_cam_imu_ ? R_wi * q_cam_imu_->toRotationMatrix().transpose() : R_wi;
  return true;
}

bool ImuOrientation::turnAtImuStamps(double s0, double s1, Eigen::Matrix3d* R) const {
  if (s1 < s0) {
    if (!turnAtImuStamps(s1, s0, R)) return false;
    if (R) R->transposeInPlace();
    return true;
  }
  Eigen::Matrix3d A, B;
  if (!atImuStamp(s0, &A) || !atImuStamp(s1, &B)) return false;
  // The corrections in (s0, s1] taken off B, the latest first.
  for (auto j = jumps_.rbegin(); j != jumps_.rend(); ++j)
    if (j->first > s0 && j->first <= s1) B = j->second.inverse().toRotationMatrix() * B;
  if (R) *R = A.transpose() * B;
  return true;
}

bool ImuOrientation::acrossGap(double t1, double t2) const {
  const auto gap = std::upper_bound(gap_stamps_.begin(), gap_stamps_.end(), std::min(t1, t2) + offset_);
  return gap != gap_stamps_.end() && *gap <= std::max(t1, t2) + offset_;
}

bool ImuOrientation::R_cam1_cam2(double t1, double t2, Eigen::Matrix3d* R) const {
  if (acrossGap(t1, t2)) return false;
  Eigen::Matrix3d R12;
  if (!turnAtImuStamps(t1 + offset_, t2 + offset_, &R12)) return false;
  // The camera's turn: the IMU's in the camera's axes.
  const Eigen::Matrix3d R_ci = q_cam_imu_ ? q_cam_imu_->toRotationMatrix() : Eigen::Matrix3d::Identity();
  if (R) *R = R_ci * R12 * R_ci.transpose();
  return true;
}

bool ImuOrientation::rotationHomography(const Eigen::Matrix3d& K, double t1, double t2,
                                        Eigen::Matrix3d* H) const {
  Eigen::Matrix3d R12;
  if (!K.allFinite() || std::abs(K.determinant()) < 1e-12) return false;
  if (!R_cam1_cam2(t1, t2, &R12)) return false;
  // x2 ~ K R_cam2_cam1 K^-1 x1.
  Eigen::Matrix3d h = K * R12.transpose() * K.inverse();
  if (!(std::abs(h(2, 2)) > 1e-12)) return false;
  if (H) *H = h / h(2, 2);
  return true;
}

bool ImuOrientation::rotationHomography(const CameraModel& k, double t1, double t2,
                                        Eigen::Matrix3d* H) const {
  Eigen::Matrix3d h;
  if (!rotationHomography(k.K(), t1, t2, &h)) return false;
  if (H) *H = k.imageHomography(h);
  return true;
}

Eigen::Vector3d ImuOrientation::upInCamera(double t) const {
  Eigen::Matrix3d R;
  if (!R_world_cam(t, &R)) return Eigen::Vector3d::Zero();
  return R.transpose() * Eigen::Vector3d::UnitZ();
}

}  // namespace imt
