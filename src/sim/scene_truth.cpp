// SceneGenerator's ground truth (frameTruth) and IMU stream (imuSamples).
#include "instant_motion_tracking/sim/scene.h"

#include "scene_internal.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace imt {

using namespace scene_detail;

namespace {

// Area of `P` covered by the union of the occluders' visible polygons
// (inclusion-exclusion over intersections of convex polygons).
double coveredArea(const Polygon& P, const std::vector<const PlaneView*>& occluders) {
  const size_t n = std::min<size_t>(occluders.size(), 12);
  double total = 0;
  for (uint32_t mask = 1; mask < (1u << n); ++mask) {
    Polygon Q = P;
    int bits = 0;
    for (size_t k = 0; k < n && Q.size() >= 3; ++k) {
      if (!(mask & (1u << k))) continue;
      ++bits;
      for (const scene_detail::HalfPlane& h : occluders[k]->bounds)
        Q = scene_detail::clipPolygon(Q, h);
    }
    if (Q.size() < 3) continue;
    total += (bits % 2 ? 1 : -1) * scene_detail::polygonArea(Q);
  }
  return std::max(0.0, total);
}

// Projection of a plane rectangle clipped to z >= z_near: its image polygon
// (unbounded parts behind the camera cut off).
Polygon projectedRect(const Eigen::Matrix3d& K, const Eigen::Isometry3d& T_cam_plane, double w,
                      double h) {
  constexpr double kNear = 1e-3;  // m
  std::vector<Eigen::Vector3d> poly;
  for (const auto& c : {Eigen::Vector2d(-w / 2, -h / 2), Eigen::Vector2d(w / 2, -h / 2),
                        Eigen::Vector2d(w / 2, h / 2), Eigen::Vector2d(-w / 2, h / 2)})
    poly.push_back(T_cam_plane * Eigen::Vector3d(c.x(), c.y(), 0));
  std::vector<Eigen::Vector3d> clipped;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector3d &p = poly[i], &q = poly[(i + 1) % poly.size()];
    if (p.z() >= kNear) clipped.push_back(p);
    if ((p.z() >= kNear) != (q.z() >= kNear))
      clipped.push_back(p + (kNear - p.z()) / (q.z() - p.z()) * (q - p));
  }
  Polygon out;
  for (const Eigen::Vector3d& p : clipped) out.push_back((K * (p / p.z())).head<2>());
  return out;
}

// Bounding box of `poly` (ideal pixels) as the lens shows it: its edges
// sampled (32 points each) and distorted; the polygon's own without distortion.
cv::Rect2d boundingBox(const Polygon& ideal, const CameraModel& lens, const cv::Rect& field) {
  Polygon poly = ideal;
  if (lens.hasDistortion() && !ideal.empty()) {
    std::vector<cv::Point2d> pts;
    for (size_t i = 0; i < ideal.size(); ++i) {
      const Eigen::Vector2d &a = ideal[i], &b = ideal[(i + 1) % ideal.size()];
      for (int k = 0; k < 32; ++k) {
        const Eigen::Vector2d p = a + (b - a) * (k / 32.0);
        pts.emplace_back(p.x(), p.y());
      }
    }
    poly.clear();
    for (const cv::Point2d& p : pts) {
      const cv::Point2d q = showThroughLens(lens, field, p);
      poly.emplace_back(q.x, q.y);
    }
  }
  if (poly.empty()) return cv::Rect2d();
  double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
  for (const Eigen::Vector2d& p : poly) {
    x0 = std::min(x0, p.x()), x1 = std::max(x1, p.x());
    y0 = std::min(y0, p.y()), y1 = std::max(y1, p.y());
  }
  return cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
}

}  // namespace

