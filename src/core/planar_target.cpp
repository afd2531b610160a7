#include "instant_motion_tracking/core/planar_target.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/video/tracking.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <sstream>

namespace imt {
namespace {

// Reprojection residual of a point (X, Y, 0) of the target plane under the
// pose (angle-axis, translation) from target to camera.
struct Reprojection {
  Reprojection(const Eigen::Vector2d& xy, const Eigen::Vector2d& uv, const CameraIntrinsics& k)
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

// A point of the target plane (X, Y) and where it is seen (u, v).
struct PlaneObservation {
  uint32_t id;
  Eigen::Vector2d xy, uv;
};

// The pose (target to camera) that minimises the reprojection error of `obs`,
// by Levenberg-Marquardt from `T` (updated in place); `loss_scale` > 0 makes
// the loss Huber. False when no usable solution was found.
bool fitPose(const std::vector<PlaneObservation>& obs, const CameraIntrinsics& k, double loss_scale,
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

// Template pixel of pyramid level `level` (OpenCV: centres at integers) ->
// target plane point (X, Y, 1), for a level-0 template of `px_per_m`. pyrDown
// keeps OpenCV pixel coordinates proportional (level-l pixel u is level-0
// pixel 2^l u).
Eigen::Matrix3d templateToPlane(double px_per_m, int level, double w, double h) {
  const double f = (1 << level) / px_per_m;
  Eigen::Matrix3d A;
  A << f, 0, 0.5 / px_per_m - w / 2, 0, f, 0.5 / px_per_m - h / 2, 0, 0, 1;
  return A;
}

// Our pixel (centres at +0.5, docs/conventions.md) of the full image -> OpenCV
// pixel of image pyramid level `level` (see templateToPlane on pyrDown).
Eigen::Matrix3d toPyramidPixel(int level) {
  const double s = 1.0 / (1 << level);
  Eigen::Matrix3d S;
  S << s, 0, -0.5 * s, 0, s, -0.5 * s, 0, 0, 1;
  return S;
}

// The pyramid level at which an image seen `ratio` image pixels per template
// pixel is sampled about 1:1.
int imageLevelFor(double ratio) {
  if (!(ratio > 1.5)) return 0;
  return std::min(4, static_cast<int>(std::lround(std::log2(ratio))));
}

cv::Mat pyramidLevel(const cv::Mat& gray, int level) {
  cv::Mat im = gray;
  for (int l = 0; l < level; ++l) {
    cv::Mat down;
    cv::pyrDown(im, down);
    im = down;
  }
  return im;
}

cv::Matx33d toMatx(const Eigen::Matrix3d& M) {
  cv::Matx33d m;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m(r, c) = M(r, c);
  return m;
}

// `gray` sampled on the template grid through `M` (template px -> image px,
// OpenCV), as CV_32F, and the mask of samples that fell inside the image.
void sampleOnTemplate(const cv::Mat& gray, const Eigen::Matrix3d& M, cv::Size size, cv::Mat* out, cv::Mat* valid) {
  cv::Mat warped;
  cv::warpPerspective(gray, warped, toMatx(M), size, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, 0);
  warped.convertTo(*out, CV_32F);
  const cv::Mat ones(gray.size(), CV_8U, cv::Scalar(255));
  cv::warpPerspective(ones, *valid, toMatx(M), size, cv::INTER_NEAREST | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, 0);
  cv::erode(*valid, *valid, cv::Mat());  // no bilinear samples mixing in the border
}

std::array<Eigen::Vector3d, 4> targetCorners(double w, double h) {
  return {Eigen::Vector3d(-w / 2, -h / 2, 0), Eigen::Vector3d(w / 2, -h / 2, 0),
          Eigen::Vector3d(w / 2, h / 2, 0), Eigen::Vector3d(-w / 2, h / 2, 0)};
}

double quadArea(const std::array<cv::Point2d, 4>& c) {
  double a = 0;
  for (int i = 0; i < 4; ++i) a += c[i].x * c[(i + 1) % 4].y - c[(i + 1) % 4].x * c[i].y;
  return 0.5 * a;
}

double fractionInside(const std::array<cv::Point2d, 4>& c, int w, int h) {
  std::vector<cv::Point2f> quad, img = {{0, 0}, {float(w), 0}, {float(w), float(h)}, {0, float(h)}}, inter;
  for (const auto& p : c) quad.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
  if (quadArea(c) < 0) std::reverse(quad.begin(), quad.end());
  const double area = std::abs(quadArea(c));
  if (area <= 0) return 0;
  const float ia = cv::intersectConvexConvex(quad, img, inter, true);
  return ia / area;
}

}  // namespace

const char* targetStatusName(TargetStatus s) {
  switch (s) {
    case TargetStatus::kTracked: return "tracked";
    case TargetStatus::kOutOfView: return "out_of_view";
    case TargetStatus::kLost: break;
  }
  return "lost";
}

// The target as seen at placement, rectified onto its plane: a pyramid of
// templates (level l has 2^-l the resolution of level 0) and their masks.
struct PlanarTargetTracker::Appearance {
  std::vector<cv::Mat> levels;  // CV_32F
  std::vector<cv::Mat> masks;   // CV_8U, 255 where the frame saw the target
  double px_per_m = 0;          // level-0 template pixels per metre
};

std::string PlanarTargetOptions::validate() const {
  if (model != "perspective" && model != "homography")
    return "planar_tracking.model: must be perspective or homography (got '" + model + "')";
  if (!(loss_scale > 0)) return "planar_tracking.loss_scale: must be > 0";
  if (max_iterations < 1 || max_iterations > 200) return "planar_tracking.max_iterations: must be in [1, 200]";
  if (!(outlier_error > 0)) return "planar_tracking.outlier_error: must be > 0";
  if (!(join_error > 0)) return "planar_tracking.join_error: must be > 0";
  if (min_points < 4) return "planar_tracking.min_points: must be >= 4";
  if (!(confidence_points >= 1)) return "planar_tracking.confidence_points: must be >= 1";
  if (template_size < 32 || template_size > 2048) return "planar_tracking.template_size: must be in [32, 2048]";
  if (!(refine_min_correlation > 0 && refine_min_correlation < 1))
    return "planar_tracking.refine_min_correlation: must be in (0, 1)";
  if (!(refine_max_correction > 0 && refine_max_correction <= 1))
    return "planar_tracking.refine_max_correction: must be in (0, 1]";
  if (!(image_memory_mb >= 0 && image_memory_mb <= 1e6)) return "planar_tracking.image_memory_mb: must be >= 0";
  return "";
}

std::string validateQuad(const std::array<cv::Point2d, 4>& c) {
  for (const auto& p : c)
    if (!std::isfinite(p.x) || !std::isfinite(p.y)) return "corner with a NaN or infinite coordinate";
  for (int i = 0; i < 4; ++i)
    for (int j = i + 1; j < 4; ++j)
      if (cv::norm(c[i] - c[j]) < 2.0) return "corners " + std::to_string(i) + " and " + std::to_string(j) + " coincide";
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

std::string validateTargetRequest(const std::array<cv::Point2d, 4>& corners, double width_m, double height_m) {
  if (std::string e = validateQuad(corners); !e.empty()) return e;
  if (!(width_m > 0) || !(height_m > 0) || !std::isfinite(width_m) || !std::isfinite(height_m))
    return "target size must be positive (got " + std::to_string(width_m) + " x " + std::to_string(height_m) + " m)";
  return "";
}

std::unique_ptr<PlanarTargetTracker> PlanarTargetTracker::create(
    const PlanarTargetOptions& options, uint32_t id, const std::array<cv::Point2d, 4>& corners,
    double width_m, double height_m, const CameraIntrinsics& k, const MotionData& md,
    std::string* error, const cv::Mat& gray) {
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
    if (cv::pointPolygonTest(std::vector<cv::Point2f>(corners.begin(), corners.end()), cv::Point2f(f.x, f.y), false) > 0 &&
        t->backProject({f.x, f.y}, &xy))
      t->model_[f.id] = xy;
  }
  for (const FeatureMotion& f : md.features) t->last_px_[f.id] = {f.x, f.y};
  t->state_.points = static_cast<int>(t->model_.size());
  t->state_.confidence = std::min(1.0, t->model_.size() / options.confidence_points);
  if (options.refine && options.model == "perspective" && !gray.empty()) t->captureAppearance(gray);
  return t;
}

bool PlanarTargetTracker::poseFromCorners(const std::array<cv::Point2d, 4>& corners) {
  std::vector<cv::Point3d> obj;
  for (const auto& p : targetCorners(state_.width_m, state_.height_m)) obj.emplace_back(p.x(), p.y(), p.z());
  const std::vector<cv::Point2d> img(corners.begin(), corners.end());
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
  return {k_.fx * q.x() / q.z() + k_.cx, k_.fy * q.y() / q.z() + k_.cy};
}

bool PlanarTargetTracker::backProject(const Eigen::Vector2d& px, Eigen::Vector2d* xy) const {
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
    const double err = (project({c->second.x(), c->second.y(), 0}) - Eigen::Vector2d(f.x, f.y)).norm();
    if (err < options_.join_error) {
      model_[f.id] = 0.5 * (c->second + xy);
    } else {
      rejected[f.id] = true;  // off the plane or moving on its own
    }
  }
  candidates_ = std::move(candidates);
  rejected_ = std::move(rejected);
}

void PlanarTargetTracker::stepPerspective(const MotionData& md) {
  std::vector<PlaneObservation> obs;
  for (const FeatureMotion& f : md.features) {
    const auto m = model_.find(f.id);
    if (m != model_.end()) obs.push_back({f.id, m->second, {f.x, f.y}});
  }
  state_.points = static_cast<int>(obs.size());
  if (static_cast<int>(obs.size()) < options_.min_points) return;

  if (!fitPose(obs, k_, options_.loss_scale, options_.max_iterations, &state_.T_cam_target)) {
    state_.points = 0;
    return;
  }

  dropDisagreeingPoints(md);
}

// Drops model points that disagree with the pose (occluders, off-plane, long
// feature tracks that drifted); `points` and `rms_error` count the others.
void PlanarTargetTracker::dropDisagreeingPoints(const MotionData& md) {
  double sq = 0;
  int inliers = 0;
  for (const FeatureMotion& f : md.features) {
    const auto m = model_.find(f.id);
    if (m == model_.end()) continue;
    const double e = (project({m->second.x(), m->second.y(), 0}) - Eigen::Vector2d(f.x, f.y)).norm();
    if (e > options_.outlier_error) {
      model_.erase(m);
      rejected_[f.id] = true;
    } else {
      sq += e * e;
      ++inliers;
    }
  }
  state_.points = inliers;
  state_.rms_error = inliers ? std::sqrt(sq / inliers) : 0;
}

Eigen::Matrix3d PlanarTargetTracker::planeToImage() const {
  const Eigen::Matrix3d K = (Eigen::Matrix3d() << k_.fx, 0, k_.cx, 0, k_.fy, k_.cy, 0, 0, 1).finished();
  Eigen::Matrix3d Rt;
  Rt.col(0) = state_.T_cam_target.linear().col(0);
  Rt.col(1) = state_.T_cam_target.linear().col(1);
  Rt.col(2) = state_.T_cam_target.translation();
  return K * Rt;
}

namespace {

double longestEdge(const std::array<cv::Point2d, 4>& c) {
  double e = 0;
  for (int i = 0; i < 4; ++i) e = std::max(e, cv::norm(c[(i + 1) % 4] - c[i]));
  return e;
}

}  // namespace

// The target's look at placement: the frame resampled onto the target plane
// at about the resolution it was seen with (at most template_size px).
bool PlanarTargetTracker::captureAppearance(const cv::Mat& gray) {
  if (gray.empty() || gray.type() != CV_8UC1) return false;
  const double w = state_.width_m, h = state_.height_m;
  const double seen = longestEdge(state_.corners);
  const double long_px = std::min<double>(options_.template_size, seen);
  const int W = std::max(16, static_cast<int>(std::lround(long_px * w / std::max(w, h))));
  const int H = std::max(16, static_cast<int>(std::lround(long_px * h / std::max(w, h))));
  auto a = std::make_shared<Appearance>();
  a->px_per_m = W / w;
  const int li = imageLevelFor(seen / long_px);
  cv::Mat tpl, valid;
  sampleOnTemplate(pyramidLevel(gray, li), toPyramidPixel(li) * planeToImage() * templateToPlane(a->px_per_m, 0, w, h),
                   cv::Size(W, H), &tpl, &valid);
  cv::Scalar mean, stddev;
  cv::meanStdDev(tpl, mean, stddev, valid);
  if (cv::countNonZero(valid) < 0.5 * W * H || stddev[0] < 2.0) return false;  // mostly unseen, or featureless
  a->levels.push_back(tpl);
  a->masks.push_back(valid);
  while (std::min(a->levels.back().cols, a->levels.back().rows) >= 48 && a->levels.size() < 5) {
    cv::Mat down, mask;
    cv::pyrDown(a->levels.back(), down);
    cv::resize(a->masks.back(), mask, down.size(), 0, 0, cv::INTER_NEAREST);
    cv::erode(mask, mask, cv::Mat());
    a->levels.push_back(down);
    a->masks.push_back(mask);
  }
  appearance_ = std::move(a);
  return true;
}

// Aligns the appearance at placement with `gray` by ECC (OpenCV's
// findTransformECC, a homography on the rectified target, coarse to fine),
// starting from the current pose, then fits the rigid pose to the aligned
// plane. The alignment is used only when it correlates well and corrects the
// pose by a plausible amount (an occluder or a wrong basin does neither).
bool PlanarTargetTracker::refine(const cv::Mat& gray) {
  state_.correlation = 0;
  if (gray.empty() || gray.type() != CV_8UC1) return false;
  if (!appearance_) {
    captureAppearance(gray);
    return false;
  }
  const Appearance& a = *appearance_;
  const double w = state_.width_m, h = state_.height_m;
  const double seen = longestEdge(state_.corners);
  const double r0 = seen / std::max(a.levels[0].cols, a.levels[0].rows);  // image px per level-0 template px
  const int top = static_cast<int>(a.levels.size()) - 1;
  const int lt = r0 >= 1 ? 0 : std::min(top, static_cast<int>(std::lround(std::log2(1 / r0))));
  Eigen::Matrix3d G = planeToImage();
  double cc = 0;
  for (int l = std::min(top, lt + 1); l >= lt; --l) {
    const int li = imageLevelFor(r0 * (1 << l));
    const Eigen::Matrix3d A = templateToPlane(a.px_per_m, l, w, h);
    cv::Mat warped, valid;
    sampleOnTemplate(pyramidLevel(gray, li), toPyramidPixel(li) * G * A, a.levels[l].size(), &warped, &valid);
    cv::bitwise_and(valid, a.masks[l], valid);
    if (cv::countNonZero(valid) < 0.25 * valid.total()) return false;  // mostly outside the frame
    cv::Mat warp = cv::Mat::eye(3, 3, CV_32F);
    try {
      cc = cv::findTransformECC(a.levels[l], warped, warp, cv::MOTION_HOMOGRAPHY,
                                cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 1e-4),
                                valid, 5);
    } catch (const cv::Exception&) {
      return false;  // did not converge (uncorrelated images)
    }
    Eigen::Matrix3d C;
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) C(r, c) = warp.at<float>(r, c);
    if (!C.allFinite()) return false;
    G = G * A * C * A.inverse();
  }
  if (!(cc >= options_.refine_min_correlation)) return false;
  // The aligned plane, seen through a grid of points, gives the rigid pose.
  std::vector<PlaneObservation> grid;
  double correction = 0;
  for (int i = 0; i <= 4; ++i) {
    for (int j = 0; j <= 4; ++j) {
      const Eigen::Vector2d xy((i / 4.0 - 0.5) * w, (j / 4.0 - 0.5) * h);
      const Eigen::Vector3d p = G * Eigen::Vector3d(xy.x(), xy.y(), 1);
      if (!(p.z() > 0)) return false;
      grid.push_back({0, xy, p.head<2>() / p.z()});
      if ((i == 0 || i == 4) && (j == 0 || j == 4))
        correction = std::max(correction, (grid.back().uv - project({xy.x(), xy.y(), 0})).norm());
    }
  }
  if (correction > options_.refine_max_correction * seen + 1.0) return false;
  Eigen::Isometry3d T = state_.T_cam_target;
  if (!fitPose(grid, k_, 0, options_.max_iterations, &T)) return false;
  state_.T_cam_target = T;
  state_.correlation = cc;
  return true;
}

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
  cv::Mat inlier_mask;
  const cv::Mat H = cv::findHomography(src, dst, cv::RANSAC, 2.0, inlier_mask);
  if (H.empty()) {
    state_.points = 0;
    return;
  }
  state_.points = cv::countNonZero(inlier_mask);
  std::vector<cv::Point2d> in(state_.corners.begin(), state_.corners.end()), out;
  cv::perspectiveTransform(in, out, H);
  std::array<cv::Point2d, 4> c;
  std::copy(out.begin(), out.end(), c.begin());
  state_.corners = c;
  poseFromCorners(c);
}

