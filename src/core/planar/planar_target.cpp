#include "instant_motion_tracking/core/planar/planar_target.h"

#include "option_checker.h"

#include "planar_appearance.h"
#include "planar_internal.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace imt {
namespace {

using namespace planar_detail;

// Reprojection residual of a point (X, Y, 0) of the target plane under the
// pose (angle-axis, translation) from target to camera; (u, v) is an ideal
// pinhole pixel (an image pixel undistorted through the camera model).
struct Reprojection {
  Reprojection(const Eigen::Vector2d& xy, const Eigen::Vector2d& uv, const CameraModel& k)
      : X(xy.x()), Y(xy.y()), u(uv.x()), v(uv.y()), fx(k.fx), fy(k.fy), cx(k.cx), cy(k.cy) {}
  template <class T>
  bool operator()(const T* aa, const T* t, T* r) const {
    const T p[3] = {T(X), T(Y), T(0)};
    T q[3];
    ceres::AngleAxisRotatePoint(aa, p, q);
    q[0] += t[0];
    q[1] += t[1];
    q[2] += t[2];
    if (q[2] < T(1e-6)) return false;  // behind the camera: reject the step
    r[0] = T(fx) * q[0] / q[2] + T(cx) - T(u);
    r[1] = T(fy) * q[1] / q[2] + T(cy) - T(v);
    return true;
  }
  double X, Y, u, v, fx, fy, cx, cy;
};

}  // namespace

namespace planar_detail {

// The pose (target to camera) that minimises the reprojection error of `obs`,
// by Levenberg-Marquardt from `T` (updated in place); `loss_scale` > 0 makes
// the loss Huber. False when no usable solution was found.
bool fitPose(const std::vector<PlaneObservation>& obs, const CameraModel& k, double loss_scale,
             int max_iterations, Eigen::Isometry3d* T) {
  const Eigen::AngleAxisd aa0(T->linear());
  double aa[3], t[3];
  for (int i = 0; i < 3; ++i) {
    aa[i] = aa0.angle() * aa0.axis()(i);
    t[i] = T->translation()(i);
  }
  ceres::Problem problem;
  for (const PlaneObservation& o : obs) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<Reprojection, 2, 3, 3>(new Reprojection(o.xy, o.uv, k)),
        loss_scale > 0 ? new ceres::HuberLoss(loss_scale) : nullptr, aa, t);
  }
  ceres::Solver::Options so;
  so.linear_solver_type = ceres::DENSE_QR;
  so.max_num_iterations = max_iterations;
  so.num_threads = 1;
  so.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(so, &problem, &summary);
  if (!summary.IsSolutionUsable() || !(t[2] > 0)) return false;
  const Eigen::Vector3d r(aa[0], aa[1], aa[2]);
  T->linear() = r.norm() > 1e-12 ? Eigen::AngleAxisd(r.norm(), r.normalized()).toRotationMatrix()
                                 : Eigen::Matrix3d::Identity();
  T->translation() = Eigen::Vector3d(t[0], t[1], t[2]);
  return true;
}

std::array<Eigen::Vector3d, 4> targetCorners(double w, double h) {
  return {Eigen::Vector3d(-w / 2, -h / 2, 0), Eigen::Vector3d(w / 2, -h / 2, 0),
          Eigen::Vector3d(w / 2, h / 2, 0), Eigen::Vector3d(-w / 2, h / 2, 0)};
}

double longestEdge(const std::array<cv::Point2d, 4>& c) {
  double e = 0;
  for (int i = 0; i < 4; ++i) e = std::max(e, cv::norm(c[(i + 1) % 4] - c[i]));
  return e;
}

cv::Rect2d quadBounds(const std::array<cv::Point2d, 4>& c) {
  double x0 = c[0].x, x1 = x0, y0 = c[0].y, y1 = y0;
  for (const cv::Point2d& p : c) {
    x0 = std::min(x0, p.x);
    x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y);
    y1 = std::max(y1, p.y);
  }
  return cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
}

