// Tests of the gyro bias found from the video while the camera moves
// (issue 14, VideoGyroBias): synthetic turns with the video's noise, odd
// frames and an IMU-to-camera rotation known only roughly.
#include "instant_motion_tracking/core/anchor/video_gyro_bias.h"
#include "instant_motion_tracking/core/anchor/imu_orientation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

namespace imt {
namespace {

constexpr double kDeg = 180.0 / M_PI;
constexpr double kDt = 1.0 / 30;

// The hand's turn rate (IMU frame, rad/s) at time s.
Eigen::Vector3d handRate(double s) {
  return Eigen::Vector3d(0.3 * std::sin(2.1 * s), 0.2 * std::cos(1.3 * s + 0.5), 0.25 * std::sin(0.9 * s + 1.0));
}

// `frames` frames of a hand's turning (IMU frame, rad per frame) seen by a
// camera turned by R_cam_imu: the gyro's turn carries `bias`, the camera's
// `noise` rad per frame; every 25th frame is odd (a passing object: 5 deg
// off). `drift`: a turn rate kept throughout (rad/s, IMU frame), as a walk
// that keeps turning one way.
void feed(VideoGyroBias* vb, const Eigen::Matrix3d& R_cam_imu, const Eigen::Vector3d& bias, double noise, int frames,
          int seed, const Eigen::Vector3d& drift = Eigen::Vector3d::Zero()) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0, 1);
  for (int f = 0; f < frames; ++f) {
    const double s = f * kDt;
    const Eigen::Vector3d turn = (handRate(s) + drift) * kDt;  // rad, IMU frame
    Eigen::Vector3d cam = R_cam_imu * turn + noise * Eigen::Vector3d(n(rng), n(rng), n(rng));
    if (f % 25 == 24) cam += Eigen::Vector3d(0.09, 0, 0);
    vb->add(1000 + (f + 1) * kDt, kDt, turn + bias * kDt, cam);
  }
}

TEST(VideoGyroBias, FindsTheBiasWithItsStandardError) {
  const Eigen::Matrix3d R_cam_imu = quaternionExp(Eigen::Vector3d(0.3, -1.2, 0.5)).toRotationMatrix();
  const Eigen::Vector3d bias(0.005, -0.006, 0.0035);  // rad/s, 0.49 deg/s
  const double noise = 5e-5;                          // rad per frame (0.03 px at f = 600 px)
  VideoGyroBias vb(30.0);
  feed(&vb, R_cam_imu, bias, noise, VideoGyroBias::kMinFrames - 1, 1);
  EXPECT_FALSE(vb.estimate(R_cam_imu.transpose())) << "no estimate before kMinFrames frames";
  feed(&vb, R_cam_imu, bias, noise, 600, 2);
  const auto e = vb.estimate(R_cam_imu.transpose());
  ASSERT_TRUE(e);
  std::printf("bias off by %.4f deg/s, sigma %.4f deg/s, %d frames kept\n", (e->bias - bias).norm() * kDeg,
              e->sigma.norm() * kDeg, e->frames);
  // The odd frames are left out; the standard error is the noise's over the
  // frames (noise / dt / sqrt(n) per axis), the bias within 4 of it.
  EXPECT_LE(e->frames, 600 - 600 / 25 + 1);
  const double expected = noise / kDt / std::sqrt(e->frames);
  EXPECT_NEAR(e->sigma.x(), expected, 0.3 * expected);
  EXPECT_LE((e->bias - bias).cwiseAbs().maxCoeff(), 4 * expected);
}

