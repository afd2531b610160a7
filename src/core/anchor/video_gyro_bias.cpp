#include "instant_motion_tracking/core/anchor/video_gyro_bias.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <vector>

namespace imt {

void VideoGyroBias::add(double t1, double dt, const Eigen::Vector3d& gyro_turn, const Eigen::Vector3d& camera_turn,
                        double offset) {
  if (!std::isfinite(t1) || !(dt > 0 && dt <= 1) || !gyro_turn.allFinite() || !camera_turn.allFinite() ||
      !std::isfinite(offset))
    return;
  if (!frames_.empty() && t1 < frames_.back().t1) return;
  frames_.push_back({t1, dt, offset, gyro_turn, camera_turn});
  while (frames_.front().t1 < t1 - seconds_) frames_.pop_front();
}

std::optional<VideoGyroBias::Estimate> VideoGyroBias::estimate(const Eigen::Matrix3d& R_imu_cam,
                                                                bool refine_rotation) const {
  if (static_cast<int>(frames_.size()) < kMinFrames || !R_imu_cam.allFinite()) return std::nullopt;
  // Each frame's turn rate in the IMU's axes, and its change per second
  // (from its neighbours, when they are there; zero otherwise): a gyro read
  // s too late reads the turn of s later, rate + s * rate', which a walk's
  // changing turns make a bias of its own over a few seconds (0.1 deg/s for
  // 40 ms on a rendered walk) unless it is fitted with the bias.
  const size_t n_frames = frames_.size();
  std::vector<Eigen::Vector3d> rate(n_frames), accel(n_frames, Eigen::Vector3d::Zero()), reading(n_frames);
  for (size_t i = 0; i < n_frames; ++i) rate[i] = R_imu_cam * frames_[i].camera / frames_[i].dt;
  for (size_t i = 1; i + 1 < n_frames; ++i) {
    const double before = frames_[i].t1 - frames_[i - 1].t1, after = frames_[i + 1].t1 - frames_[i].t1;
    const bool next = std::abs(before - frames_[i].dt) < 0.1 * frames_[i].dt &&
                      std::abs(after - frames_[i + 1].dt) < 0.1 * frames_[i + 1].dt;
    if (next) accel[i] = (rate[i + 1] - rate[i - 1]) / (before + after);
  }
  // Each frame's reading of the bias, rad/s: the gyro's turn rate less the
  // camera's, and less what reading it at another offset than the newest
  // frame's put in (that offset's lateness is the one fitted).
  const double newest_offset = frames_.back().offset;
  for (size_t i = 0; i < n_frames; ++i)
    reading[i] = frames_[i].gyro / frames_[i].dt - rate[i] - (frames_[i].offset - newest_offset) * accel[i];
  // Per axis: the median and the median absolute deviation (x 1.4826: a
  // standard deviation for Gaussian noise); frames over 4 of them from the
  // median on any axis are left out.
  Eigen::Vector3d median, spread;
  std::vector<double> v(n_frames);
  for (int a = 0; a < 3; ++a) {
    for (size_t i = 0; i < n_frames; ++i) v[i] = reading[i](a);
    auto mid = v.begin() + v.size() / 2;
    std::nth_element(v.begin(), mid, v.end());
    median(a) = *mid;
    for (double& x : v) x = std::abs(x - median(a));
    std::nth_element(v.begin(), mid, v.end());
    spread(a) = std::max(1.4826 * *mid, 1e-9);
  }
  std::vector<size_t> kept;
  for (size_t i = 0; i < n_frames; ++i)
    if (!((reading[i] - median).array().abs() > 4 * spread.array()).any()) kept.push_back(i);
  if (static_cast<int>(kept.size()) < kMinFrames / 2) return std::nullopt;
  // Weighted least squares (weights dt^2: the video's noise is per frame)
  // for the bias b, the IMU's lateness s and, with refine_rotation, a small
  // rotation d of the camera's axes:
  //   reading = b + s rate' + (R d-turned turn - R turn) / dt = b + s rate' - [rate]x d.
  const int n = refine_rotation ? 7 : 4;
  using Row = Eigen::Matrix<double, 3, 7>;
  Eigen::Matrix<double, 7, 7> N = Eigen::Matrix<double, 7, 7>::Zero();
  Eigen::Matrix<double, 7, 1> y = Eigen::Matrix<double, 7, 1>::Zero();
  auto jacobian = [&](size_t i) {
    Row J = Row::Zero();
    J.leftCols<3>().setIdentity();
    J.col(3) = accel[i];
    const Eigen::Vector3d& r = rate[i];
    Eigen::Matrix3d skew;
    skew << 0, -r.z(), r.y(), r.z(), 0, -r.x(), -r.y(), r.x(), 0;
    J.rightCols<3>() = -skew;
    return J;
  };
  for (const size_t i : kept) {
    const double w = frames_[i].dt * frames_[i].dt;
    const Row J = jacobian(i);
    N += w * J.transpose() * J;
    y += w * J.transpose() * reading[i];
  }
  // A turn rate that never changes leaves the lateness free: a weak prior
  // (1 s) keeps the system solvable without moving a lateness the turns show.
  N(3, 3) += 1e-12 + 1e-6 * N(0, 0);
  const Eigen::MatrixXd Nn = N.topLeftCorner(n, n);
  const Eigen::LDLT<Eigen::MatrixXd> ldlt(Nn);
  const Eigen::VectorXd x = ldlt.solve(y.head(n));
  if (ldlt.info() != Eigen::Success || !x.allFinite()) return std::nullopt;
  // The noise of a frame's turn (rad), from the residuals; the standard
  // errors from it and the normal matrix (the bias's part: turns about one
  // axis only leave the rotation and the bias hard to tell apart, and say so).
  double ss = 0;
  for (const size_t i : kept) {
    const Eigen::Vector3d res = reading[i] - jacobian(i).leftCols(n) * x;
    ss += frames_[i].dt * frames_[i].dt * res.squaredNorm();
  }
  const double noise2 = ss / std::max(1.0, 3.0 * kept.size() - n);
  const Eigen::MatrixXd cov = noise2 * ldlt.solve(Eigen::MatrixXd::Identity(n, n));
  Estimate e;
  e.bias = x.head<3>();
  e.sigma = cov.diagonal().head<3>().cwiseMax(0.0).cwiseSqrt();
  e.lateness = x(3);
  e.lateness_sigma = std::sqrt(std::max(0.0, cov(3, 3)));
  e.frames = static_cast<int>(kept.size());
  return e;
}

}  // namespace imt