double quadArea(const std::array<cv::Point2d, 4>& c) {
  double a = 0;
  for (int i = 0; i < 4; ++i) a += c[i].x * c[(i + 1) % 4].y - c[(i + 1) % 4].x * c[i].y;
  return 0.5 * a;
}

double fractionInside(const std::array<cv::Point2d, 4>& c, int w, int h) {
  std::vector<cv::Point2f> quad, img = {{0, 0}, {float(w), 0}, {float(w), float(h)}, {0, float(h)}},
                                 inter;
  for (const auto& p : c) quad.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  if (quadArea(c) < 0) std::reverse(quad.begin(), quad.end());
  const double area = std::abs(quadArea(c));
  if (area <= 0) return 0;
  const float ia = cv::intersectConvexConvex(quad, img, inter, true);
  return ia / area;
}

}  // namespace planar_detail


const char* targetStatusName(TargetStatus s) {
  switch (s) {
    case TargetStatus::kTracked:
      return "tracked";
    case TargetStatus::kOutOfView:
      return "out_of_view";
    case TargetStatus::kNotFound:
      return "not_found";
    case TargetStatus::kPredicted:
      return "predicted";
    case TargetStatus::kLost:
      break;
  }
  return "lost";
}


std::string PlanarTargetOptions::validate() const {
  OptionChecker c("planar_tracking");
  c.check(model == "perspective" || model == "homography", "model", "must be perspective or homography",
          "'" + model + "'");
  c.check(loss_scale > 0, "loss_scale", "must be > 0", loss_scale);
  c.inRange("max_iterations", max_iterations, 1, 200);
  c.check(outlier_error > 0, "outlier_error", "must be > 0", outlier_error);
  c.check(join_error > 0, "join_error", "must be > 0", join_error);
  c.atLeast("min_points", min_points, 4);
  c.atLeast("confidence_points", confidence_points, 1.0);
  c.inRange("template_size", template_size, 32, 2048);
  c.inRange("refine_iterations", refine_iterations, 1, 500);
  c.check(refine_epsilon > 0, "refine_epsilon", "must be > 0", refine_epsilon);
  c.check(refine_min_visible > 0 && refine_min_visible <= 1, "refine_min_visible", "must be in (0, 1]",
          refine_min_visible);
  c.check(refine_outlier_sigma > 0, "refine_outlier_sigma", "must be > 0", refine_outlier_sigma);
  c.check(refine_max_step > 0, "refine_max_step", "must be > 0", refine_max_step);
  c.check(refine_min_correlation > 0 && refine_min_correlation < 1, "refine_min_correlation", "must be in (0, 1)",
          refine_min_correlation);
  c.check(refine_max_correction > 0 && refine_max_correction <= 1, "refine_max_correction", "must be in (0, 1]",
          refine_max_correction);
  c.check(prediction_gate > 0, "prediction_gate", "must be > 0", prediction_gate);
  c.inRange("refine_search_below", refine_search_below, 0.0, 1.0);
  c.inRange("refine_search_range", refine_search_range, 0.0, 1.0);
  c.check(refine_search_min_score > 0 && refine_search_min_score < 1, "refine_search_min_score",
          "must be in (0, 1)", refine_search_min_score);
  c.check(refine_search_margin >= 0 && refine_search_margin < 1, "refine_search_margin", "must be in [0, 1)",
          refine_search_margin);
  c.inRange("image_memory_mb", image_memory_mb, 0.0, 1e6);
  c.inRange("max_targets", max_targets, 1, 10000);
  c.inRange("detect_interval", detect_interval, 1, 1000);
  c.inRange("detect_features", detect_features, 100, 100000);
  c.inRange("detect_picture_size", detect_picture_size, 64, 4096);
  c.inRange("detect_picture_features", detect_picture_features, 50, 100000);
  c.check(detect_ratio > 0 && detect_ratio < 1, "detect_ratio", "must be in (0, 1)", detect_ratio);
  c.inRange("detect_min_inliers", detect_min_inliers, 8, 10000);
  c.check(detect_min_correlation > 0 && detect_min_correlation < 1, "detect_min_correlation", "must be in (0, 1)",
          detect_min_correlation);
  c.check(detect_ransac_error > 0, "detect_ransac_error", "must be > 0", detect_ransac_error);
  return c.error();
}

