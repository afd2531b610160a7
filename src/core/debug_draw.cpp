#include "instant_motion_tracking/core/debug_draw.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

namespace imt {
namespace {

// Our pixel convention has pixel centres at +0.5; OpenCV draws at integers.
cv::Point toCv(double x, double y) {
  return cv::Point(static_cast<int>(std::lround(x - 0.5)), static_cast<int>(std::lround(y - 0.5)));
}

// White text with a dark outline, readable on any background.
void label(cv::Mat* out, const std::string& text, cv::Point at, const cv::Scalar& colour,
           double scale = 0.45) {
  at.x = std::clamp(at.x, 2, std::max(2, out->cols - 40));
  at.y = std::clamp(at.y, 12, std::max(12, out->rows - 4));
  cv::putText(*out, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, cv::Scalar(0, 0, 0), 3, cv::LINE_AA);
  cv::putText(*out, text, at, cv::FONT_HERSHEY_SIMPLEX, scale, colour, 1, cv::LINE_AA);
}

// Tracked items are drawn bright and 2 px wide; the others (featureless,
// out of view, no IMU) at half intensity and 1 px wide.
cv::Scalar shade(const cv::Scalar& colour, bool tracked) { return tracked ? colour : colour * 0.5; }
int width(bool tracked) { return tracked ? 2 : 1; }

// Projects p (camera optical frame, m) through k, lens distortion included
// (an image pixel); false behind the camera.
bool project(const CameraModel& k, const Eigen::Vector3d& p, cv::Point2d* uv) {
  if (!(p.z() > 1e-6) || !p.allFinite()) return false;
  *uv = k.distort(cv::Point2d(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy));
  return std::isfinite(uv->x) && std::isfinite(uv->y);
}

// The x (red), y (green), z (blue) axes of T, `length` m long.
void drawAxes(cv::Mat* out, const CameraModel& k, const Eigen::Isometry3d& T, double length) {
  if (!k.valid || !(length > 0) || !T.matrix().allFinite()) return;
  cv::Point2d o;
  if (!project(k, T.translation(), &o)) return;
  const cv::Scalar colours[3] = {cv::Scalar(0, 0, 255), cv::Scalar(0, 200, 0),
                                 cv::Scalar(255, 0, 0)};
  for (int i = 0; i < 3; ++i) {
    cv::Point2d e;
    if (project(k, T * Eigen::Vector3d(length * Eigen::Vector3d::Unit(i)), &e))
      cv::line(*out, toCv(o.x, o.y), toCv(e.x, e.y), colours[i], 2, cv::LINE_AA);
  }
}

void drawRegion(cv::Mat* out, const RegionState& s) {
  const cv::Rect2d b = s.extent();
  if (s.status == RegionStatus::kLost || !(std::isfinite(b.x) && std::isfinite(b.y) &&
                                           std::isfinite(b.width) && std::isfinite(b.height)))
    return;
  const bool tracked = s.status == RegionStatus::kTracked;
  // The box covers pixels [x, x + width): its last pixel starts at x + width - 1.
  cv::rectangle(*out, toCv(b.x + 0.5, b.y + 0.5), toCv(b.x + b.width - 0.5, b.y + b.height - 0.5),
                shade(kRegionColour, tracked), width(tracked), cv::LINE_AA);
  label(out, std::to_string(s.id) + " " + regionStatusName(s.status), toCv(b.x, b.y - 5),
        shade(kRegionColour, tracked));
}

void drawTarget(cv::Mat* out, const PlanarTargetState& s, const CameraModel& k) {
  if (!s.hasPose()) return;
  for (const cv::Point2d& c : s.corners)
    if (!std::isfinite(c.x) || !std::isfinite(c.y)) return;
  const bool tracked = s.status == TargetStatus::kTracked;
  const cv::Scalar colour = shade(kPlanarTargetColour, tracked);
  std::vector<cv::Point> quad;
  for (const cv::Point2d& c : s.corners) quad.push_back(toCv(c.x, c.y));
  cv::polylines(*out, quad, true, colour, width(tracked), cv::LINE_AA);
  cv::circle(*out, quad[0], 4, colour, cv::FILLED, cv::LINE_AA);  // TL: the order given at init
  const double size = std::min(s.width_m, s.height_m);
  drawAxes(out, k, s.T_cam_target, 0.5 * size);
  std::string text = "P" + std::to_string(s.id);
  if (!tracked) text += std::string(" ") + targetStatusName(s.status);
  label(out, text, quad[3] + cv::Point(0, 16), colour);  // below BL: region labels sit above boxes
}

void drawAnchor(cv::Mat* out, const AnchorState& s, const CameraModel& k) {
  if (s.status == AnchorStatus::kLost || !std::isfinite(s.pixel.x) || !std::isfinite(s.pixel.y))
    return;
  const bool tracked = s.status == AnchorStatus::kTracked;
  const cv::Scalar colour = shade(kAnchorColour, tracked);
  const cv::Point p = toCv(s.pixel.x, s.pixel.y);
  drawAxes(out, k, s.T_cam_anchor, 0.1 * s.T_cam_anchor.translation().norm());
  cv::circle(*out, p, 7, colour, width(tracked), cv::LINE_AA);
  cv::circle(*out, p, 2, colour, cv::FILLED, cv::LINE_AA);
  std::string text = "A" + std::to_string(s.id);
  if (!tracked) text += std::string(" ") + anchorStatusName(s.status);
  label(out, text, p + cv::Point(9, -9), colour);
}

}  // namespace

cv::Mat drawMotionData(const cv::Mat& gray, const MotionData& md, double vector_scale) {
  cv::Mat out;
  if (gray.empty()) return out;
  cv::cvtColor(gray, out, cv::COLOR_GRAY2BGR);
  const cv::Scalar kBackground(60, 200, 60), kForeground(40, 40, 230);
  for (const FeatureMotion& f : md.features) {
    const cv::Point2d p(f.x - 0.5, f.y - 0.5);
    const cv::Scalar colour = f.foreground ? kForeground : kBackground;
    cv::circle(out, p, 2, colour, cv::FILLED, cv::LINE_AA);
    if (f.foreground) {
      const cv::Point2d tail(p.x - vector_scale * f.dx, p.y - vector_scale * f.dy);
      cv::line(out, tail, p, colour, 1, cv::LINE_AA);
    }
  }
  char text[128];
  std::snprintf(text, sizeof(text), "%s  features %d  inliers %d", motionModelName(md.camera.model),
                md.camera.features, md.camera.inliers);
  label(&out, text, cv::Point(8, 20), cv::Scalar(255, 255, 255), 0.5);
  return out;
}

void drawOverlay(cv::Mat* bgr, const DebugOverlay& overlay) {
  if (bgr->empty() || bgr->type() != CV_8UC3) return;
  for (const RegionState& s : overlay.regions) drawRegion(bgr, s);
  for (const PlanarTargetState& s : overlay.targets) drawTarget(bgr, s, overlay.intrinsics);
  for (const AnchorState& s : overlay.anchors) drawAnchor(bgr, s, overlay.intrinsics);
}

}  // namespace imt
