// Calibration-free 6DoF anchor pose (paper 3.4): translation and relative
// scale from a tracked region, rotation from the IMU, "up" from gravity.
//
// The anchor point lies along the ray through the region's current centre
// pixel, at depth0 * width0 / width (the user sets the initial depth; the
// region's scale change gives the relative depth), corrected by
// patchSizeFactor() for where the region sits in the image and how obliquely
// its surface is seen. Its frame (interface spec)
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

// How large a small surface patch looks at `pixel` relative to its range:
// its image size is proportional to this / range, namely sqrt(|n . d|) / d_z^1.5
// for the unit ray d through the pixel and the patch's unit normal n (camera
// frame; image area = f^2 area |n . d| / (range^2 d_z^3)). Without a normal
// the patch faces the camera (n . d = 1). |n . d| and d_z are floored at 0.1
// (grazing views, rays near 90 degrees off-axis). `pixel` is an image pixel:
// through a distorting lens the ray is its undistorted pixel's, and the
// factor includes the lens's local magnification there (localScale).
double patchSizeFactor(const cv::Point2d& pixel, const CameraModel& k,
                       const Eigen::Vector3d* normal_cam = nullptr);

// T_cam_anchor for the anchor seen at `pixel` (our pixel convention) with
// relative scale `scale_ratio` = width0 / width (> 0), initial distance
// `depth0` (m, along the pixel's unit ray, as the spec's `depth`), camera `k`
// (the ray goes through k.undistort(pixel): `pixel` is an image pixel).
Eigen::Isometry3d anchorPose(const cv::Point2d& pixel, double scale_ratio, double depth0,
                             const CameraModel& k, const Eigen::Matrix3d& R_world_cam_now,
                             const Eigen::Matrix3d& R_world_anchor);

}  // namespace imt
