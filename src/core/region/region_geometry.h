// Box geometry shared by the region tracker's files (private to it).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

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

// The fraction of `box` inside an image of `size`.
inline double fractionInside(const cv::Rect2d& box, cv::Size size) {
  const cv::Rect2d inter = box & cv::Rect2d(0, 0, size.width, size.height);
  return box.area() > 0 ? inter.area() / box.area() : 0;
}

}  // namespace region_geometry
}  // namespace imt