std::string validateQuad(const std::array<cv::Point2d, 4>& c) {
  for (const auto& p : c)
    if (!std::isfinite(p.x) || !std::isfinite(p.y))
      return "corner with a NaN or infinite coordinate";
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      if (cv::norm(c[i] - c[j]) < 2.0)
        return "corners " + std::to_string(i) + " and " + std::to_string(j) + " coincide";
  int sign = 0;
  for (int i = 0; i < 4; ++i) {
    const cv::Point2d a = c[(i + 1) % 4] - c[i], b = c[(i + 2) % 4] - c[(i + 1) % 4];
    const double cross = a.x * b.y - a.y * b.x;
    const int s = cross > 1e-9 ? 1 : cross < -1e-9 ? -1 : 0;
    if (s == 0) return "three corners are collinear";
    if (sign != 0 && s != sign) return "quad is not convex (corners must be TL, TR, BR, BL)";
    sign = s;
  }
  if (std::abs(quadArea(c)) < 25.0) return "degenerate quad (area below 25 px^2)";
  return "";
}

std::string validateTargetRequest(const std::array<cv::Point2d, 4>& corners, double width_m,
                                  double height_m) {
  if (std::string e = validateQuad(corners); !e.empty()) return e;
  // Convex, so the winding is that of any corner (y down: clockwise > 0).
  const cv::Point2d a = corners[1] - corners[0], b = corners[2] - corners[1];
  if (a.x * b.y - a.y * b.x < 0)
    return "corners are counter-clockwise in the image (a mirrored quad): they must be TL, TR, BR, BL, "
           "clockwise in the image";
  return validateTargetSize(width_m, height_m);
}

std::string validateTargetSize(double width_m, double height_m) {
  if (!(width_m > 0) || !(height_m > 0) || !std::isfinite(width_m) || !std::isfinite(height_m))
    return "target size must be positive (got " + std::to_string(width_m) + " x " +
           std::to_string(height_m) + " m)";
  return "";
}

std::unique_ptr<PlanarTargetTracker> PlanarTargetTracker::create(
    const PlanarTargetOptions& options, uint32_t id, const std::array<cv::Point2d, 4>& corners,
    double width_m, double height_m, const CameraModel& k, const MotionData& md,
    std::string* error, const cv::Mat& gray, const cv::Mat& picture) {
  if (std::string e = options.validate(); !e.empty()) {
    *error = e;
    return nullptr;
  }
  if (std::string e = validateTargetRequest(corners, width_m, height_m); !e.empty()) {
    *error = e;
    return nullptr;
  }
  if (!k.valid || !(k.fx > 0) || !(k.fy > 0)) {
    *error = "camera intrinsics are not valid";
    return nullptr;
  }
  std::unique_ptr<PlanarTargetTracker> t(new PlanarTargetTracker);
  t->options_ = options;
  t->k_ = k;
  t->state_.id = id;
  t->state_.stamp = md.stamp;
  t->state_.width_m = width_m;
  t->state_.height_m = height_m;
  if (!t->poseFromCorners(corners)) {
    *error = "no pose explains the four corners";
    return nullptr;
  }
  t->state_.corners = corners;
  // Every feature inside the quad now lies on the target plane.
  for (const FeatureMotion& f : md.features) {
    Eigen::Vector2d xy;
    if (cv::pointPolygonTest(std::vector<cv::Point2f>(corners.begin(), corners.end()),
                             cv::Point2f(f.x, f.y), false) > 0 &&
        t->backProject({f.x, f.y}, &xy))
      t->model_[f.id] = xy;
  }
  for (const FeatureMotion& f : md.features) t->last_px_[f.id] = {f.x, f.y};
  t->state_.points = static_cast<int>(t->model_.size());
  t->state_.confidence = std::min(1.0, t->model_.size() / options.confidence_points);
  if (options.refine && options.model == "perspective" && (!gray.empty() || !picture.empty()))
    t->captureAppearance(gray, picture);
  return t;
}