// The IMU-to-camera rotation the video found is 1 deg off: an error e in it
// reads as a bias of e times the turn rate. Fitted together with the bias
// (refine_rotation), the bias holds; read with the rotation as given, it
// does not where the camera keeps turning one way.
TEST(VideoGyroBias, ARoughRotationIsRefinedWithTheBias) {
  const Eigen::Matrix3d R_cam_imu = quaternionExp(Eigen::Vector3d(0.3, -1.2, 0.5)).toRotationMatrix();
  const Eigen::Matrix3d rough = quaternionExp(Eigen::Vector3d(0.01, 0.012, -0.008)).toRotationMatrix() * R_cam_imu;
  const Eigen::Vector3d bias(0.005, -0.006, 0.0035);
  VideoGyroBias vb(30.0);
  feed(&vb, R_cam_imu, bias, 5e-5, 600, 3, Eigen::Vector3d(0.1, 0, 0.05));
  const auto as_given = vb.estimate(rough.transpose());
  const auto refined = vb.estimate(rough.transpose(), true);
  ASSERT_TRUE(as_given);
  ASSERT_TRUE(refined);
  std::printf("rough rotation: bias off by %.4f deg/s as given, %.4f deg/s refined (sigma %.4f)\n",
              (as_given->bias - bias).norm() * kDeg, (refined->bias - bias).norm() * kDeg,
              refined->sigma.norm() * kDeg);
  EXPECT_GT((as_given->bias - bias).norm() * kDeg, 0.05);
  EXPECT_LE((refined->bias - bias).norm(), 4 * refined->sigma.norm());
  EXPECT_LT((refined->bias - bias).norm() * kDeg, 0.01);
}

// The gyro is read `offset` s after the frames while the IMU's stamps are
// `truth` s after them: its turn over a frame is the hand's of offset -
// truth later. The offset in use moves from 0 to 40 ms halfway through
// 30 s (the time-offset fit applied), with the true one 30 ms: the frames
// read before the move are kept, their lateness against the newest offset
// taken out, and the lateness fitted is the newest offset's (+10 ms).
TEST(VideoGyroBias, FramesReadAtAnOlderOffsetAreKept) {
  const Eigen::Vector3d bias(0.005, -0.006, 0.0035);
  const double truth = 0.030;
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0, 1);
  VideoGyroBias vb(30.0), unlabelled(30.0);
  for (int f = 0; f < 900; ++f) {
    const double t0 = f * kDt, offset = f < 450 ? 0.0 : 0.040;
    Eigen::Vector3d gyro = bias * kDt, cam = Eigen::Vector3d::Zero();
    for (int k = 0; k < 20; ++k) {  // the turns over the frame, in 20 steps
      const double s = t0 + (k + 0.5) * kDt / 20;
      gyro += handRate(s + offset - truth) * kDt / 20;
      cam += handRate(s) * kDt / 20;
    }
    cam += 5e-5 * Eigen::Vector3d(n(rng), n(rng), n(rng));
    vb.add(1000 + t0 + kDt, kDt, gyro, cam, offset);
    unlabelled.add(1000 + t0 + kDt, kDt, gyro, cam);
  }
  const auto e = vb.estimate(Eigen::Matrix3d::Identity());
  const auto u = unlabelled.estimate(Eigen::Matrix3d::Identity());
  ASSERT_TRUE(e);
  ASSERT_TRUE(u);
  std::printf("offset moved 0 -> 40 ms (true 30 ms): bias off by %.4f deg/s (sigma %.4f), lateness %.1f +- %.1f ms; "
              "with the frames' offsets unknown %.4f deg/s, lateness %.1f ms\n",
              (e->bias - bias).norm() * kDeg, e->sigma.norm() * kDeg, 1e3 * e->lateness, 1e3 * e->lateness_sigma,
              (u->bias - bias).norm() * kDeg, 1e3 * u->lateness);
  EXPECT_LE((e->bias - bias).cwiseAbs().maxCoeff(), 4 * e->sigma.maxCoeff());
  // 2 ms: the rate's change is read from the camera's noisy rates (a
  // frame's 5e-5 rad is 1.5 mrad/s over 33 ms), and a frame's turn is its
  // mean rate, not the rate at its middle.
  EXPECT_NEAR(e->lateness, 0.010, 0.002);
  EXPECT_LE(e->lateness_sigma, 0.002);
}

