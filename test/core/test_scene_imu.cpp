// Tests of the scene generator's IMU stream against its trajectory.
#include "instant_motion_tracking/sim/scene.h"

#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

namespace imt {
namespace {

using test::make;
using test::preset;

double rotationAngleDeg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return Eigen::AngleAxisd(A.transpose() * B).angle() * 180.0 / M_PI;
}

// Integrates the gyro (midpoint rule on consecutive samples) from the first
// sample's orientation and returns the worst angle to the trajectory's
// R_world_cam over all samples.
double gyroIntegrationErrorDeg(const SceneGenerator& scene) {
  const std::vector<ImuSample> imu = scene.imuSamples();
  const Eigen::Matrix3d R_cam_imu = scene.options().q_cam_imu.toRotationMatrix();
  Eigen::Matrix3d R = scene.T_world_cam(0).linear() * R_cam_imu;  // R_world_imu(0)
  double worst = 0;
  for (size_t k = 1; k < imu.size(); ++k) {
    const double dt = imu[k].stamp - imu[k - 1].stamp;
    const Eigen::Vector3d w = 0.5 * (imu[k].gyro + imu[k - 1].gyro);
    if (w.norm() > 0) R = R * Eigen::AngleAxisd(w.norm() * dt, w.normalized()).toRotationMatrix();
    const double t = imu[k].stamp - scene.options().start_time;
    worst =
        std::max(worst, rotationAngleDeg(R * R_cam_imu.transpose(), scene.T_world_cam(t).linear()));
  }
  return worst;
}

TEST(SceneImu, GyroIntegrationReproducesTheTrajectory) {
  for (const std::string name :
       {"wall_pan", "poster_orbit", "floor_walk", "region_follow", "poster_handheld"}) {
    SceneOptions o = preset(name);
    o.duration = 10;
    for (ScenePlane& p : o.planes) p.flat = true;  // no textures needed here
    auto scene = make(o);
    ASSERT_TRUE(scene);
    const double err = gyroIntegrationErrorDeg(*scene);
    // Default gyro noise 5e-4 rad/s per sample at 200 Hz: a random walk of
    // ~0.006 deg over 10 s; midpoint integration adds < 0.01 deg on these
    // smooth curves. Measured 0.005-0.02 deg.
    EXPECT_LT(err, 0.1) << name;
    std::printf("[ info ] %s: gyro integration error over 10 s %.4f deg\n", name.c_str(), err);
  }
}

TEST(SceneImu, SamplesCoverTheSceneInTheImuFrame) {
  SceneOptions o = preset("floor_walk");
  for (ScenePlane& p : o.planes) p.flat = true;
  o.gyro_noise = 0;
  o.accel_noise = 0;
  auto scene = make(o);
  ASSERT_TRUE(scene);
  const std::vector<ImuSample> imu = scene->imuSamples();
  ASSERT_EQ(imu.size(), static_cast<size_t>(o.duration * o.imu_rate) + 1);
  EXPECT_DOUBLE_EQ(imu.front().stamp, o.start_time);
  EXPECT_NEAR(imu.back().stamp, o.start_time + o.duration, 1e-9);
  const Eigen::Matrix3d R_cam_imu = o.q_cam_imu.toRotationMatrix();
  for (size_t k = 0; k < imu.size(); k += 97) {
    const double t = imu[k].stamp - o.start_time;
    ASSERT_TRUE(imu[k].has_orientation);
    EXPECT_LT(rotationAngleDeg(imu[k].orientation.toRotationMatrix(),
                               scene->T_world_cam(t).linear() * R_cam_imu),
              1e-6);
  }
  // Specific force: orientation * accel + g_world integrates to the change in
  // velocity of the camera (central differences of its position), over 1 s windows.
  auto velocity = [&](double t) {
    const double h = 1e-3;
    return Eigen::Vector3d(
        (scene->T_world_cam(t + h).translation() - scene->T_world_cam(t - h).translation()) /
        (2 * h));
  };
  const Eigen::Vector3d g(0, 0, -9.81);
  for (size_t start = 0; start + 200 < imu.size(); start += 400) {
    Eigen::Vector3d dv = Eigen::Vector3d::Zero();
    for (size_t k = start; k < start + 200; ++k) {
      const Eigen::Vector3d a0 = imu[k].orientation * imu[k].accel + g;
      const Eigen::Vector3d a1 = imu[k + 1].orientation * imu[k + 1].accel + g;
      dv += 0.5 * (a0 + a1) / o.imu_rate;
    }
    const double t0 = imu[start].stamp - o.start_time, t1 = imu[start + 200].stamp - o.start_time;
    // Trapezoid rule over a 2 cm, 1.1 Hz step bob: measured < 1e-4 m/s.
    EXPECT_LT((dv - (velocity(t1) - velocity(t0))).norm(), 2e-3) << "window at " << t0;
  }
  // The gyro bias is added as given, in the IMU frame.
  SceneOptions ob = o;
  ob.gyro_bias = Eigen::Vector3d(0.01, -0.02, 0.005);
  auto biased = make(ob);
  const std::vector<ImuSample> imu_b = biased->imuSamples();
  for (size_t k = 0; k < imu.size(); k += 211)
    EXPECT_LT((imu_b[k].gyro - imu[k].gyro - ob.gyro_bias).norm(), 1e-12);
}

TEST(SceneImu, AccelerometerAtRestReadsGravityUp) {
  SceneOptions o = preset("still");
  for (ScenePlane& p : o.planes) p.flat = true;
  auto scene = make(o);
  ASSERT_TRUE(scene);
  const std::vector<ImuSample> imu = scene->imuSamples();
  Eigen::Vector3d mean_world = Eigen::Vector3d::Zero(), mean_gyro = Eigen::Vector3d::Zero();
  for (const ImuSample& s : imu) {
    const Eigen::Vector3d a_world = s.orientation * s.accel;
    // accel_noise 0.01 m/s^2 per axis: 6 sigma.
    EXPECT_LT((a_world - Eigen::Vector3d(0, 0, 9.81)).norm(), 0.06);
    mean_world += a_world / imu.size();
    mean_gyro += s.gyro / imu.size();
  }
  EXPECT_LT((mean_world - Eigen::Vector3d(0, 0, 9.81)).norm(), 0.003);  // mean of 2001 samples
  EXPECT_LT(mean_gyro.norm(), 1e-4);
  // In the IMU frame gravity is not trivially along z: the camera looks
  // horizontally (optical y down = IMU +x, as R_cam_imu is 90 deg about z),
  // so "up" is the IMU's -x axis.
  EXPECT_NEAR(imu[0].accel.x(), -9.81, 0.05);
}

}  // namespace
}  // namespace imt