bool PlanarTargetTracker::poseFromCorners(const std::array<cv::Point2d, 4>& corners) {
  std::vector<cv::Point3d> obj;
  for (const auto& p : targetCorners(state_.width_m, state_.height_m))
    obj.emplace_back(p.x(), p.y(), p.z());
  std::vector<cv::Point2d> img(corners.begin(), corners.end());
  k_.undistort(&img);  // image -> ideal pinhole pixels (no-op without distortion)
  const cv::Matx33d K(k_.fx, 0, k_.cx, 0, k_.fy, k_.cy, 0, 0, 1);
  cv::Vec3d rvec, tvec;
  bool ok = false;
  try {
    ok = cv::solvePnP(obj, img, K, cv::noArray(), rvec, tvec, false, cv::SOLVEPNP_IPPE);
  } catch (const cv::Exception&) {
    ok = false;
  }
  if (!ok || tvec[2] <= 0) return false;
  const Eigen::Vector3d r(rvec[0], rvec[1], rvec[2]);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  if (r.norm() > 1e-12) T.linear() = Eigen::AngleAxisd(r.norm(), r.normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(tvec[0], tvec[1], tvec[2]);
  state_.T_cam_target = T;
  return true;
}

Eigen::Vector2d PlanarTargetTracker::project(const Eigen::Vector3d& p_target) const {
  const Eigen::Vector3d q = state_.T_cam_target * p_target;
  const Eigen::Vector2d ideal(k_.fx * q.x() / q.z() + k_.cx, k_.fy * q.y() / q.z() + k_.cy);
  if (!k_.hasDistortion()) return ideal;
  const cv::Point2d px = k_.distort(cv::Point2d(ideal.x(), ideal.y()));
  return {px.x, px.y};
}

bool PlanarTargetTracker::backProject(const Eigen::Vector2d& image_px, Eigen::Vector2d* xy) const {
  Eigen::Vector2d px = image_px;
  if (k_.hasDistortion()) {
    const cv::Point2d ideal = k_.undistort(cv::Point2d(image_px.x(), image_px.y()));
    px = {ideal.x, ideal.y};
  }
  const Eigen::Vector3d d((px.x() - k_.cx) / k_.fx, (px.y() - k_.cy) / k_.fy, 1.0);
  const Eigen::Matrix3d R = state_.T_cam_target.linear();
  const Eigen::Vector3d t = state_.T_cam_target.translation();
  const Eigen::Vector3d n = R.col(2);
  const double denom = n.dot(d);
  if (std::abs(denom) < 1e-9) return false;
  const double s = n.dot(t) / denom;
  if (s <= 0) return false;
  const Eigen::Vector3d p = R.transpose() * (s * d - t);
  *xy = p.head<2>();
  return std::abs(xy->x()) <= state_.width_m / 2 && std::abs(xy->y()) <= state_.height_m / 2;
}

void PlanarTargetTracker::projectCorners() {
  const auto c = targetCorners(state_.width_m, state_.height_m);
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector2d p = project(c[i]);
    state_.corners[i] = cv::Point2d(p.x(), p.y());
  }
}

