#include "instant_motion_tracking/core/anchor/cam_imu_rotation.h"

#include "instant_motion_tracking/core/anchor/imu_orientation.h"

#include <Eigen/Dense>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace imt {
namespace {

// The rotation R maximising sum w_i a_i . (R b_i) (a_i ~ R b_i).
Eigen::Matrix3d procrustes(const Eigen::Matrix3d& sum_a_bt) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum_a_bt, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  if ((svd.matrixU() * svd.matrixV().transpose()).determinant() < 0) D(2, 2) = -1;
  return svd.matrixU() * D * svd.matrixV().transpose();
}

}  // namespace

namespace {

// Rays through a grid over the middle 80% of the image and through their
// images under H (ideal normalised coordinates, z = 1), with those images in
// image pixels. False when H or the camera model is unusable, or a grid
// point maps behind the camera.
struct GridRays {
  std::vector<Eigen::Vector3d> from, to;
  std::vector<cv::Point2d> seen;
};
bool gridRays(const CameraModel& k, const Eigen::Matrix3d& H, GridRays* g) {
  if (!k.valid || !(k.fx > 0) || !(k.fy > 0) || !H.allFinite() || k.width <= 0 || k.height <= 0) return false;
  const Eigen::Matrix3d Kinv = k.K().inverse();
  constexpr int kGrid = 5;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const cv::Point2d p(k.width * (0.1 + 0.8 * j / (kGrid - 1)), k.height * (0.1 + 0.8 * i / (kGrid - 1)));
      const Eigen::Vector3d q = H * Eigen::Vector3d(p.x, p.y, 1.0);
      if (!(q.z() > 0)) return false;
      const cv::Point2d p2(q.x() / q.z(), q.y() / q.z());
      const cv::Point2d a = k.undistort(p), b = k.undistort(p2);
      g->from.push_back(Kinv * Eigen::Vector3d(a.x, a.y, 1.0));
      g->to.push_back(Kinv * Eigen::Vector3d(b.x, b.y, 1.0));
      g->seen.push_back(p2);
    }
  return true;
}

// How far, in image pixels, the rays G x (x: the grid's `from`) land from
// H's images of the grid: the rms.
double rmsPx(const CameraModel& k, const GridRays& g, const Eigen::Matrix3d& G) {
  const Eigen::Matrix3d KG = k.K() * G;
  double sum = 0;
  for (size_t i = 0; i < g.from.size(); ++i) {
    const Eigen::Vector3d r = KG * g.from[i];
    if (!(r.z() > 0)) return std::numeric_limits<double>::infinity();
    const cv::Point2d shown = k.distort(cv::Point2d(r.x() / r.z(), r.y() / r.z()));
    sum += std::pow(shown.x - g.seen[i].x, 2) + std::pow(shown.y - g.seen[i].y, 2);
  }
  return std::sqrt(sum / g.from.size());
}

}  // namespace

bool rotationFromHomography(const CameraModel& k, const Eigen::Matrix3d& H, Eigen::Matrix3d* R, double* rms_px) {
  GridRays g;
  if (!gridRays(k, H, &g)) return false;
  const std::vector<Eigen::Vector3d>& from = g.from;
  const std::vector<Eigen::Vector3d>& to = g.to;
  // A turn and a zoom about the principal point (the camera also moved
  // along its axis: a hand walking forward), fitted in turn: the rotation
  // by Procrustes on the rays with the zoom applied, the zoom by least
  // squares on the points turned back.
  double zoom = 1;
  std::vector<Eigen::Vector3d> zoomed(from.size());
  for (int it = 0; it < 4; ++it) {
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    for (size_t i = 0; i < from.size(); ++i) {
      zoomed[i] = Eigen::Vector3d(zoom * from[i].x(), zoom * from[i].y(), 1.0).normalized();
      M += to[i].normalized() * zoomed[i].transpose();
    }
    *R = procrustes(M);
    double num = 0, den = 0;
    for (size_t i = 0; i < from.size(); ++i) {
      const Eigen::Vector3d back = R->transpose() * to[i];
      if (!(back.z() > 0)) return false;
      num += back.head<2>().dot(from[i].head<2>()) / back.z();
      den += from[i].head<2>().squaredNorm();
    }
    if (!(den > 0)) break;
    zoom = std::clamp(num / den, 0.5, 2.0);
  }
  // How well the turn and zoom reproduce H, in image pixels.
  *rms_px = rmsPx(k, g, *R * Eigen::Vector3d(zoom, zoom, 1.0).asDiagonal());
  return std::isfinite(*rms_px);
}

