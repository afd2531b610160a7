#include "instant_motion_tracking/core/anchor/epipolar_rotation.h"

#include "instant_motion_tracking/core/anchor/imu_orientation.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Eigenvalues>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

namespace imt {
namespace {

// A pair is fixed to the camera when the gyro's turn would move it at least
// this far (px) and it moved less than this share of that.
constexpr double kFixedMinTurnPx = 2.0;
constexpr double kFixedMaxShare = 0.25;

// One feature's epipolar distance (px) under R_cam_imu (angle-axis) and its
// frame's direction of travel t (unit): r1 . (t x c), c = R r0, divided by
// the constraint's gradient over both rays' image coordinates (Sampson).
struct EpipolarDistance {
  EpipolarDistance(const Eigen::Vector3d& r0, const Eigen::Vector3d& r1, const Eigen::Vector3d& theta_imu, double focal)
      : r0(r0), r1(r1), turn_back(-theta_imu), focal(focal) {}

  template <typename T>
  bool operator()(const T* aa, const T* t, T* residual) const {
    const T ray[3] = {T(r0.x()), T(r0.y()), T(r0.z())};
    const T aa_inv[3] = {-aa[0], -aa[1], -aa[2]};
    const T back[3] = {T(turn_back.x()), T(turn_back.y()), T(turn_back.z())};
    T in_imu[3], turned[3], c[3];
    ceres::AngleAxisRotatePoint(aa_inv, ray, in_imu);      // R_cam_imu^T r0
    ceres::AngleAxisRotatePoint(back, in_imu, turned);     // exp(theta_imu)^T
    ceres::AngleAxisRotatePoint(aa, turned, c);            // R_cam_imu
    T n[3];  // t x c: the epipolar line in the second frame
    ceres::CrossProduct(t, c, n);
    const T e = T(r1.x()) * n[0] + T(r1.y()) * n[1] + T(r1.z()) * n[2];
    // d e / d r1 = t x c = n; d e / d c = r1 x t = m, taken as the first
    // ray's own (R^T m, to first order in the small turn).
    T m[3];
    const T r1t[3] = {T(r1.x()), T(r1.y()), T(r1.z())};
    ceres::CrossProduct(r1t, t, m);
    const T g = n[0] * n[0] + n[1] * n[1] + m[0] * m[0] + m[1] * m[1];
    residual[0] = T(focal) * e / ceres::sqrt(g + T(1e-18));
    return true;
  }

  Eigen::Vector3d r0, r1, turn_back;
  double focal;
};

struct Solved {
  Eigen::Quaterniond R;
  double inlier_fraction = 0;
  bool ok = false;
};

// One solve over the frames selected by `use` (index -> bool).
struct FramePairs {
  std::vector<EpipolarPair> pairs;
  double focal_px = 0;
};

template <typename Use>
Solved solve(const std::vector<FramePairs>& frames, const Eigen::Quaterniond& start,
             const EpipolarCamImuRotation::Options& o, Use use) {
  const Eigen::AngleAxisd aa0(start.normalized());
  std::array<double, 3> aa = {aa0.angle() * aa0.axis().x(), aa0.angle() * aa0.axis().y(),
                              aa0.angle() * aa0.axis().z()};
  const Eigen::Matrix3d R0 = start.normalized().toRotationMatrix();
  std::vector<std::array<double, 3>> travel(frames.size());
  const auto loss = std::make_unique<ceres::CauchyLoss>(o.loss_px);  // outlives the problem
  ceres::Problem::Options po;
  po.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(po);
  int used = 0;
  for (size_t f = 0; f < frames.size(); ++f) {
    if (!use(f)) continue;
    // The travel's start: the direction closest to every pair's epipolar
    // plane under the start rotation (the least eigenvector).
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    for (const EpipolarPair& p : frames[f].pairs) {
      const Eigen::Matrix3d Rf = R0 * quaternionExp(p.theta_imu).toRotationMatrix().transpose() * R0.transpose();
      const Eigen::Vector3d v = (Rf * p.ray0).cross(p.ray1);
      A += v * v.transpose();
    }
    const Eigen::Vector3d t0 = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(A).eigenvectors().col(0).normalized();
    travel[f] = {t0.x(), t0.y(), t0.z()};
    for (const EpipolarPair& p : frames[f].pairs)
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<EpipolarDistance, 1, 3, 3>(
                                   new EpipolarDistance(p.ray0, p.ray1, p.theta_imu, frames[f].focal_px)),
                               loss.get(), aa.data(), travel[f].data());
    problem.SetManifold(travel[f].data(), new ceres::SphereManifold<3>());
    ++used;
  }
  Solved out;
  if (used < 2) return out;
  ceres::Solver::Options so;
  so.max_num_iterations = 50;
  so.linear_solver_type = ceres::DENSE_SCHUR;  // a 3x3 reduced system; needs no sparse backend
  so.num_threads = 1;  // the same answer live and offline
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (summary.termination_type == ceres::FAILURE) return out;
  const Eigen::Vector3d v(aa[0], aa[1], aa[2]);
  if (!v.allFinite()) return out;
  out.R = quaternionExp(v);
  // Inliers: pairs within 2 loss scales.
  int inliers = 0, total = 0;
  for (size_t f = 0; f < frames.size(); ++f) {
    if (!use(f)) continue;
    for (const EpipolarPair& p : frames[f].pairs) {
      double r = 0;
      const EpipolarDistance d(p.ray0, p.ray1, p.theta_imu, frames[f].focal_px);
      d(aa.data(), travel[f].data(), &r);
      inliers += std::abs(r) <= 2 * o.loss_px;
      ++total;
    }
  }
  out.inlier_fraction = total > 0 ? static_cast<double>(inliers) / total : 0;
  out.ok = true;
  return out;
}

}  // namespace