void PlanarTargetTracker::addNewPoints(const MotionData& md) {
  std::vector<cv::Point2f> quad(state_.corners.begin(), state_.corners.end());
  std::map<uint32_t, Eigen::Vector2d> candidates;
  std::map<uint32_t, bool> rejected;
  for (const FeatureMotion& f : md.features) {
    if (model_.count(f.id)) continue;
    if (rejected_.count(f.id)) {
      rejected[f.id] = true;  // keep only ids still around
      continue;
    }
    if (cv::pointPolygonTest(quad, cv::Point2f(f.x, f.y), false) <= 0) continue;
    Eigen::Vector2d xy;
    if (!backProject({f.x, f.y}, &xy)) continue;
    const auto c = candidates_.find(f.id);
    if (c == candidates_.end()) {
      candidates[f.id] = xy;
      continue;
    }
    // Second observation: its first plane position must reproject here.
    const double err =
        (project({c->second.x(), c->second.y(), 0}) - Eigen::Vector2d(f.x, f.y)).norm();
    if (err < std::max(options_.join_error, 1.5 * residual_level_)) {
      model_[f.id] = 0.5 * (c->second + xy);
    } else {
      rejected[f.id] = true;  // off the plane or moving on its own
    }
  }
  candidates_ = std::move(candidates);
  rejected_ = std::move(rejected);
}

void PlanarTargetTracker::stepPerspective(const MotionData& md,
                                          const std::array<cv::Point2d, 4>* predicted) {
  std::vector<PlaneObservation> obs;
  for (const FeatureMotion& f : md.features) {
    const auto m = model_.find(f.id);
    if (m != model_.end()) obs.push_back({f.id, m->second, {f.x, f.y}});
  }
  state_.points = static_cast<int>(obs.size());
  if (static_cast<int>(obs.size()) < options_.min_points) return;
  if (k_.hasDistortion()) {  // the fit compares ideal pinhole pixels
    std::vector<cv::Point2d> uv;
    for (const PlaneObservation& o : obs) uv.emplace_back(o.uv.x(), o.uv.y());
    k_.undistort(&uv);
    for (size_t i = 0; i < obs.size(); ++i) obs[i].uv = {uv[i].x, uv[i].y};
  }

  const Eigen::Isometry3d T_last = state_.T_cam_target;
  if (!fitPose(obs, k_, options_.loss_scale, options_.max_iterations, &state_.T_cam_target)) {
    state_.points = 0;
    return;
  }
  // A pose resting on few points that puts the target far from where the
  // camera motion moves it is not used: when something passes in front of
  // the target, the last features left are those its edge drags along, and
  // they would take the pose (and the model, as they outvote the rest) with
  // them. The camera motion predicts it instead (step()). "Far" is the
  // smaller of prediction_gate (a share of the target's size) and four times
  // how far this target's confirmed poses usually sit from the prediction
  // (at least 1 px): a poster on a wall moves with the camera motion to a
  // tenth of a pixel, and a few points 2-7 px off it are an occluder's.
  if (predicted && static_cast<int>(obs.size()) < 2 * options_.min_points) {
    double gap = 0;
    const auto corners = targetCorners(state_.width_m, state_.height_m);
    for (int i = 0; i < 4; ++i)
      gap = std::max(gap, (project(corners[i]) -
                           Eigen::Vector2d((*predicted)[i].x, (*predicted)[i].y))
                              .norm());
    const double gate = options_.prediction_gate * longestEdge(state_.corners) + 1.0;
    // (Only where the look can take over from a refused pose: without one
    // the camera motion would carry it on its own.)
    const double usual =
        prediction_level_ < 0 || !appearance_ ? gate : std::max(1.0, 4 * prediction_level_);
    if (gap > std::min(gate, usual)) {
      state_.T_cam_target = T_last;
      state_.points = 0;
      return;
    }
  }

  dropDisagreeingPoints(md, false);
}

