// The region tracker's motion fit (private to it): the motion vectors of a
// step, the local model fitted to them (translation, + scale, similarity) by
// weighted least squares, and what the camera's homography does to a box.
#pragma once

#include "region_geometry.h"

#include <Eigen/Dense>
#include <opencv2/core.hpp>

#include <cmath>
#include <cstdint>
#include <vector>

namespace imt {
namespace region_fit {

using region_geometry::boxAt;
using region_geometry::centre;

// One motion vector in the tracking direction: src in the state's frame, dst
// in the frame being tracked into.
struct Vec {
  uint32_t id = 0;
  Eigen::Vector2d src, dst;
  Eigen::Vector2d src_cam;  // src moved by the camera motion: the fit explains dst - src_cam
  double prior = 1, weight = 1, error = 0;
  double bg = -1;  // the motion analysis's background weight (-1: a region's own feature)
  bool in_box = false;
};

// dst = c + t + A (src - c), A = [a -b; b a]; a = 1, b = 0 for translation.
struct LocalModel {
  Eigen::Vector2d c = Eigen::Vector2d::Zero();
  Eigen::Vector2d t = Eigen::Vector2d::Zero();
  double a = 1, b = 0;
  int dof = 2;
  Eigen::Vector2d apply(const Eigen::Vector2d& p) const {
    const Eigen::Vector2d q = p - c;
    return c + t + Eigen::Vector2d(a * q.x() - b * q.y(), b * q.x() + a * q.y());
  }
  double scale() const { return std::hypot(a, b); }
  double rotation() const { return std::atan2(b, a); }
};

// Weighted least squares for a model of `dof` 2 (translation), 3 (+scale) or
// 4 (similarity). False when degenerate.
inline bool fitModel(const std::vector<Vec>& v, const Eigen::Vector2d& c, int dof, LocalModel* m) {
  Eigen::Matrix4d AtA = Eigen::Matrix4d::Zero();
  Eigen::Vector4d Atb = Eigen::Vector4d::Zero();
  double wsum = 0;
  for (const Vec& e : v) {
    if (e.weight <= 0) continue;
    const Eigen::Vector2d q = e.src_cam - c, r = e.dst - c;
    // unknowns: tx, ty, a, b
    Eigen::Matrix<double, 2, 4> J;
    J << 1, 0, q.x(), -q.y(), 0, 1, q.y(), q.x();
    AtA += e.weight * J.transpose() * J;
    Atb += e.weight * J.transpose() * r;
    wsum += e.weight;
  }
  if (wsum <= 0) return false;
  m->c = c;
  m->dof = dof;
  if (dof == 2) {
    // translation only: r - q = t
    Eigen::Vector2d t = Eigen::Vector2d::Zero();
    for (const Vec& e : v)
      if (e.weight > 0) t += e.weight * (e.dst - e.src_cam);
    m->t = t / wsum;
    m->a = 1;
    m->b = 0;
    return true;
  }
  if (dof == 3) {
    const Eigen::Matrix3d M = AtA.topLeftCorner<3, 3>();
    const Eigen::Vector3d x = M.ldlt().solve(Atb.head<3>());
    if (!x.allFinite() || std::abs(M.determinant()) < 1e-9) return false;
    m->t = x.head<2>();
    m->a = x(2);
    m->b = 0;
    return true;
  }
  const Eigen::Vector4d x = AtA.ldlt().solve(Atb);
  if (!x.allFinite() || std::abs(AtA.determinant()) < 1e-9) return false;
  m->t = x.head<2>();
  m->a = x(2);
  m->b = x(3);
  return true;
}

// A scale seen only between two classes of features (background, weight
// 0.5 or more, and moving: the motion analysis's `bg`; a region's own
// feature weighs 1 / (1 + (r / own_residual)^2) from how far, r, it moved
// from where the camera put it on this step, and has no class when
// `own_residual` is 0), not within either: two motions mixed, not a zoom. A
// card sliding off a wall patch, the wall's features still on one side of
// the box and the card's moving on the other, is fitted as the patch
// growing 3-4% a frame, each residual under the inlier threshold; so is a
// walker the camera pans along with, the ground on one side of his box. A
// true zoom (the camera or the target approaching) shows within the class
// that carries it. True when the inliers (residual under `thr`) hold at
// least `min_each` of each class, `m`'s scale changes by kMinRefusedScale
// or more, and either its scale change is more than twice either class's
// own (each fitted about the same centre), or a shift of each class's own
// explains their inliers as well as `m` does (a class's own scale, fitted
// on a few features at one side of the box, is as noisy as the joint one:
// the walker's 3-4 features gave 2-4% a frame). A class too small or
// degenerate to fit is no evidence either way: false.
constexpr double kMinRefusedScale = 0.005;
inline bool scaleOnlyBetweenClasses(const std::vector<Vec>& v, const LocalModel& m, double thr, int min_each,
                                    double own_residual) {
  const double joint = std::abs(m.scale() - 1);
  if (m.dof < 3 || joint < kMinRefusedScale) return false;
  const auto weightOf = [&](const Vec& e) {
    if (e.bg >= 0 || !(own_residual > 0)) return e.bg;
    const double r = (e.dst - e.src_cam).norm() / own_residual;
    return 1 / (1 + r * r);
  };
  std::vector<Vec> cls[2];
  for (const Vec& e : v) {
    const double bg = weightOf(e);
    if (e.in_box && bg >= 0 && e.weight > 0 && (e.dst - m.apply(e.src_cam)).norm() < thr)
      cls[bg >= 0.5 ? 0 : 1].push_back(e);
  }
  bool each_without = true;  // neither class scales by half the joint change
  double joint_rss = 0, shifts_rss = 0;
  for (const std::vector<Vec>& c : cls) {
    LocalModel own, shift;
    if (static_cast<int>(c.size()) < min_each || !fitModel(c, m.c, 2, &shift)) return false;
    if (!fitModel(c, m.c, 3, &own) || joint <= 2 * std::abs(own.scale() - 1)) each_without = false;
    for (const Vec& e : c) {
      joint_rss += e.weight * (e.dst - m.apply(e.src_cam)).squaredNorm();
      shifts_rss += e.weight * (e.dst - shift.apply(e.src_cam)).squaredNorm();
    }
  }
  return each_without || shifts_rss <= joint_rss;
}

inline Eigen::Vector2d applyH(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = H * p.homogeneous();
  return q.hnormalized();
}

// What a homography does to a small patch about the centre of `box`: where
// the centre goes, and where the patch's axes (of half the box's shorter
// side, `h`) go from there.
struct LocalMap {
  Eigen::Vector2d c2, dx, dy;
  double h;
  LocalMap(const cv::Rect2d& box, const Eigen::Matrix3d& H) {
    const Eigen::Vector2d c = centre(box);
    c2 = applyH(H, c);
    h = 0.5 * std::max(1.0, std::min(box.width, box.height));
    dx = applyH(H, c + Eigen::Vector2d(h, 0)) - c2;
    dy = applyH(H, c + Eigen::Vector2d(0, h)) - c2;
  }
  // The local area change's square root (1 when degenerate).
  double scale() const {
    const double s = std::sqrt(std::abs(dx.x() * dy.y() - dx.y() * dy.x())) / h;
    return std::isfinite(s) && s > 0 ? s : 1.0;
  }
  // The rotation part (rad, x toward y; 0 when degenerate).
  double turn() const {
    const double t = std::atan2(dx.y() - dy.x(), dx.x() + dy.y());
    return std::isfinite(t) ? t : 0.0;
  }
};

// Box moved by a homography: its centre is mapped, its size scaled by the
// local area change of H at the centre.
inline cv::Rect2d moveBox(const cv::Rect2d& box, const Eigen::Matrix3d& H) {
  const LocalMap m(box, H);
  return boxAt(m.c2, m.scale() * box.width, m.scale() * box.height);
}

inline cv::Rect2d moveBox(const cv::Rect2d& box, const LocalModel& m) {
  const double s = m.scale();
  return boxAt(m.apply(centre(box)), s * box.width, s * box.height);
}

}  // namespace region_fit
}  // namespace imt