void EpipolarCamImuRotation::addFrame(const std::vector<EpipolarPair>& pairs, double focal_px) {
  if (!(focal_px > 0) || !std::isfinite(focal_px)) return;
  Frame f;
  f.focal_px = focal_px;
  const size_t n = pairs.size();
  const size_t keep = std::min(n, static_cast<size_t>(std::max(0, options_.max_pairs_per_frame)));
  for (size_t k = 0; k < keep; ++k) {
    const EpipolarPair& p = pairs[k * n / keep];  // evenly over the list
    if (p.ray0.allFinite() && p.ray1.allFinite() && p.theta_imu.allFinite() && p.ray0.z() > 0 && p.ray1.z() > 0)
      f.pairs.push_back(p);
  }
  if (f.pairs.size() < 8) return;
  frames_.push_back(std::move(f));
  while (static_cast<int>(frames_.size()) > std::max(1, options_.max_frames)) frames_.pop_front();
}

std::optional<EpipolarRotationFit> EpipolarCamImuRotation::fit(const Eigen::Quaterniond& start) const {
  if (static_cast<int>(frames_.size()) < options_.min_frames || !start.coeffs().allFinite()) return std::nullopt;
  // A feature that stays put while the camera turns is fixed to the camera
  // (a dashboard, a reflection in the windscreen, an overlay): no world point
  // does that but where the travel cancels the turn. Such pairs are left
  // out: under small turns they sit near every epipolar line, and a fifth
  // of them took a rendered fit 2.5 deg off.
  const Eigen::Matrix3d R_start = start.normalized().toRotationMatrix();
  std::vector<FramePairs> frames;
  int pairs = 0, turning = 0;
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (const Frame& f : frames_) {
    FramePairs kept;
    kept.focal_px = f.focal_px;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const EpipolarPair& p : f.pairs) {
      const Eigen::Vector3d turned = quaternionExp(R_start * p.theta_imu).toRotationMatrix().transpose() * p.ray0;
      const double turn_px = f.focal_px * (turned / turned.z() - p.ray0 / p.ray0.z()).norm();
      const double moved_px = f.focal_px * (p.ray1 / p.ray1.z() - p.ray0 / p.ray0.z()).norm();
      if (turn_px >= kFixedMinTurnPx && moved_px < kFixedMaxShare * turn_px) continue;
      kept.pairs.push_back(p);
      mean += p.theta_imu / f.pairs.size();
    }
    if (kept.pairs.size() < 8) continue;
    pairs += static_cast<int>(kept.pairs.size());
    turning += mean.norm() >= options_.min_angle;
    S += mean * mean.transpose();
    frames.push_back(std::move(kept));
  }
  if (static_cast<int>(frames.size()) < options_.min_frames || 2 * turning < options_.min_frames) return std::nullopt;
  // The turns must span two axes.
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(S).eigenvalues();  // ascending
  if (!(ev(2) > 0) || !(ev(1) >= options_.min_axis_ratio * ev(2))) return std::nullopt;
  const Solved whole = solve(frames, start, options_, [](size_t) { return true; });
  if (!whole.ok) return std::nullopt;
  EpipolarRotationFit out;
  out.R_cam_imu = whole.R;
  out.frames = static_cast<int>(frames.size());
  out.pairs = pairs;
  out.inlier_fraction = whole.inlier_fraction;
  if (whole.inlier_fraction < options_.min_inlier_fraction) return out;  // not sharp: the halves would not help
  // How sharp: the even and the odd frames fitted apart, from the whole's answer.
  const Solved even = solve(frames, whole.R, options_, [](size_t f) { return f % 2 == 0; });
  const Solved odd = solve(frames, whole.R, options_, [](size_t f) { return f % 2 == 1; });
  if (even.ok && odd.ok)
    out.spread_deg = std::max(whole.R.angularDistance(even.R), whole.R.angularDistance(odd.R)) * 180 / M_PI;
  out.sharp = out.spread_deg >= 0 && out.spread_deg <= options_.max_spread_deg &&
              out.inlier_fraction >= options_.min_inlier_fraction;
  return out;
}

}  // namespace imt