TEST(VideoGyroBias, BadInputIsIgnoredAndOldFramesGo) {
  VideoGyroBias vb(2.0);  // 60 frames at 30 frames/s
  const Eigen::Vector3d z = Eigen::Vector3d::Zero();
  vb.add(1.0, kDt, Eigen::Vector3d(NAN, 0, 0), z);
  vb.add(1.0, 0.0, z, z);
  vb.add(1.0, 2.0, z, z);
  vb.add(NAN, kDt, z, z);
  EXPECT_EQ(vb.frames(), 0u);
  vb.add(2.0, kDt, z, z);
  vb.add(1.5, kDt, z, z);  // behind the last
  EXPECT_EQ(vb.frames(), 1u);
  for (int f = 1; f <= 200; ++f) vb.add(2.0 + f * kDt, kDt, z, z);
  EXPECT_LE(vb.frames(), 61u);
  EXPECT_FALSE(vb.estimate(Eigen::Matrix3d::Constant(NAN)));
}

// The IMU side: a bias from the video replaces the fixed one, and what the
// old one put into the orientation is taken out where it is given (the
// orientations before stay); never a still stretch's.
TEST(ImuOrientation, VideoBiasReplacesAFixedBiasNotAStillOne) {
  ImuOptions o;
  o.still_needs_video = false;
  ImuOrientation imu(o);
  const Eigen::Vector3d bias(0.01, 0, 0);
  // 2 s turning at 0.2 rad/s about z, the gyro reading 0.01 rad/s too much about x.
  auto turn = [&](ImuOrientation* into) {
    for (int i = 0; i <= 400; ++i) {
      ImuSample s;
      s.stamp = i * 0.005;
      s.gyro = Eigen::Vector3d(0, 0, 0.2) + bias;
      s.accel = Eigen::Vector3d(0, 0, 9.81);
      ASSERT_TRUE(into->add(s));
    }
  };
  turn(&imu);
  Eigen::Matrix3d A, B;
  // The error of the turn from 0 to 2 s, deg.
  auto drift = [&](const ImuOrientation& of) {
    EXPECT_TRUE(of.atImuStamp(0.0, &A));
    EXPECT_TRUE(of.atImuStamp(2.0, &B));
    const Eigen::Matrix3d truth = quaternionExp(Eigen::Vector3d(0, 0, 0.4)).toRotationMatrix();
    return Eigen::AngleAxisd(truth.transpose() * A.transpose() * B).angle() * kDeg;
  };
  EXPECT_GT(drift(imu), 1.0);  // 0.02 rad
  EXPECT_FALSE(imu.setVideoGyroBias(Eigen::Vector3d(NAN, 0, 0), 0.0, 2.0));
  ASSERT_TRUE(imu.setVideoGyroBias(bias, 0.0, 2.0));
  EXPECT_EQ(imu.biasSource(), ImuOrientation::BiasSource::kVideo);
  EXPECT_LT(drift(imu), 1e-6);  // taken out at 2 s
  // Before that stamp the orientations are as they were: at 1 s, 0.01 rad off.
  Eigen::Matrix3d M;
  ASSERT_TRUE(imu.atImuStamp(1.0, &M));
  const Eigen::Matrix3d at1 = quaternionExp(Eigen::Vector3d(0, 0, 0.2)).toRotationMatrix();
  EXPECT_NEAR(Eigen::AngleAxisd(at1.transpose() * A.transpose() * M).angle(), 0.01, 1e-3);
  // Given at a stamp before every sample: every sample takes it.
  ImuOrientation early(o);
  turn(&early);
  ASSERT_TRUE(early.setVideoGyroBias(bias, -1.0, -1.0));
  EXPECT_LT(drift(early), 1e-6);
  // A still second: the gyro's own mean takes over, and the video's is refused.
  for (int i = 1; i <= 300; ++i) {
    ImuSample s;
    s.stamp = 2.0 + i * 0.005;
    s.gyro = bias;
    s.accel = Eigen::Vector3d(0, 0, 9.81);
    ASSERT_TRUE(imu.add(s));
  }
  ASSERT_EQ(imu.biasSource(), ImuOrientation::BiasSource::kStill);
  EXPECT_FALSE(imu.setVideoGyroBias(Eigen::Vector3d::Zero(), 0.0, 2.0));
  EXPECT_NEAR((imu.gyroBias() - bias).norm(), 0, 1e-9);
  // Off with estimate_gyro_bias.
  o.estimate_gyro_bias = false;
  ImuOrientation fixed(o);
  EXPECT_FALSE(fixed.setVideoGyroBias(bias, 0.0, 2.0));
}

}  // namespace
}  // namespace imt