// Drops model points that disagree with the pose (occluders, off-plane, long
// feature tracks that drifted); `points` and `rms_error` count the others.
// "Disagree" is relative to how well the points fit at all: features measured
// on a downscaled frame, or intrinsics that are only assumed, leave every point
// a pixel or two off, and a fixed threshold would then drop good points one by
// one. With `reanchor` (the pose comes from the appearance alignment, which
// does not drift) the points that stay move on the plane to where they are
// seen now, so the model follows its features' slow drift.
void PlanarTargetTracker::dropDisagreeingPoints(const MotionData& md, bool reanchor) {
  std::vector<std::pair<std::map<uint32_t, Eigen::Vector2d>::iterator, const FeatureMotion*>> seen;
  std::vector<double> errors;
  for (const FeatureMotion& f : md.features) {
    const auto m = model_.find(f.id);
    if (m == model_.end()) continue;
    seen.emplace_back(m, &f);
    errors.push_back(
        (project({m->second.x(), m->second.y(), 0}) - Eigen::Vector2d(f.x, f.y)).norm());
  }
  if (!errors.empty()) {
    std::vector<double> sorted = errors;
    std::nth_element(sorted.begin(), sorted.begin() + sorted.size() / 2, sorted.end());
    // The median of a 2D Gaussian residual's norm is 1.18 sigma; smoothed
    // over frames, since a few points give a noisy median.
    const double level = sorted[sorted.size() / 2] / 1.18;
    residual_level_ = residual_level_ > 0 ? 0.8 * residual_level_ + 0.2 * level : level;
  }
  const double limit = std::max(options_.outlier_error, 3.0 * residual_level_);
  double sq = 0;
  int inliers = 0;
  for (size_t i = 0; i < seen.size(); ++i) {
    const double e = errors[i];
    if (e > limit) {
      rejected_[seen[i].first->first] = true;
      model_.erase(seen[i].first);
      continue;
    }
    sq += e * e;
    ++inliers;
    Eigen::Vector2d xy;
    if (reanchor && backProject({seen[i].second->x, seen[i].second->y}, &xy))
      seen[i].first->second = xy;
  }
  state_.points = inliers;
  state_.rms_error = inliers ? std::sqrt(sq / inliers) : 0;
}

// Target plane (X, Y, 1) -> ideal pinhole pixels, K [r1 r2 t] (sampleImage
// looks them up through the lens).
void PlanarTargetTracker::stepHomography(const MotionData& md) {
  std::vector<cv::Point2f> quad(state_.corners.begin(), state_.corners.end());
  std::vector<cv::Point2f> src, dst;
  for (const FeatureMotion& f : md.features) {
    const auto p = last_px_.find(f.id);
    if (p == last_px_.end()) continue;
    const cv::Point2f s(p->second.x(), p->second.y());
    if (cv::pointPolygonTest(quad, s, false) <= 0) continue;
    src.push_back(s);
    dst.emplace_back(f.x, f.y);
  }
  state_.points = static_cast<int>(src.size());
  if (static_cast<int>(src.size()) < std::max(8, options_.min_points)) {
    state_.points = 0;
    return;
  }
  k_.undistort(&src);  // a plane's motion is a homography between ideal pixels only
  k_.undistort(&dst);
  cv::Mat inlier_mask;
  const cv::Mat H = cv::findHomography(src, dst, cv::RANSAC, 2.0, inlier_mask);
  if (H.empty()) {
    state_.points = 0;
    return;
  }
  state_.points = cv::countNonZero(inlier_mask);
  std::vector<cv::Point2d> in(state_.corners.begin(), state_.corners.end()), out;
  k_.undistort(&in);
  cv::perspectiveTransform(in, out, H);
  k_.distort(&out);
  std::array<cv::Point2d, 4> c;
  std::copy(out.begin(), out.end(), c.begin());
  state_.corners = c;
  poseFromCorners(c);
}

void PlanarTargetTracker::predict(const std::array<cv::Point2d, 4>& c) {
  if (validateQuad(c).empty() && poseFromCorners(c)) {
    if (options_.model == "perspective") {
      projectCorners();
    } else {
      state_.corners = c;
    }
  }
}

