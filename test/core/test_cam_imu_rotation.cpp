// Tests of the IMU-to-camera rotation found from the video (issue 14):
// rotations read off camera-motion homographies, and the estimator that
// aligns them with the gyro's.
#include "instant_motion_tracking/core/anchor/cam_imu_rotation.h"
#include "instant_motion_tracking/core/anchor/imu_orientation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace imt {
namespace {

constexpr double kDeg = 180.0 / M_PI;

double angleDeg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return Eigen::AngleAxisd(A.transpose() * B).angle() * kDeg;
}

CameraModel camera(bool lens) {
  CameraModel k = CameraModel::fromFieldOfView(640, 480, 60);
  if (lens) {
    std::string why;
    EXPECT_TRUE(k.setDistortion(CameraModel::Distortion::kPlumbBob, {-0.28, 0.07, 0, 0, 0}, &why)) << why;
  }
  return k;
}

TEST(RotationFromHomography, ReadsTheTurnOffARotationHomography) {
  const Eigen::Matrix3d R = quaternionExp(Eigen::Vector3d(0.01, -0.02, 0.015)).toRotationMatrix();
  for (const bool lens : {false, true}) {
    const CameraModel k = camera(lens);
    const Eigen::Matrix3d H_ideal = k.K() * R * k.K().inverse();
    // Through the lens the image motion is no homography: the best fit of it.
    const Eigen::Matrix3d H = lens ? k.imageHomography(H_ideal) : H_ideal;
    Eigen::Matrix3d found;
    double rms = -1;
    ASSERT_TRUE(rotationFromHomography(k, H, &found, &rms));
    // Exact through a pinhole; through the lens within the homography's own
    // fit of the distorted motion (CameraModel::imageHomography: ~1 px at the
    // edges for this turn of 1.5 deg).
    EXPECT_LT(angleDeg(found, R), lens ? 0.05 : 1e-6) << "lens " << lens;
    EXPECT_LT(rms, lens ? 1.5 : 1e-6) << "lens " << lens;
    std::printf("lens %d: turn found within %.4f deg, rms %.3f px\n", lens, angleDeg(found, R), rms);
  }
}

TEST(RotationFromHomography, SaysWhenTheMotionIsNoTurn) {
  // A camera 1 m from a wall moving 10 cm sideways and 10 cm closer: the
  // wall's homography K (I + t n^T / d) K^-1 is no rotation.
  const CameraModel k = camera(false);
  const Eigen::Vector3d t(0.1, 0, -0.1), n(0, 0, 1);
  const Eigen::Matrix3d H = k.K() * (Eigen::Matrix3d::Identity() + t * n.transpose() / 1.0) * k.K().inverse();
  Eigen::Matrix3d found;
  double rms = -1;
  ASSERT_TRUE(rotationFromHomography(k, H, &found, &rms));
  EXPECT_GT(rms, 10.0);  // tens of pixels off: the zoom no rotation makes
  // Unusable input: no answer.
  EXPECT_FALSE(rotationFromHomography(k, Eigen::Matrix3d::Constant(NAN), &found, &rms));
  EXPECT_FALSE(rotationFromHomography(CameraModel(), H, &found, &rms));
}

// A hand's turns between frames (rad per frame, ~30 frames/s): smooth, on
// all three axes, with the gyro's and the video's noise.
struct Turns {
  std::vector<Eigen::Vector3d> imu, cam;
};
Turns handTurns(const Eigen::Matrix3d& R_cam_imu, int frames, double noise, const Eigen::Vector3d& axes, int seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 1);
  Turns t;
  for (int f = 0; f < frames; ++f) {
    const double s = f / 30.0;
    const Eigen::Vector3d w(std::sin(2.1 * s) + 0.3 * std::sin(7.3 * s), std::cos(1.3 * s + 0.5),
                            std::sin(0.9 * s + 1.0) * std::cos(3.1 * s));
    const Eigen::Vector3d theta = 0.02 * w.cwiseProduct(axes);  // up to ~1.2 deg per frame
    t.imu.push_back(theta + noise * Eigen::Vector3d(n(rng), n(rng), n(rng)));
    t.cam.push_back(R_cam_imu * theta + noise * Eigen::Vector3d(n(rng), n(rng), n(rng)));
  }
  return t;
}

