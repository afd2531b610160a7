// Tests of ImuOrientation (issue 6: the IMU side of the calibration-free
// anchors) on generator IMU streams with exact truth and on real EuRoC data.
#include "instant_motion_tracking/core/anchor/imu_orientation.h"
#include "instant_motion_tracking/core/anchor/video_gyro_bias.h"
#include "instant_motion_tracking/sim/scene.h"

#include "shared_data.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <random>
#include <sstream>

namespace imt {
namespace {

constexpr double kDeg = 180.0 / M_PI;

SceneOptions preset(const std::string& name) {
  std::optional<SceneOptions> o = SceneOptions::fromPreset(name);
  EXPECT_TRUE(o.has_value()) << name;
  SceneOptions r = o ? *o : SceneOptions();
  for (ScenePlane& p : r.planes) p.flat = true;  // no textures needed
  return r;
}

std::unique_ptr<SceneGenerator> make(const SceneOptions& o) {
  std::string err;
  auto scene = SceneGenerator::create(o, &err);
  EXPECT_TRUE(scene != nullptr) << err;
  return scene;
}

double angleDeg(const Eigen::Matrix3d& A, const Eigen::Matrix3d& B) {
  return Eigen::AngleAxisd(A.transpose() * B).angle() * kDeg;
}

double angleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * kDeg;
}

Eigen::Matrix3d yawRotation(double psi) {
  return Eigen::AngleAxisd(psi, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

// Yaw of the rotation D (about world z) that best aligns: R_est ~ D R_true.
double yawOffset(const Eigen::Matrix3d& R_est, const Eigen::Matrix3d& R_true) {
  const Eigen::Matrix3d D = R_est * R_true.transpose();
  return std::atan2(D(1, 0) - D(0, 1), D(0, 0) + D(1, 1));
}

size_t feed(ImuOrientation& imu, const std::vector<ImuSample>& samples) {
  size_t accepted = 0;
  std::string why;
  for (const ImuSample& s : samples) accepted += imu.add(s, &why) ? 1 : 0;
  return accepted;
}

struct Errors {
  double relative = 0;  // worst |R_cam1_cam2 - truth|, deg, stamps 5 s apart
  double absolute = 0;  // worst |R_world_cam - truth| after removing the initial yaw, deg
  double up = 0;        // worst angle of upInCamera to the truth, deg
};

// Compares the orientation with the scene's truth at every frame stamp from
// `from` s of scene time on; `shift` is added to scene time to get stamps.
Errors compare(const ImuOrientation& imu, const SceneGenerator& scene, double from = 0,
               double shift = 0) {
  const SceneOptions& o = scene.options();
  auto truth = [&](double t) { return Eigen::Matrix3d(scene.T_world_cam(t).linear()); };
  Errors e;
  bool have_yaw = false;
  double psi = 0;
  for (int i = 0; i < scene.frameCount(); ++i) {
    const double t = i / o.fps;
    if (t < from) continue;
    const double stamp = scene.frameStamp(i) + shift;
    Eigen::Matrix3d R;
    EXPECT_TRUE(imu.R_world_cam(stamp, &R)) << stamp;
    if (!have_yaw) {
      psi = yawOffset(R, truth(t));
      have_yaw = true;
    }
    e.absolute = std::max(e.absolute, angleDeg(R, yawRotation(psi) * truth(t)));
    e.up = std::max(e.up, angleDeg(imu.upInCamera(stamp),
                                   Eigen::Vector3d(truth(t).transpose() * Eigen::Vector3d::UnitZ())));
    if (t + 5.0 <= o.duration) {
      Eigen::Matrix3d R12;
      EXPECT_TRUE(imu.R_cam1_cam2(stamp, stamp + 5.0, &R12));
      e.relative = std::max(e.relative, angleDeg(R12, truth(t).transpose() * truth(t + 5.0)));
    }
  }
  return e;
}

// The IMU alone, without a camera: stillness is the IMU's to judge
// (still_needs_video off; the anchors' tests give it the video).
ImuOptions wholeScene() {
  ImuOptions opt;
  opt.window_seconds = 30;  // keep every sample of the scene for the comparison
  opt.still_needs_video = false;
  return opt;
}

TEST(ImuOrientation, OptionsVisitAndValidate) {
  ImuOptions o;
  EXPECT_EQ(o.validate(), "");
  int fields = 0;
  auto count = [&](const char* name, auto& field, const char* doc) {
    (void)field;
    EXPECT_TRUE(name && *name && doc && *doc);
    ++fields;
  };
  o.visit(count);
  EXPECT_EQ(fields, 20);
  ImuOptions b = o;
  b.still_seconds = 0;
  EXPECT_NE(b.validate().find("imu.still_seconds"), std::string::npos) << b.validate();
  b = o;
  b.gyro_bias_y = std::nan("");
  EXPECT_NE(b.validate().find("imu.gyro_bias_y"), std::string::npos) << b.validate();
  b = o;
  b.max_gap_seconds = 0;
  EXPECT_NE(b.validate().find("imu.max_gap_seconds"), std::string::npos) << b.validate();
  b = o;
  b.window_seconds = -1;
  EXPECT_NE(b.validate(), "");
  // Invalid options are refused at construction, never swapped for defaults.
  EXPECT_THROW(ImuOrientation imu(b), std::invalid_argument);
}

TEST(ImuOrientation, GyroIntegrationReproducesTheCameraRotation) {
  for (const std::string name : {"floor_walk", "rotate"}) {
    SceneOptions so = preset(name);
    so.duration = 10;
    auto scene = make(so);
    ASSERT_TRUE(scene);
    const std::vector<ImuSample> samples = scene->imuSamples();
    for (const bool fused : {false, true}) {
      ImuOptions opt = wholeScene();
      opt.use_fused_orientation = fused;
      ImuOrientation imu(opt);
      ASSERT_TRUE(imu.setRotationCamImu(so.q_cam_imu));
      ASSERT_EQ(feed(imu, samples), samples.size());
      const Errors e = compare(imu, *scene);
      std::printf("[ info ] %s%s: relative (5 s) %.4f deg, absolute up to yaw %.4f deg, up %.4f deg, bias "
                  "%s (%.2g rad/s)\n",
                  name.c_str(), fused ? " fused" : "", e.relative, e.absolute, e.up,
                  imu.biasEstimated() ? "estimated" : "fixed", imu.gyroBias().norm());
      // Gyro noise 5e-4 rad/s per sample at 200 Hz is an angle random walk of
      // 5e-4 / 200 * sqrt(2000) = 1.1e-4 rad = 0.006 deg (1 sigma per axis)
      // over 10 s; midpoint integration and slerp between samples add
      // < 0.005 deg on these smooth curves. Measured <= 0.02 deg: bound 0.05.
      EXPECT_LT(e.relative, 0.05) << name;
      // Absolute (up to the initial yaw): also the initial level from one
      // accelerometer reading, accel noise 0.01 m/s^2 -> 0.06 deg (the walk
      // starts with no acceleration). Measured 0.06 deg on both.
      EXPECT_LT(e.absolute, 0.15) << name;
      EXPECT_LT(e.up, 0.5) << name;  // the bound for the gravity direction
      if (fused) {
        EXPECT_LT(e.absolute, 0.01) << name;  // exact samples, slerp only
      }
    }
  }
}

// The rotate scene with a constant gyro bias, preceded by `still_s` seconds
// at rest in its initial orientation (same bias and noise): the bias must be
// estimated from the still prefix.
std::vector<ImuSample> stillThenRotate(const SceneGenerator& scene, double still_s) {
  const SceneOptions& o = scene.options();
  std::vector<ImuSample> rot = scene.imuSamples();
  std::mt19937 rng(5);
  std::normal_distribution<double> gyro_n(0, o.gyro_noise), accel_n(0, o.accel_noise);
  std::vector<ImuSample> out;
  const int n = static_cast<int>(std::lround(still_s * o.imu_rate));
  for (int k = 0; k < n; ++k) {
    ImuSample s = rot.front();
    s.stamp = o.start_time + k / o.imu_rate;
    s.gyro = o.gyro_bias + Eigen::Vector3d(gyro_n(rng), gyro_n(rng), gyro_n(rng));
    s.accel = s.orientation.conjugate() * Eigen::Vector3d(0, 0, 9.81) +
              Eigen::Vector3d(accel_n(rng), accel_n(rng), accel_n(rng));
    out.push_back(s);
  }
  for (ImuSample s : rot) {
    s.stamp += still_s;
    out.push_back(s);
  }
  return out;
}

TEST(ImuOrientation, GyroBiasFromStillStretchAndFromParameter) {
  SceneOptions so = preset("rotate");
  so.duration = 10;
  so.gyro_bias = Eigen::Vector3d(0.01, -0.02, 0.015);  // rad/s, a typical MEMS turn-on bias
  auto scene = make(so);
  ASSERT_TRUE(scene);

  // 1. The `still` preset: the estimate is the mean of ~2000 readings.
  {
    SceneOptions st = preset("still");
    st.gyro_bias = so.gyro_bias;
    auto still = make(st);
    ASSERT_TRUE(still);
    ImuOrientation imu(wholeScene());
    feed(imu, still->imuSamples());
    ASSERT_TRUE(imu.biasEstimated());
    // 5e-4 rad/s noise / sqrt(2000) = 1.1e-5 rad/s per axis; bound 10 sigma.
    EXPECT_LT((imu.gyroBias() - so.gyro_bias).norm(), 1e-4) << imu.gyroBias().transpose();
  }

  // 2. A still second, then rotation: estimated, the still second re-integrated.
  const double still_s = 1.5;
  const std::vector<ImuSample> samples = stillThenRotate(*scene, still_s);
  {
    ImuOrientation imu(wholeScene());
    ASSERT_TRUE(imu.setRotationCamImu(so.q_cam_imu));
    ASSERT_EQ(feed(imu, samples), samples.size());
    ASSERT_TRUE(imu.biasEstimated());
    const double bias_err = (imu.gyroBias() - so.gyro_bias).norm();
    const Errors e = compare(imu, *scene, 0, still_s);
    std::printf("[ info ] still + rotate, estimated bias: error %.2g rad/s, relative %.4f deg, "
                "absolute %.4f deg, up %.4f deg\n",
                bias_err, e.relative, e.absolute, e.up);
    // 300 still readings: 5e-4 / sqrt(300) = 2.9e-5 rad/s per axis, unless the
    // stretch wrongly continued into the slow start of the rotation.
    EXPECT_LT(bias_err, 2e-4);
    // 2e-4 rad/s over 5 s = 0.06 deg, plus the unbiased figures above.
    EXPECT_LT(e.relative, 0.1);
    EXPECT_LT(e.absolute, 0.15);
    EXPECT_LT(e.up, 0.5);
  }
  // 3. The fixed parameter, no estimate: as good as an unbiased gyro.
  {
    ImuOptions opt = wholeScene();
    opt.estimate_gyro_bias = false;
    opt.gyro_bias_x = so.gyro_bias.x();
    opt.gyro_bias_y = so.gyro_bias.y();
    opt.gyro_bias_z = so.gyro_bias.z();
    ImuOrientation imu(opt);
    ASSERT_TRUE(imu.setRotationCamImu(so.q_cam_imu));
    feed(imu, scene->imuSamples());
    EXPECT_FALSE(imu.biasEstimated());
    const Errors e = compare(imu, *scene);
    std::printf("[ info ] rotate, fixed bias: relative %.4f deg, absolute %.4f deg\n", e.relative,
                e.absolute);
    EXPECT_LT(e.relative, 0.05);  // as in GyroIntegrationReproducesTheCameraRotation
    EXPECT_LT(e.absolute, 0.1);
  }
  // 4. Control: neither -> the bias (0.027 rad/s) drifts 7.7 deg in 5 s.
  {
    ImuOptions opt = wholeScene();
    opt.estimate_gyro_bias = false;
    ImuOrientation imu(opt);
    ASSERT_TRUE(imu.setRotationCamImu(so.q_cam_imu));
    feed(imu, scene->imuSamples());
    const Errors e = compare(imu, *scene);
    std::printf("[ info ] rotate, bias ignored: relative %.3f deg\n", e.relative);
    EXPECT_GT(e.relative, 5.0);
  }
}

// A 0.5 s hole in the stream of the rotate scene (the camera turning all the
// while): no orientation inside it, roll and pitch right again after it (the
// first accelerometer reading levels it), and the gyro integration fine from
// there on; before the gap nothing changes.
TEST(ImuOrientation, GapsAreNotIntegratedAcrossAndReLevelAfter) {
  SceneOptions so = preset("rotate");
  so.duration = 8;
  auto scene = make(so);
  ASSERT_TRUE(scene);
  const double gap_begin = so.start_time + 3.0, gap_end = so.start_time + 3.5;
  std::vector<ImuSample> samples;
  for (const ImuSample& s : scene->imuSamples())
    if (s.stamp < gap_begin || s.stamp >= gap_end) samples.push_back(s);
  ImuOrientation imu(wholeScene());
  ASSERT_TRUE(imu.setRotationCamImu(so.q_cam_imu));
  ASSERT_EQ(feed(imu, samples), samples.size());
  EXPECT_EQ(imu.gaps(), 1u);
  EXPECT_NEAR(imu.lastGapSeconds(), 0.5, 0.01);
  auto truth = [&](double stamp) { return Eigen::Matrix3d(scene->T_world_cam(stamp - so.start_time).linear()); };
  Eigen::Matrix3d R, R12;
  EXPECT_FALSE(imu.R_world_cam(gap_begin + 0.2, &R));
  EXPECT_FALSE(imu.R_cam1_cam2(gap_begin - 0.5, gap_begin + 0.2, &R12));
  EXPECT_FALSE(imu.rotationHomography(Eigen::Matrix3d::Identity(), gap_begin - 0.1, gap_end + 0.1, &R12));
  double up_before = 0, up_after = 0, relative_after = 0;
  for (double t = so.start_time + 0.5; t < so.start_time + so.duration - 1.0; t += 0.1) {
    if (t > gap_begin - 0.01 && t < gap_end) continue;
    const double up = angleDeg(imu.upInCamera(t), Eigen::Vector3d(truth(t).transpose() * Eigen::Vector3d::UnitZ()));
    (t < gap_begin ? up_before : up_after) = std::max(t < gap_begin ? up_before : up_after, up);
    if (t >= gap_end) {
      ASSERT_TRUE(imu.R_cam1_cam2(t, t + 1.0, &R12)) << t;
      relative_after = std::max(relative_after, angleDeg(R12, truth(t).transpose() * truth(t + 1.0)));
    }
  }
  std::printf("[ info ] gap of 0.5 s: up %.3f deg before, %.3f deg after; relative (1 s) after %.4f deg\n",
              up_before, up_after, relative_after);
  // Before: the integration's own figures (<= 0.5 deg, the gravity
  // bound). After: one accelerometer reading (noise 0.01 m/s^2 -> ~0.06 deg)
  // re-levels it (measured 0.12 deg); carried over without re-levelling,
  // the 0.5 s of unseen turning tilts "up" by 5.5 deg. The relative rotation is the gyro's again (< 0.05 deg).
  EXPECT_LT(up_before, 0.5);
  EXPECT_LT(up_after, 0.5);
  EXPECT_LT(relative_after, 0.05);
}

TEST(ImuOrientation, BadSamplesAreDroppedWithAReason) {
  SceneOptions so = preset("rotate");
  so.duration = 2;
  auto scene = make(so);
  ASSERT_TRUE(scene);
  std::vector<ImuSample> samples = scene->imuSamples();
  ImuOrientation imu(wholeScene());
  std::string why;
  ImuSample zero = samples[0];
  zero.accel.setZero();
  EXPECT_FALSE(imu.add(zero, &why));  // cannot level the first orientation
  EXPECT_NE(why.find("accelerometer"), std::string::npos) << why;
  ASSERT_EQ(feed(imu, std::vector<ImuSample>(samples.begin(), samples.begin() + 100)), 100u);

  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  ImuSample s = samples[100];
  s.gyro.y() = nan;
  why.clear();
  EXPECT_FALSE(imu.add(s, &why));
  EXPECT_NE(why.find("gyro"), std::string::npos) << why;
  s = samples[100];
  s.accel.z() = inf;
  why.clear();
  EXPECT_FALSE(imu.add(s, &why));
  EXPECT_NE(why.find("accel"), std::string::npos) << why;
  // Finite but beyond any sensor (issue 16: an accelerometer reading of
  // 1e300 tilted the anchors' "up" by 88 deg, a gyro of 1e30 turned them 7
  // deg, both silently): dropped with the bound named.
  s = samples[100];
  s.accel.x() = 1e300;
  why.clear();
  EXPECT_FALSE(imu.add(s, &why));
  EXPECT_NE(why.find("imu.max_accel"), std::string::npos) << why;
  s = samples[100];
  s.gyro.z() = 1e30;
  why.clear();
  EXPECT_FALSE(imu.add(s, &why));
  EXPECT_NE(why.find("imu.max_gyro"), std::string::npos) << why;
  s = samples[100];
  s.gyro.z() = 30.0;  // 1700 deg/s: a fast spin, in range
  ImuOrientation spin(wholeScene());
  EXPECT_TRUE(spin.add(s, &why)) << why;
  s = samples[100];
  s.stamp = nan;
  why.clear();
  EXPECT_FALSE(imu.add(s, &why));
  EXPECT_NE(why.find("stamp"), std::string::npos) << why;
  s = samples[50];  // time going backwards
  why.clear();
  EXPECT_FALSE(imu.add(s, &why));
  EXPECT_NE(why.find("not after"), std::string::npos) << why;
  s = samples[99];  // repeated stamp
  why.clear();
  EXPECT_FALSE(imu.add(s, &why));
  EXPECT_NE(why.find("not after"), std::string::npos) << why;
  EXPECT_FALSE(imu.add(s));  // no reason requested: no crash
  EXPECT_EQ(imu.size(), 100u);
  // A broken fused orientation only matters when it is used.
  s = samples[100];
  s.orientation.coeffs() << nan, 0, 0, 1;
  EXPECT_TRUE(imu.add(s, &why));
  ImuOptions fo = wholeScene();
  fo.use_fused_orientation = true;
  ImuOrientation fused(fo);
  s.stamp = samples[0].stamp;
  why.clear();
  EXPECT_FALSE(fused.add(s, &why));
  EXPECT_NE(why.find("orientation"), std::string::npos) << why;
  // Bad rotations are refused.
  EXPECT_FALSE(imu.setRotationCamImu(Eigen::Quaterniond(0, 0, 0, 0)));
  EXPECT_FALSE(imu.setRotationCamImu(Eigen::Quaterniond(nan, 0, 0, 1)));
  // Queries at NaN stamps fail; the stream continues normally.
  EXPECT_FALSE(imu.R_world_cam(nan, nullptr));
  EXPECT_EQ(imu.upInCamera(nan), Eigen::Vector3d::Zero());
  EXPECT_EQ(feed(imu, std::vector<ImuSample>(samples.begin() + 101, samples.end())),
            samples.size() - 101);
  EXPECT_EQ(imu.size(), samples.size());
}

// Issue 14: a slow smooth turn about gravity (0.05 rad/s, 2.9 deg/s: under
// still_gyro_max, the accelerometer steady) feels still to the IMU, which
// then takes the turning rate for the bias. With the video's turns reported
// (still_needs_video, the default) only a stretch the video saw still counts.
TEST(ImuOrientation, StillnessNeedsTheVideosAgreement) {
  const Eigen::Vector3d bias(0.004, -0.003, 0.002);  // rad/s
  const double rate = 200, fps = 30, seconds = 4;
  // The IMU's samples and the video's frames (camera = IMU axes) turning at
  // `turn` rad/s about z; `known`: the video could read each frame's turn.
  auto run = [&](double turn, bool needs_video, bool known, double video_lag) {
    ImuOptions o;
    o.still_needs_video = needs_video;
    ImuOrientation imu(o);
    std::mt19937 rng(3);
    std::normal_distribution<double> gyro_n(0, 0.0005), angle_n(0, 2e-4);  // rad/s; rad per frame
    int frame = 1;
    for (int k = 0; k <= seconds * rate; ++k) {
      ImuSample s;
      s.stamp = 10 + k / rate;
      s.gyro = Eigen::Vector3d(0, 0, turn) + bias + Eigen::Vector3d(gyro_n(rng), gyro_n(rng), gyro_n(rng));
      s.accel = Eigen::Vector3d(0, 0, 9.81);
      EXPECT_TRUE(imu.add(s));
      // The frames up to the IMU's stamp less the video's lag.
      for (; 10 + frame / fps <= s.stamp - video_lag; ++frame) {
        const Eigen::Vector3d theta(angle_n(rng), angle_n(rng), turn / fps + angle_n(rng));
        imu.addVideoTurn(10 + (frame - 1) / fps, 10 + frame / fps, theta, known);
      }
    }
    return imu;
  };
  // The IMU alone takes the turn for the bias.
  const ImuOrientation alone = run(0.05, false, true, 0);
  ASSERT_TRUE(alone.biasEstimated());
  EXPECT_NEAR(alone.gyroBias().z(), bias.z() + 0.05, 1e-3);
  // With the video: no bias from it.
  EXPECT_FALSE(run(0.05, true, true, 0).biasEstimated());
  // Still, and the video agrees (lagging the IMU by 0.1 s, as a live camera
  // does): the bias, to the gyro's noise (5e-4 rad/s per sample over >= 200
  // samples: 3.5e-5 per axis; bound ~10 sigma).
  const ImuOrientation still = run(0, true, true, 0.1);
  ASSERT_TRUE(still.biasEstimated());
  EXPECT_LT((still.gyroBias() - bias).norm(), 3e-4) << still.gyroBias().transpose();
  // Still, but the video cannot read its frames (no camera model): no bias.
  EXPECT_FALSE(run(0, true, false, 0).biasEstimated());
  // A turn slow enough that single frames look still (0.006 rad/s, under 4x
  // still_video_rate per frame) is caught by the frames' sum.
  EXPECT_FALSE(run(0.006, true, true, 0).biasEstimated());
}

TEST(ImuOrientation, WindowIsBoundedAndQueriesOutsideItFail) {
  SceneOptions so = preset("rotate");
  so.duration = 10;
  auto scene = make(so);
  ASSERT_TRUE(scene);
  const std::vector<ImuSample> samples = scene->imuSamples();
  ImuOptions opt;
  opt.window_seconds = 2.0;
  ImuOrientation imu(opt);
  Eigen::Matrix3d R;
  EXPECT_FALSE(imu.R_world_cam(samples[0].stamp, &R));  // empty
  EXPECT_EQ(imu.upInCamera(samples[0].stamp), Eigen::Vector3d::Zero());
  size_t most = 0;
  for (const ImuSample& s : samples) {
    ASSERT_TRUE(imu.add(s));
    most = std::max(most, imu.size());
  }
  EXPECT_LE(most, static_cast<size_t>(2.0 * so.imu_rate) + 2);  // 2 s at 200 Hz (+ the bracket)
  const double newest = samples.back().stamp;
  EXPECT_DOUBLE_EQ(imu.newestStamp(), newest);
  EXPECT_LE(imu.oldestStamp(), newest - 2.0);
  EXPECT_TRUE(imu.R_world_cam(newest, &R));
  EXPECT_TRUE(imu.R_world_cam(newest - 2.0, &R));
  EXPECT_TRUE(imu.R_world_cam(newest - 1.234567, &R));
  EXPECT_FALSE(imu.R_world_cam(newest + 1e-6, &R));  // the future
  EXPECT_FALSE(imu.R_world_cam(newest - 2.1, &R));   // forgotten
  EXPECT_FALSE(imu.R_cam1_cam2(newest - 3, newest, &R));
  EXPECT_EQ(imu.upInCamera(newest - 5), Eigen::Vector3d::Zero());
  EXPECT_NEAR(imu.upInCamera(newest - 1).norm(), 1.0, 1e-12);
  imu.reset();
  EXPECT_TRUE(imu.empty());
  EXPECT_FALSE(imu.R_world_cam(newest, &R));
}

// Rotation-only homography vs the generator's background homography on the
// rotate scene (pure rotation: exactly K R K^-1).
TEST(ImuOrientation, RotationHomographyPredictsPixels) {
  SceneOptions so = preset("rotate");
  so.duration = 4;
  auto scene = make(so);
  ASSERT_TRUE(scene);
  ImuOrientation imu(wholeScene());
  ASSERT_TRUE(imu.setRotationCamImu(so.q_cam_imu));
  feed(imu, scene->imuSamples());
  const Eigen::Matrix3d K = scene->intrinsics().K();
  double worst = 0;
  for (int i = 0; i + 15 < scene->frameCount(); i += 7) {
    const int j = i + 15;  // half a second apart
    Eigen::Matrix3d H;
    ASSERT_TRUE(imu.rotationHomography(K, scene->frameStamp(i), scene->frameStamp(j), &H));
    const std::optional<Eigen::Matrix3d> Ht = scene->backgroundHomography(i, j);
    ASSERT_TRUE(Ht.has_value());
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(640, 0, 1),
                                    Eigen::Vector3d(640, 480, 1), Eigen::Vector3d(320, 240, 1)}) {
      const Eigen::Vector3d a = H * p, b = *Ht * p;
      worst = std::max(worst, (a.hnormalized() - b.hnormalized()).norm());
    }
  }
  std::printf("[ info ] rotate: rotation homography vs truth, worst corner %.4f px\n", worst);
  // fx = 554 px: 0.01 deg of rotation error is ~0.1 px (more at the corners).
  EXPECT_LT(worst, 0.3);
}

// --- EuRoC V1_01 (real ADIS16448 gyro, Vicon ground truth) ---

struct Pose {
  double t;
  Eigen::Quaterniond q;  // R_world_imu (the GT is the IMU/body pose)
};

// The whole V1_01 IMU stream and its ground truth; false (the test skips)
// when ../shared is absent.
bool loadEuroc(std::vector<ImuSample>* samples, std::vector<Pose>* gt, std::string* why) {
  const std::string dir = test::sharedDataDir() + "/euroc_v1_01_excerpt";
  std::ifstream imu_file(dir + "/mav0/imu0/data.csv"), gt_file(dir + "/groundtruth/V101_gt_tum.txt");
  if (!test::pathExists(dir) || !imu_file || !gt_file) {
    *why = "EuRoC files not found in " + dir;
    return false;
  }
  std::string line;
  while (std::getline(imu_file, line)) {
    if (line.empty() || line[0] == '#') continue;
    long long ns = 0;
    double v[6];
    if (std::sscanf(line.c_str(), "%lld,%lf,%lf,%lf,%lf,%lf,%lf", &ns, &v[0], &v[1], &v[2], &v[3],
                    &v[4], &v[5]) != 7)
      continue;
    ImuSample s;
    s.stamp = static_cast<double>(ns / 1000000000LL) + static_cast<double>(ns % 1000000000LL) * 1e-9;
    s.gyro = Eigen::Vector3d(v[0], v[1], v[2]);
    s.accel = Eigen::Vector3d(v[3], v[4], v[5]);
    samples->push_back(s);
  }
  while (std::getline(gt_file, line)) {
    if (line.empty() || line[0] == '#') continue;
    double t, x, y, z, qx, qy, qz, qw;
    if (std::sscanf(line.c_str(), "%lf %lf %lf %lf %lf %lf %lf %lf", &t, &x, &y, &z, &qx, &qy, &qz,
                    &qw) != 8)
      continue;
    gt->push_back({t, Eigen::Quaterniond(qw, qx, qy, qz).normalized()});
  }
  return true;
}

// 5-s windows starting every 0.5 s: mean and worst angle between the
// integrated and the GT relative rotation (R_cam_imu = identity: "camera" =
// IMU = body frame, in which the GT is given).
struct WindowErrors {
  double mean = 0, worst = 0, most_rotation = 0;
  int windows = 0;
};
WindowErrors fiveSecondWindows(const ImuOrientation& imu, const std::vector<Pose>& gt) {
  WindowErrors r;
  size_t j = 0;
  for (size_t i = 0; i < gt.size(); i += 10) {
    while (j < gt.size() && gt[j].t < gt[i].t + 5.0 - 1e-3) ++j;
    if (j >= gt.size()) break;
    Eigen::Matrix3d R12;
    if (!imu.R_cam1_cam2(gt[i].t, gt[j].t, &R12)) continue;
    const Eigen::Matrix3d R12_gt = (gt[i].q.conjugate() * gt[j].q).toRotationMatrix();
    const double err = angleDeg(R12, R12_gt);
    r.worst = std::max(r.worst, err);
    r.most_rotation = std::max(r.most_rotation, Eigen::AngleAxisd(R12_gt).angle() * kDeg);
    r.mean += err;
    ++r.windows;
  }
  if (r.windows > 0) r.mean /= r.windows;
  return r;
}

// The README's bias, fitted with the official GT in flight (rad/s, IMU frame).
const Eigen::Vector3d kEurocReadmeBias(-0.0022, 0.0207, 0.0764);

// An orientation over the whole sequence with the bias fixed at `bias`.
ImuOptions fixedBias(const Eigen::Vector3d& bias) {
  ImuOptions o;
  o.window_seconds = 200;  // the whole sequence, for the comparison
  o.estimate_gyro_bias = false;
  o.gyro_bias_x = bias.x();
  o.gyro_bias_y = bias.y();
  o.gyro_bias_z = bias.z();
  return o;
}

TEST(ImuOrientation, EurocGyroMatchesGroundTruthOver5sWindows) {
  std::vector<ImuSample> samples;
  std::vector<Pose> gt;
  std::string why;
  if (!loadEuroc(&samples, &gt, &why)) GTEST_SKIP() << why;
  ASSERT_GT(samples.size(), 20000u);
  ASSERT_GT(gt.size(), 2000u);
  using Result = WindowErrors;
  auto evaluate = [&](const ImuOrientation& imu) { return fiveSecondWindows(imu, gt); };
  const Eigen::Vector3d& readme_bias = kEurocReadmeBias;

  // 1. The fixed bias from the README.
  ImuOrientation imu_fixed(fixedBias(readme_bias));
  ASSERT_EQ(feed(imu_fixed, samples), samples.size());
  const Result rf = evaluate(imu_fixed);
  ASSERT_GT(rf.windows, 200);
  std::printf("[ info ] EuRoC, README bias: %d 5-s windows (up to %.0f deg of rotation): relative "
              "error mean %.3f deg, worst %.3f deg\n",
              rf.windows, rf.most_rotation, rf.mean, rf.worst);
  // Gyro noise density 1.7e-4 rad/s/sqrt(Hz): 0.002 deg of random walk in
  // 5 s; what remains is the ADIS16448's scale factor and axis misalignment
  // on up to 135 deg of rotation, bias drift and Vicon noise. The README's
  // check reached 0.57 deg on three windows; the bound is 1 deg.
  // Measured 0.36 mean, 0.85 worst.
  EXPECT_LT(rf.worst, 1.0);
  EXPECT_LT(rf.mean, 0.5);

  // 2. Calibration-free: the bias estimated while the MAV rests on the ground
  // (first ~5 s, rotors vibrating: +-1 m/s^2, +-0.3 rad/s per sample).
  ImuOptions est;
  est.window_seconds = 200;
  est.still_needs_video = false;  // the IMU alone (EuRoC's cameras are not used here)
  ImuOrientation imu(est);
  ASSERT_EQ(feed(imu, samples), samples.size());
  ASSERT_TRUE(imu.biasEstimated());
  const Result re = evaluate(imu);
  std::printf("[ info ] EuRoC, still-estimated bias %.4f %.4f %.4f rad/s (README %.4f %.4f %.4f): "
              "relative error mean %.3f deg, worst %.3f deg\n",
              imu.gyroBias().x(), imu.gyroBias().y(), imu.gyroBias().z(), readme_bias.x(),
              readme_bias.y(), readme_bias.z(), re.mean, re.worst);
  // The bias on the ground differs from the in-flight fit by 0.0016 rad/s
  // about z (the ground readings average 0.078 over each of the first 5 s):
  // 0.46 deg more over 5 s in the worst windows. Later hovers and the slow
  // landing must not replace it (they did before still_gyro_tight /
  // still_replace_seconds: 17 deg). Measured 0.54 mean, 1.26 worst.
  EXPECT_LT((imu.gyroBias() - readme_bias).norm(), 0.003);
  EXPECT_LT(re.worst, 1.5);
  EXPECT_LT(re.mean, 0.7);

  // Gravity from the still start vs the GT (Vicon world z is up).
  const double t_up = gt[40].t;  // 2 s in, at rest
  Eigen::Matrix3d R_gt = gt[40].q.toRotationMatrix();
  const double up_err =
      angleDeg(imu.upInCamera(t_up), Eigen::Vector3d(R_gt.transpose() * Eigen::Vector3d::UnitZ()));
  std::printf("[ info ] EuRoC: up at rest vs GT %.3f deg\n", up_err);
  // Accelerometer bias/misalignment of the IMU vs Vicon's body frame, and the
  // Vicon world's own tilt: a fraction of a degree.
  EXPECT_LT(up_err, 1.0);
}

// The gyro bias while flying (VideoGyroBias), with the video's turns
// replaced by the Vicon's: the real gyro's turn over each GT interval (20
// Hz) against the GT's turn over it, from 8 s in (the MAV flies from ~5 s).
// What this checks on real data is the fit itself (real gyro noise, scale
// factor and misalignment, bias drift and a real clock), not the video's
// reading of the turns.
TEST(ImuOrientation, EurocBiasFromTheTurnsWhileFlying) {
  std::vector<ImuSample> samples;
  std::vector<Pose> gt;
  std::string why;
  if (!loadEuroc(&samples, &gt, &why)) GTEST_SKIP() << why;
  ImuOrientation raw(fixedBias(Eigen::Vector3d::Zero()));  // the gyro's turns as read
  ASSERT_EQ(feed(raw, samples), samples.size());
  VideoGyroBias vb(30.0);
  std::vector<VideoGyroBias::Estimate> estimates;  // every 10 s from 30 s of flight on
  const double start = gt.front().t + 8.0;
  double next_fit = start + 30.0;
  for (size_t i = 0; i + 1 < gt.size(); ++i) {
    if (gt[i].t < start) continue;
    Eigen::Matrix3d R0, R1;
    if (!raw.atImuStamp(gt[i].t, &R0) || !raw.atImuStamp(gt[i + 1].t, &R1)) continue;
    vb.add(gt[i + 1].t, gt[i + 1].t - gt[i].t, rotationVector(R0.transpose() * R1),
           rotationVector((gt[i].q.conjugate() * gt[i + 1].q).toRotationMatrix()));
    if (gt[i + 1].t >= next_fit) {
      next_fit += 10.0;
      const auto e = vb.estimate(Eigen::Matrix3d::Identity());
      ASSERT_TRUE(e) << "at " << gt[i + 1].t - gt.front().t << " s";
      estimates.push_back(*e);
      std::printf("[ info ] EuRoC, %.0f s: bias from the turns %.4f %.4f %.4f rad/s (README %.4f %.4f %.4f), "
                  "off by %.4f rad/s, sigma %.4f, %d frames; the gyro late by %.1f +- %.1f ms\n",
                  gt[i + 1].t - gt.front().t, e->bias.x(), e->bias.y(), e->bias.z(), kEurocReadmeBias.x(),
                  kEurocReadmeBias.y(), kEurocReadmeBias.z(), (e->bias - kEurocReadmeBias).norm(), e->sigma.norm(),
                  e->frames, 1000 * e->lateness, 1000 * e->lateness_sigma);
    }
  }
  ASSERT_GE(estimates.size(), 8u);
  // Measured 0.0004-0.0009 rad/s off (0.02-0.05 deg/s) in every 30-s
  // window, the standard error 0.0001: the README's bias is itself one fit
  // over the whole flight, and the ADIS16448's bias wanders (random walk
  // 1.9e-5 rad/s^2/sqrt(Hz): 2e-4 rad/s over 100 s) and its scale factor
  // and axes are off by fractions of a percent on turns of up to 1 rad/s.
  // 0.0015 rad/s: 0.09 deg/s, a fifth of the bias a cheap IMU has.
  for (const VideoGyroBias::Estimate& e : estimates) {
    EXPECT_LT((e.bias - kEurocReadmeBias).cwiseAbs().maxCoeff(), 0.0015);
    // The GT is on the IMU's clock (README): measured 0.4-0.7 ms late.
    EXPECT_LT(std::abs(e.lateness), 0.002);
  }
  ImuOrientation with_bias(fixedBias(estimates.back().bias)), with_readme(fixedBias(kEurocReadmeBias));
  ASSERT_EQ(feed(with_bias, samples), samples.size());
  ASSERT_EQ(feed(with_readme, samples), samples.size());
  const WindowErrors with = fiveSecondWindows(with_bias, gt), readme = fiveSecondWindows(with_readme, gt);
  std::printf("[ info ] EuRoC, 5-s windows with the last bias from the turns: mean %.3f deg, worst %.3f deg "
              "(README bias: %.3f / %.3f)\n", with.mean, with.worst, readme.mean, readme.worst);
  // As good as the README's own bias: within 0.05 deg on the mean.
  ASSERT_GT(with.windows, 200);
  EXPECT_LT(with.mean, readme.mean + 0.05);
  EXPECT_LT(with.worst, 1.0);
}

}  // namespace
}  // namespace imt
