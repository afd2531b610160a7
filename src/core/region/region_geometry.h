// Box geometry, and a peak's sub-step offset, shared by the region tracker's
// files (private to it).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>

namespace imt {
namespace region_geometry {

// The box of size w x h centred on c.
inline cv::Rect2d boxAt(const Eigen::Vector2d& c, double w, double h) {
  return cv::Rect2d(c.x() - w / 2, c.y() - h / 2, w, h);
}

inline Eigen::Vector2d centre(const cv::Rect2d& b) { return {b.x + b.width / 2, b.y + b.height / 2}; }

// `b` with the aspect (width / height) `aspect` and the same centre and area;
// `b` itself when the aspect is unknown (0).
inline cv::Rect2d withAspect(const cv::Rect2d& b, double aspect) {
  if (!(aspect > 0) || !(b.height > 0)) return b;
  const double k = std::sqrt(aspect / (b.width / b.height));
  return boxAt(centre(b), k * b.width, b.height / k);
}

// `b` with the size `size` and the same centre; `b` itself when `size` is
// empty or not finite.
inline cv::Rect2d withSize(const cv::Rect2d& b, const cv::Size2d& size) {
  if (!(size.width > 0 && size.height > 0 && std::isfinite(size.width) && std::isfinite(size.height))) return b;
  return boxAt(centre(b), size.width, size.height);
}

// The axis-aligned extent of `box` turned by `angle` (rad) about its centre.
inline cv::Rect2d turnedExtent(const cv::Rect2d& box, double angle) {
  const double c = std::abs(std::cos(angle)), s = std::abs(std::sin(angle));
  return boxAt(centre(box), box.width * c + box.height * s, box.width * s + box.height * c);
}

// The axis-aligned extent reported for a region whose `box` has turned by
// `angle`: what lies inside the box is unknown. A rectangle filling it (a
// poster, a screen) grows its extent most as it turns, a round object not at
// all, and an object already turned when the box was drawn grows less than
// the box would. The extent is the mean of the turned rectangle's and the
// turned inscribed ellipse's.
inline cv::Rect2d reportedExtent(const cv::Rect2d& box, double angle) {
  const cv::Rect2d rect = turnedExtent(box, angle);
  const double c = std::cos(angle), s = std::sin(angle), w = box.width, h = box.height;
  const double ew = std::sqrt(w * w * c * c + h * h * s * s), eh = std::sqrt(w * w * s * s + h * h * c * c);
  return boxAt(centre(box), 0.5 * (rect.width + ew), 0.5 * (rect.height + eh));
}

// Where a peak lies between its two neighbours' samples (a parabola through
// the three), in steps from the centre sample, within [-0.5, 0.5]; 0 when
// the centre is no peak.
inline double peakOffset(double left, double centre, double right) {
  const double d = left - 2.0 * centre + right;
  if (!(d < 0)) return 0;
  return std::clamp(0.5 * (left - right) / d, -0.5, 0.5);
}

// How far apart two sizes are: |log| of the ratio of their geometric-mean
// sides (0 when equal; log(1.1) when one is 1.1x the other).
inline double sizeOff(const cv::Size2d& a, const cv::Size2d& b) {
  return std::abs(std::log(a.area() / std::max(1e-9, b.area()))) / 2;
}

// The fraction of `box` inside an image of `size`.
inline double fractionInside(const cv::Rect2d& box, cv::Size size) {
  const cv::Rect2d inter = box & cv::Rect2d(0, 0, size.width, size.height);
  return box.area() > 0 ? inter.area() / box.area() : 0;
}

}  // namespace region_geometry
}  // namespace imt