TEST(CamImuRotationEstimator, FindsAnArbitraryRotationFromOrdinaryHandMotion) {
  // An IMU mounted at an arbitrary angle (rotated about a tilted axis by 128 deg).
  const Eigen::Matrix3d R = Eigen::AngleAxisd(128 / kDeg, Eigen::Vector3d(1, -2, 0.5).normalized()).toRotationMatrix();
  // 5 s at 30 frames/s; noise 0.02 deg per frame on each axis, both sides
  // (the visual turn's: 0.2 px at this focal length; the gyro's is far less).
  const Turns t = handTurns(R, 150, 0.02 / kDeg, Eigen::Vector3d::Ones(), 1);
  CamImuRotationEstimator est;
  for (size_t i = 0; i < t.imu.size(); ++i) est.add(t.cam[i], t.imu[i]);
  ASSERT_TRUE(est.estimate().has_value());
  const double err = angleDeg(est.estimate()->toRotationMatrix(), R);
  std::printf("hand motion, 5 s: found within %.3f deg (residual %.3f, %zu pairs)\n", err, est.residual(), est.pairs());
  EXPECT_LT(err, 1.0);  // the goal: within 1 deg after 5 s of ordinary hand motion
}

TEST(CamImuRotationEstimator, WaitsForTurnsOnTwoAxesAndIgnoresOddFrames) {
  const Eigen::Matrix3d R = Eigen::AngleAxisd(40 / kDeg, Eigen::Vector3d(0, 1, 1).normalized()).toRotationMatrix();
  // A pan about one axis only: the rotation about that axis is free.
  const Turns pan = handTurns(R, 300, 0.02 / kDeg, Eigen::Vector3d(1, 0, 0), 2);
  CamImuRotationEstimator est;
  for (size_t i = 0; i < pan.imu.size(); ++i) est.add(pan.cam[i], pan.imu[i]);
  EXPECT_FALSE(est.estimate().has_value());
  // Then ordinary motion, with one frame in 10 whose visual turn is wrong
  // (a passing object took the background's motion): found all the same.
  const Turns hand = handTurns(R, 300, 0.02 / kDeg, Eigen::Vector3d::Ones(), 3);
  for (size_t i = 0; i < hand.imu.size(); ++i)
    est.add(i % 10 == 0 ? Eigen::Vector3d(hand.cam[i].z(), -hand.cam[i].x(), 2 * hand.cam[i].y()) : hand.cam[i],
            hand.imu[i]);
  ASSERT_TRUE(est.estimate().has_value());
  EXPECT_LT(angleDeg(est.estimate()->toRotationMatrix(), R), 0.5);
  // Turns that disagree with any one rotation (the camera and IMU on
  // different bodies): no estimate.
  CamImuRotationEstimator wrong;
  std::mt19937 rng(4);
  std::normal_distribution<double> n(0, 0.01);
  for (int i = 0; i < 300; ++i) wrong.add(Eigen::Vector3d(n(rng), n(rng), n(rng)), Eigen::Vector3d(n(rng), n(rng), n(rng)));
  EXPECT_FALSE(wrong.estimate().has_value());
  EXPECT_GT(wrong.residual(), 0.25);
  // Non-finite input is ignored.
  const size_t before = est.pairs();
  est.add(Eigen::Vector3d(NAN, 0, 0), Eigen::Vector3d(0.1, 0, 0));
  EXPECT_EQ(est.pairs(), before);
}

}  // namespace
}  // namespace imt
