// Box overlap for scoring trackers against ground truth, shared by the
// tests, the rostest nodes and the benchmarks: intersection over union, and
// the same of the boxes clipped to the image (the truth's box of a region
// partly outside the image extends past it; a tracker's need not).
#pragma once

#include <opencv2/core.hpp>

namespace imt {
namespace test {

inline double iou(const cv::Rect2d& a, const cv::Rect2d& b) {
  const double i = (a & b).area();
  const double u = a.area() + b.area() - i;
  return u > 0 ? i / u : 0;
}

inline cv::Rect2d clipToImage(const cv::Rect2d& box, cv::Size size) {
  return box & cv::Rect2d(0, 0, size.width, size.height);
}

inline double iouClipped(const cv::Rect2d& a, const cv::Rect2d& b, cv::Size size) {
  return iou(clipToImage(a, size), clipToImage(b, size));
}

}  // namespace test
}  // namespace imt
