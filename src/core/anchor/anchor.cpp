#include "instant_motion_tracking/core/anchor/anchor.h"

#include <algorithm>
#include <cmath>

namespace imt {

Eigen::Matrix3d anchorOrientation(const Eigen::Matrix3d& R_world_cam_at_placement) {
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d x = R_world_cam_at_placement.col(2);  // optical axis in the world
  x.z() = 0;
  if (x.norm() < 1e-6) {  // looking straight down or up: the image's down axis instead
    x = R_world_cam_at_placement.col(1);
    x.z() = 0;
  }
  x.normalize();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

double patchSizeFactor(const cv::Point2d& pixel, const CameraModel& k, const Eigen::Vector3d* normal_cam) {
  const cv::Point2d ideal = k.undistort(pixel);  // the ray is the ideal pinhole pixel's
  const Eigen::Vector3d d = Eigen::Vector3d((ideal.x - k.cx) / k.fx, (ideal.y - k.cy) / k.fy, 1.0).normalized();
  const double dz = std::max(d.z(), 0.1);
  const double nd = normal_cam ? std::max(std::abs(normal_cam->normalized().dot(d)), 0.1) : 1.0;
  const double pinhole = std::sqrt(nd) / std::pow(dz, 1.5);
  return k.hasDistortion() ? pinhole * k.localScale(ideal) : pinhole;
}

Eigen::Isometry3d anchorPose(const cv::Point2d& pixel, double scale_ratio, double depth0,
                             const CameraModel& k, const Eigen::Matrix3d& R_world_cam_now,
                             const Eigen::Matrix3d& R_world_anchor) {
  const cv::Point2d ideal = k.undistort(pixel);  // image pixel -> the ray's ideal pinhole pixel
  const Eigen::Vector3d ray =
      Eigen::Vector3d((ideal.x - k.cx) / k.fx, (ideal.y - k.cy) / k.fy, 1.0).normalized();
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.translation() = depth0 * scale_ratio * ray;
  T.linear() = R_world_cam_now.transpose() * R_world_anchor;
  return T;
}

}  // namespace imt