FrameTruth SceneGenerator::frameTruth(int i) const {
  const SceneOptions& o = options_;
  const double t = i / o.fps;
  FrameTruth gt;
  gt.index = i;
  gt.stamp = frameStamp(i);
  gt.T_world_cam = T_world_cam(t);
  gt.brightness_gain = brightnessGain(t);
  if (i > 0) gt.background_homography = backgroundHomography(i - 1, i);

  const Eigen::Matrix3d K = impl_->K.K();
  const Eigen::Isometry3d T_cam_world = gt.T_world_cam.inverse();
  const size_t n = o.planes.size();
  std::vector<Eigen::Isometry3d> T_cam_plane(n);
  std::vector<PlaneView> views(n);
  for (size_t k = 0; k < n; ++k) {
    T_cam_plane[k] = T_cam_world * T_world_plane(k, t);
    views[k] = scene_detail::makePlaneView(K, T_cam_plane[k], o.planes[k].width_m,
                                           o.planes[k].height_m, o.width, o.height);
  }
  const std::vector<size_t> order = drawOrder(o.planes, T_cam_plane);
  const cv::Rect2d image(0, 0, o.width, o.height);

  for (size_t pos = 0; pos < order.size(); ++pos) {
    const size_t k = order[pos];
    const ScenePlane& p = o.planes[k];
    if (p.id == 0) continue;
    const Polygon full = projectedRect(K, T_cam_plane[k], p.width_m, p.height_m);
    const double full_area = scene_detail::polygonArea(full);
    const Polygon& seen = views[k].visible;
    const double seen_area = views[k].empty ? 0 : scene_detail::polygonArea(seen);
    double occluded = 0;
    if (seen_area > 0) {
      std::vector<const PlaneView*> nearer;
      for (size_t q = pos + 1; q < order.size(); ++q)
        if (!views[order[q]].empty && !views[order[q]].visible.empty())
          nearer.push_back(&views[order[q]]);
      occluded = coveredArea(seen, nearer) / seen_area;
    }
    if (p.kind == ScenePlane::Kind::kTarget) {
      FrameTruth::Target tg;
      tg.id = p.id;
      tg.width_m = p.width_m;
      tg.height_m = p.height_m;
      tg.T_cam_target = T_cam_plane[k];
      const double hw = p.width_m / 2, hh = p.height_m / 2;
      const Eigen::Vector3d corners[4] = {{-hw, -hh, 0}, {hw, -hh, 0}, {hw, hh, 0}, {-hw, hh, 0}};
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector3d q = K * (T_cam_plane[k] * corners[c]);
        tg.corners[c] =
            showThroughLens(impl_->K, impl_->canvas, cv::Point2d(q.x() / q.z(), q.y() / q.z()));
      }
      tg.visible_fraction = full_area > 0 ? std::min(1.0, seen_area / full_area) : 0;
      tg.occluded_fraction = occluded;
      gt.targets.push_back(tg);
    } else {
      FrameTruth::Region r;
      r.id = p.id;
      r.featureless = p.isFlat();
      r.box_unclipped = boundingBox(full, impl_->K, impl_->canvas);
      r.box = r.box_unclipped & image;
      const double a = r.box_unclipped.area();
      r.visible_fraction = a > 0 ? r.box.area() / a : 0;
      r.occluded_fraction = occluded;
      gt.regions.push_back(r);
    }
  }
  std::sort(gt.regions.begin(), gt.regions.end(),
            [](const auto& a, const auto& b) { return a.id < b.id; });
  std::sort(gt.targets.begin(), gt.targets.end(),
            [](const auto& a, const auto& b) { return a.id < b.id; });

  for (size_t k = 0; k < o.anchors.size(); ++k) {
    const SceneAnchor& a = o.anchors[k];
    FrameTruth::Anchor an;
    an.id = a.id;
    an.placed = t >= a.placed_at - 1e-9;
    Eigen::Isometry3d T_world_anchor = Eigen::Isometry3d::Identity();
    T_world_anchor.linear() = impl_->R_world_anchor[k];
    T_world_anchor.translation() = a.p_world;
    an.T_cam_anchor = T_cam_world * T_world_anchor;
    const Eigen::Vector3d p = an.T_cam_anchor.translation();
    const Eigen::Vector3d q = K * p;
    an.pixel = showThroughLens(impl_->K, impl_->canvas, cv::Point2d(q.x() / q.z(), q.y() / q.z()));
    an.in_view = p.z() > 0 && an.pixel.x >= 0 && an.pixel.x < o.width && an.pixel.y >= 0 &&
                 an.pixel.y < o.height;
    gt.anchors.push_back(an);
  }
  return gt;
}

std::vector<ImuSample> SceneGenerator::imuSamples() const {
  const SceneOptions& o = options_;
  const Eigen::Matrix3d R_cam_imu = o.q_cam_imu.toRotationMatrix();
  const Eigen::Vector3d g_world(0, 0, -kGravity);
  const int n = static_cast<int>(std::floor(o.duration * o.imu_rate + 1e-6)) + 1;
  cv::RNG rng(scene_detail::mixSeed(o.seed, 0x1a1a1a));
  auto R_world_imu = [&](double t) { return Eigen::Matrix3d(T_world_cam(t).linear() * R_cam_imu); };
  auto position = [&](double t) { return Eigen::Vector3d(T_world_cam(t).translation()); };
  constexpr double hr = 1e-4;  // s, central difference step for the rotation
  constexpr double hp = 1e-3;  // s, for the position's second derivative
  std::vector<ImuSample> out;
  out.reserve(n);
  for (int k = 0; k < n; ++k) {
    const double t = k / o.imu_rate;
    ImuSample s;
    s.stamp = o.start_time + t;
    const Eigen::Matrix3d R = R_world_imu(t);
    // Body rate: R(t-h)^T R(t+h) = exp([w] 2h) + O(h^3).
    const Eigen::AngleAxisd d(R_world_imu(t - hr).transpose() * R_world_imu(t + hr));
    s.gyro = d.axis() * d.angle() / (2 * hr) + o.gyro_bias;
    const Eigen::Vector3d a_world =
        (position(t + hp) - 2 * position(t) + position(t - hp)) / (hp * hp);
    s.accel = R.transpose() * (a_world - g_world);
    for (int c = 0; c < 3; ++c) {
      s.gyro(c) += rng.gaussian(o.gyro_noise);
      s.accel(c) += rng.gaussian(o.accel_noise);
    }
    s.orientation = Eigen::Quaterniond(R).normalized();
    s.has_orientation = true;
    out.push_back(s);
  }
  return out;
}

}  // namespace imt
