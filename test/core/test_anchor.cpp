// Calibration-free 6DoF anchors: the pose math against exact inputs, and end
// to end on the rendered `floor_walk` scene (camera 1.2 m over a textured
// floor, walking, pitching and rolling, yawing away from the anchor for ~2 s
// and back; IMU frame rotated relative to the camera): real motion analysis,
// region tracking of a box around the tapped pixel, gyro orientation.
#include "instant_motion_tracking/core/anchor/anchor.h"
#include "instant_motion_tracking/core/anchor/imu_orientation.h"
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/region/region_manager.h"
#include "instant_motion_tracking/sim/scene.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>

namespace imt {
namespace {

double angleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180 / M_PI;
}

TEST(Anchor, OrientationIsUpAndLevelledViewDirection) {
  // Camera looking along world +y, pitched 30 degrees down, rolled 10.
  const Eigen::Matrix3d R_level = (Eigen::Matrix3d() << 1, 0, 0, 0, 0, 1, 0, -1, 0).finished();
  const Eigen::Matrix3d R_wc = R_level * Eigen::AngleAxisd(0.52, Eigen::Vector3d::UnitX()).toRotationMatrix() *
                               Eigen::AngleAxisd(0.17, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Matrix3d R = anchorOrientation(R_wc);
  EXPECT_TRUE(R.col(2).isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(R.col(0).z(), 0.0, 1e-12);
  EXPECT_GT(R.col(0).dot(R_wc.col(2)), 0.8);  // the view direction, levelled
  EXPECT_NEAR(R.determinant(), 1.0, 1e-12);
  // Looking straight down: still a proper rotation with z up.
  const Eigen::Matrix3d down = (Eigen::Matrix3d() << 1, 0, 0, 0, -1, 0, 0, 0, -1).finished();
  const Eigen::Matrix3d Rd = anchorOrientation(down);
  EXPECT_NEAR(Rd.determinant(), 1.0, 1e-12);
  EXPECT_TRUE(Rd.col(2).isApprox(Eigen::Vector3d::UnitZ()));
}

TEST(Anchor, PoseFromExactInputsMatchesTheScene) {
  auto opt = SceneOptions::fromPreset("floor_walk");
  ASSERT_TRUE(opt);
  std::string err;
  auto scene = SceneGenerator::create(*opt, &err);
  ASSERT_TRUE(scene) << err;
  const FrameTruth f0 = scene->frameTruth(0);
  ASSERT_FALSE(f0.anchors.empty());
  const Eigen::Matrix3d R_wa = anchorOrientation(f0.T_world_cam.linear());
  const double d0 = f0.anchors[0].T_cam_anchor.translation().norm();
  for (int i : {0, 60, 200}) {
    const FrameTruth f = scene->frameTruth(i);
    const auto& a = f.anchors[0];
    const double ratio = a.T_cam_anchor.translation().norm() / d0;  // what the region scale would give
    const Eigen::Isometry3d T = anchorPose(a.pixel, ratio, d0, scene->intrinsics(), f.T_world_cam.linear(), R_wa);
    EXPECT_LT((T.translation() - a.T_cam_anchor.translation()).norm(), 1e-6) << i;
    EXPECT_LT(angleDeg(T.linear(), a.T_cam_anchor.linear()), 1e-6) << i;
  }
}

// patchSizeFactor against the projection of a small square patch: sqrt of its
// image area times its range / f equals factor * side for any pixel, range
// and normal (up to the patch's finite size: 1 mm at >= 1 m, so 1e-3 relative).
TEST(Anchor, PatchSizeFactorIsTheProjectedSizeTimesRange) {
  CameraModel K = CameraModel::fromFieldOfView(640, 480, 70.0);
  const double side = 1e-3;
  for (const cv::Point2d px : {cv::Point2d(320, 240), cv::Point2d(600, 60), cv::Point2d(30, 400)}) {
    for (const double range : {1.0, 4.0}) {
      for (const Eigen::Vector3d& n : {Eigen::Vector3d(0, 0, -1), Eigen::Vector3d(0, -1, -0.3),
                                      Eigen::Vector3d(0.5, -1, -0.2)}) {
        const Eigen::Vector3d d = Eigen::Vector3d((px.x - K.cx) / K.fx, (px.y - K.cy) / K.fy, 1).normalized();
        const Eigen::Vector3d c = range * d, nn = n.normalized();
        if (std::abs(nn.dot(d)) < 0.1) continue;  // floored: a grazing view
        const Eigen::Vector3d u = nn.unitOrthogonal(), v = nn.cross(u);
        std::vector<cv::Point2f> quad;
        for (const auto& [a, b] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
          const Eigen::Vector3d p = c + side / 2 * (a * u + b * v);
          quad.emplace_back(K.fx * p.x() / p.z() + K.cx, K.fy * p.y() / p.z() + K.cy);
        }
        const double measured = std::sqrt(cv::contourArea(quad)) * range / K.fx;
        EXPECT_NEAR(measured / side, patchSizeFactor(px, K, &n), 1e-3 * patchSizeFactor(px, K, &n))
            << px << " range " << range << " n " << n.transpose();
      }
    }
  }
  // Facing the camera (no normal): n = d.
  const cv::Point2d px(600, 60);
  const Eigen::Vector3d d = Eigen::Vector3d((px.x - K.cx) / K.fx, (px.y - K.cy) / K.fy, 1).normalized();
  EXPECT_NEAR(patchSizeFactor(px, K), patchSizeFactor(px, K, &d), 1e-12);
}

// End to end on floor_walk (region tracking, the IMU, the range correction):
// test_anchor_manager.cpp, AnchorManager.FloorWalkAgainstGroundTruth.

}  // namespace
}  // namespace imt