bool rotationFromPlaneHomography(const CameraModel& k, const Eigen::Matrix3d& H, const Eigen::Vector3d& normal,
                                 Eigen::Matrix3d* R, double* rms_px) {
  if (!normal.allFinite() || !(normal.norm() > 0.5)) return false;
  GridRays g;
  if (!gridRays(k, H, &g)) return false;
  // G ~ H between ideal rays (the lens taken out), by least squares on the
  // grid: G x_i parallel to y_i, i.e. [y_i]x G x_i = 0 (DLT).
  Eigen::MatrixXd A(2 * g.from.size(), 9);
  for (size_t i = 0; i < g.from.size(); ++i) {
    const Eigen::Vector3d x = g.from[i], y = g.to[i] / g.to[i].z();
    A.row(2 * i) << 0, 0, 0, -x.transpose(), y.y() * x.transpose();
    A.row(2 * i + 1) << x.transpose(), 0, 0, 0, -y.x() * x.transpose();
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::VectorXd h = svd.matrixV().col(8);
  Eigen::Matrix3d G;
  G << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  if (G.determinant() < 0) G = -G;
  // G = lambda (R + t n^T): on the plane's own directions (u n = 0) G acts
  // as lambda R, whatever the translation t.
  const Eigen::Vector3d n = normal.normalized();
  const Eigen::Vector3d u1 = n.unitOrthogonal(), u2 = n.cross(u1);
  const Eigen::Vector3d a1 = G * u1, a2 = G * u2;
  const double lambda = std::sqrt(0.5 * (a1.squaredNorm() + a2.squaredNorm()));
  if (!(lambda > 0)) return false;
  const Eigen::Matrix3d M = a1 * u1.transpose() + a2 * u2.transpose() + (a1.cross(a2) / lambda) * n.transpose();
  *R = procrustes(M);
  const Eigen::Vector3d t = G * n / lambda - *R * n;
  *rms_px = rmsPx(k, g, *R + t * n.transpose());
  return std::isfinite(*rms_px);
}

bool cameraTurn(const CameraModel& k, const CameraMotion& camera, Eigen::Vector3d* theta, double* rms_px) {
  Eigen::Matrix3d R_c1c0;
  double rms = 0;
  if (camera.model == MotionModel::kInvalid || !rotationFromHomography(k, camera.H, &R_c1c0, &rms)) return false;
  const Eigen::Vector3d turn = rotationVector(R_c1c0.transpose());
  if (!(rms <= std::max(0.5, k.fx * turn.norm()))) return false;
  *theta = turn;
  if (rms_px) *rms_px = rms;
  return true;
}

void CamImuRotationEstimator::add(const Eigen::Vector3d& theta_cam, const Eigen::Vector3d& theta_imu) {
  if (!theta_cam.allFinite() || !theta_imu.allFinite()) return;
  if (theta_imu.norm() < options_.min_angle || theta_cam.norm() < options_.min_angle) return;
  pairs_.push_back({theta_cam, theta_imu});
  while (pairs_.size() > options_.max_pairs) pairs_.pop_front();
  if (static_cast<int>(pairs_.size()) >= options_.min_pairs) fit();
}

void CamImuRotationEstimator::reset() {
  pairs_.clear();
  estimate_.reset();
  best_fit_.reset();
  residual_ = -1;
}

void CamImuRotationEstimator::fit() {
  // The turns must span two axes, else the rotation about the one axis is free.
  Eigen::Matrix3d S = Eigen::Matrix3d::Zero();
  for (const Pair& p : pairs_) S += p.imu * p.imu.transpose();
  const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(S).eigenvalues();  // ascending
  if (!(ev(1) >= options_.min_axis_ratio * ev(2))) return;
  // Two passes: all pairs, then those within 3x the median relative residual
  // (a frame whose background motion was not the camera's turn: a passing
  // object, a translation the rotation fit could not tell).
  std::vector<double> rel(pairs_.size());
  std::vector<bool> keep(pairs_.size(), true);
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  double rms = 0;
  for (int pass = 0; pass < 2; ++pass) {
    Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
    for (size_t i = 0; i < pairs_.size(); ++i)
      if (keep[i]) M += pairs_[i].cam * pairs_[i].imu.transpose();
    R = procrustes(M);
    double sum = 0;
    size_t n = 0;
    for (size_t i = 0; i < pairs_.size(); ++i) {
      rel[i] = (pairs_[i].cam - R * pairs_[i].imu).norm() / pairs_[i].imu.norm();
      if (keep[i]) {
        sum += rel[i] * rel[i];
        ++n;
      }
    }
    rms = n > 0 ? std::sqrt(sum / n) : 1e9;
    if (pass == 0) {
      std::vector<double> sorted = rel;
      std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
      const double cut = std::max(0.1, 3 * sorted[sorted.size() / 2]);
      for (size_t i = 0; i < pairs_.size(); ++i) keep[i] = rel[i] <= cut;
    }
  }
  residual_ = rms;
  best_fit_ = Eigen::Quaterniond(R).normalized();
  if (rms <= options_.max_residual) estimate_ = best_fit_;
}

}  // namespace imt