const PlanarTargetState& PlanarTargetTracker::step(const MotionData& md,
                                                   const Eigen::Matrix3d& H_last_to_this,
                                                   bool H_valid, const cv::Mat& gray) {
  state_.stamp = md.stamp;
  state_.correlation = 0;
  state_.visible = 0;
  if (state_.status == TargetStatus::kLost) return state_;
  const bool perspective = options_.model == "perspective";
  const bool predictable = H_valid && H_last_to_this.allFinite();
  // Where the camera motion moves the last frame's corners.
  std::array<cv::Point2d, 4> predicted_corners = state_.corners;
  if (predictable)
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector3d p =
          H_last_to_this * Eigen::Vector3d(state_.corners[i].x, state_.corners[i].y, 1);
      predicted_corners[i] = cv::Point2d(p.x() / p.z(), p.y() / p.z());
    }
  if (perspective) {
    stepPerspective(md, predictable ? &predicted_corners : nullptr);
  } else {
    stepHomography(md);
  }
  bool measured = state_.points >= options_.min_points;
  if (measured && perspective) projectCorners();
  if (!measured && predictable) predict(predicted_corners);
  if (perspective && options_.refine && !gray.empty() &&
      fractionInside(state_.corners, md.width, md.height) > 0.2 && refine(gray)) {
    frames_unaligned_ = 0;
    projectCorners();
    dropDisagreeingPoints(md, true);
    measured = true;
  }
  if (state_.correlation == 0) ++frames_unaligned_;
  // Carried by the camera motion, a target's place is a prediction until its
  // look confirms it: features that join it after the prediction may be
  // whatever lies in the predicted quad (the background, when the camera
  // was blind while it moved). Without a look, or a frame without its image,
  // the features have the last word.
  if (!measured) unconfirmed_ = true;
  if (state_.correlation > 0 || !appearance_ || gray.empty()) unconfirmed_ = false;
  // A pose the look confirmed, or many points: how far it sits from the
  // camera motion's prediction is what this target usually does.
  if (predictable && perspective &&
      (state_.correlation > 0 || state_.points >= 2 * options_.min_points)) {
    double gap = 0;
    for (int i = 0; i < 4; ++i)
      gap = std::max(gap, cv::norm(predicted_corners[i] - state_.corners[i]));
    prediction_level_ = prediction_level_ < 0 ? gap : 0.8 * prediction_level_ + 0.2 * gap;
  }
  // Back in view after a prediction: features inside the predicted quad
  // become candidates, and the rigid fit takes over once enough join.
  if (measured || fractionInside(state_.corners, md.width, md.height) > 0.05) addNewPoints(md);
  for (const FeatureMotion& f : md.features) last_px_[f.id] = {f.x, f.y};
  if (last_px_.size() > 4 * md.features.size() + 100) {  // forget ids long gone
    std::map<uint32_t, Eigen::Vector2d> keep;
    for (const FeatureMotion& f : md.features) keep[f.id] = {f.x, f.y};
    last_px_ = std::move(keep);
  }

  const double inside = fractionInside(state_.corners, md.width, md.height);
  state_.confidence = measured ? std::min(1.0, state_.points / options_.confidence_points) : 0.2;
  if (state_.correlation > 0) state_.confidence = std::max(state_.confidence, state_.correlation);
  if (!validateQuad(state_.corners).empty() || state_.T_cam_target.translation().z() <= 0) {
    state_.status = TargetStatus::kLost;
    state_.reason = "the target's quad degenerated";
    state_.confidence = 0;
  } else if (inside < 0.05 || (!measured && inside < 0.5)) {
    state_.status = TargetStatus::kOutOfView;
  } else if (!measured || unconfirmed_) {
    state_.status = TargetStatus::kPredicted;
    state_.confidence = std::min(state_.confidence, 0.2);
  } else {
    state_.status = TargetStatus::kTracked;
  }
  return state_;
}

}  // namespace imt
