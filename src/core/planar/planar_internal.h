// Private to the planar tracker (src/core/planar): the pose fit and quad
// helpers shared by planar_target.cpp (features) and
// planar_target_alignment.cpp (appearance), and the tracker's appearance model.
#pragma once

#include "instant_motion_tracking/core/planar/planar_target.h"

#include "planar_appearance.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <vector>

namespace imt {
namespace planar_detail {

// A point of the target plane (X, Y) and where it is seen (u, v), an ideal
// pinhole pixel (CameraModel::undistort of the image pixel).
struct PlaneObservation {
  uint32_t id;
  Eigen::Vector2d xy, uv;
};

// The pose (target to camera) that minimises the reprojection error of `obs`,
// by Levenberg-Marquardt from `T` (updated in place); `loss_scale` > 0 makes
// the loss Huber. False when no usable solution was found.
bool fitPose(const std::vector<PlaneObservation>& obs, const CameraModel& k, double loss_scale,
             int max_iterations, Eigen::Isometry3d* T);
// The target's corners TL, TR, BR, BL in its own frame (m; origin at the centre).
std::array<Eigen::Vector3d, 4> targetCorners(double w, double h);
double longestEdge(const std::array<cv::Point2d, 4>& c);  // px
cv::Rect2d quadBounds(const std::array<cv::Point2d, 4>& c);  // px; the axis-aligned box around the corners
double quadArea(const std::array<cv::Point2d, 4>& c);     // px^2, signed (positive clockwise on screen)
// Fraction of the quad's area inside a w x h image.
double fractionInside(const std::array<cv::Point2d, 4>& c, int w, int h);

}  // namespace planar_detail

// The target as seen at placement, rectified onto its plane: a pyramid of
// templates (level l has 2^-l the resolution of level 0) and their masks.
struct PlanarTargetTracker::Appearance {
  std::vector<cv::Mat> levels;     // CV_32F
  std::vector<cv::Mat> masks;      // CV_8U, 255 where the frame saw the target
  std::vector<cv::Mat> gradients;  // CV_32F, gradient magnitude of each level
  std::vector<planar_detail::TemplateWindows> windows;  // of each level, for unoccludedPixels
  std::vector<planar_detail::EccTemplate> ecc;  // each level prepared for the alignment
  double px_per_m = 0;             // level-0 template pixels per metre
};

}  // namespace imt
