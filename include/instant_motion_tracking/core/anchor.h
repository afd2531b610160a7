// Calibration-free 6DoF anchor pose (paper 3.4): translation and relative
// scale from a tracked region, rotation from the IMU, "up" from gravity.
//
// The anchor point lies along the ray through the region's current centre
// pixel, at depth0 * width0 / width (the user sets the initial depth; the
// region's scale change gives the relative depth). Its frame (interface spec)
// has z up (against gravity) and x the camera's viewing direction at
// placement, levelled to horizontal; y = z cross x. In the camera optical
// frame: R_cam_anchor = R_world_cam(now)^T * R_world_anchor.
//
// Usage:
//   Eigen::Matrix3d R_wa = imt::anchorOrientation(R_world_cam_at_placement);
//   Eigen::Isometry3d T = imt::anchorPose(pixel, width0 / width, depth0, K, R_world_cam_now, R_wa);
#pragma once

#include "instant_motion_tracking/core/types.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace imt {

// The anchor frame's orientation in the world: z = world up, x = the
// camera's optical axis at placement projected on the horizontal plane
// (the camera's down axis when it looks straight down or up).
Eigen::Matrix3d anchorOrientation(const Eigen::Matrix3d& R_world_cam_at_placement);

// T_cam_anchor for the anchor seen at `pixel` (our pixel convention) with
// relative scale `scale_ratio` = width0 / width (> 0), initial distance
// `depth0` (m, along the pixel's unit ray, as the spec's `depth`), intrinsics `k`.
Eigen::Isometry3d anchorPose(const cv::Point2d& pixel, double scale_ratio, double depth0,
                             const CameraIntrinsics& k, const Eigen::Matrix3d& R_world_cam_now,
                             const Eigen::Matrix3d& R_world_anchor);

}  // namespace imt
