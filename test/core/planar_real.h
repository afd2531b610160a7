// Helpers of the planar tests on real video (POT-210, ViSP): the real clips
// give no intrinsics and no physical size, so the target is given with the
// aspect ratio its first quad implies under an assumed field of view.
#pragma once

#include "instant_motion_tracking/core/camera_model.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <vector>

namespace imt {
namespace test {

// The target's height / width, from its quad seen through the assumed
// intrinsics (0 when the quad does not rectify): the homography H from the
// unit square to the quad is K [w r1, h r2, t] up to scale, so the column
// norms of K^-1 H give the aspect ratio. The user gives the physical size;
// the clips do not, and this is what it implies under the assumed K.
inline double rectifiedAspect(const std::array<cv::Point2d, 4>& c, const CameraModel& k) {
  const std::vector<cv::Point2d> square = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  const cv::Mat H = cv::findHomography(square, std::vector<cv::Point2d>(c.begin(), c.end()));
  if (H.empty()) return 0;
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  const cv::Matx33d M = K.inv() * cv::Matx33d(H);
  const double w = std::hypot(std::hypot(M(0, 0), M(1, 0)), M(2, 0));
  const double h = std::hypot(std::hypot(M(0, 1), M(1, 1)), M(2, 1));
  return w > 0 ? h / w : 0;
}

// POT's precision at `px`: the fraction of the errors (px) at most `px` (0
// without errors).
inline double precisionAt(const std::vector<double>& errors, double px) {
  if (errors.empty()) return 0;
  return static_cast<double>(
             std::count_if(errors.begin(), errors.end(), [px](double e) { return e <= px; })) /
         errors.size();
}

}  // namespace test
}  // namespace imt