void PlanarTargetTracker::predict(const Eigen::Matrix3d& H) {
  std::array<cv::Point2d, 4> c;
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3d p = H * Eigen::Vector3d(state_.corners[i].x, state_.corners[i].y, 1);
    c[i] = cv::Point2d(p.x() / p.z(), p.y() / p.z());
  }
  if (validateQuad(c).empty() && poseFromCorners(c)) {
    if (options_.model == "perspective") {
      projectCorners();
    } else {
      state_.corners = c;
    }
  }
}

const PlanarTargetState& PlanarTargetTracker::step(const MotionData& md, const Eigen::Matrix3d& H_last_to_this,
                                                   bool H_valid, const cv::Mat& gray) {
  state_.stamp = md.stamp;
  state_.correlation = 0;
  if (state_.status == TargetStatus::kLost) return state_;
  const bool perspective = options_.model == "perspective";
  if (perspective) {
    stepPerspective(md);
  } else {
    stepHomography(md);
  }
  bool measured = state_.points >= options_.min_points;
  if (measured && perspective) projectCorners();
  if (!measured && H_valid && H_last_to_this.allFinite()) predict(H_last_to_this);
  if (perspective && options_.refine && !gray.empty() &&
      fractionInside(state_.corners, md.width, md.height) > 0.2 && refine(gray)) {
    projectCorners();
    dropDisagreeingPoints(md);
    measured = true;
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
  } else {
    state_.status = TargetStatus::kTracked;
  }
  return state_;
}

}  // namespace imt
