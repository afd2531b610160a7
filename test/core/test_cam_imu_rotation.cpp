// Tests of the IMU-to-camera rotation found from the video (issue 14):
// rotations read off camera-motion homographies, and the estimator that
// aligns them with the gyro's; and the fit from features' epipolar lines
// for a camera that travels as it turns.
#include "instant_motion_tracking/core/anchor/cam_imu_rotation.h"
#include "instant_motion_tracking/core/anchor/anchor_manager.h"
#include "instant_motion_tracking/core/anchor/epipolar_rotation.h"
#include "instant_motion_tracking/core/anchor/imu_orientation.h"
#include "instant_motion_tracking/core/anchor/time_offset.h"
#include "instant_motion_tracking/core/motion/motion_analysis.h"

#include "shared_data.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>
#include <sstream>

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
  // A camera 1 m over a floor (its normal along the camera's -y) moving 10 cm
  // along its axis: the floor's homography K (I + t n^T / d) K^-1 stretches
  // the image's lower part more than its upper, which no turn and zoom make
  // (the best turn moves it 3 px, what it leaves is 5 px). (Sideways over a
  // wall facing the camera would look like a pan: no homography tells those
  // apart.)
  const CameraModel k = camera(false);
  const Eigen::Vector3d t(0, 0, -0.1), n(0, -1, 0);
  const Eigen::Matrix3d H = k.K() * (Eigen::Matrix3d::Identity() + t * n.transpose() / 1.0) * k.K().inverse();
  Eigen::Matrix3d found;
  double rms = -1;
  ASSERT_TRUE(rotationFromHomography(k, H, &found, &rms));
  std::printf("floor, along the axis: rms %.2f px\n", rms);
  EXPECT_GT(rms, 4.0);
  CameraMotion m;
  m.model = MotionModel::kHomography;
  m.H = H;
  Eigen::Vector3d theta;
  EXPECT_FALSE(cameraTurn(k, m, &theta));
  // Unusable input: no answer.
  EXPECT_FALSE(rotationFromHomography(k, Eigen::Matrix3d::Constant(NAN), &found, &rms));
  EXPECT_FALSE(rotationFromHomography(CameraModel(), H, &found, &rms));
}

// A camera over a floor (normal along the camera's -y, 1 m below) turning
// and moving at once: the floor's homography K (R + t n^T / d) K^-1. Read
// with the floor's normal, the turn is exact whatever the walk; the
// turn-and-zoom fit takes part of the walk for a turn (issue 14: on the slow
// walk as large as the gyro bias being sought). A wrong normal says so in
// its rms.
TEST(RotationFromPlaneHomography, ReadsTheTurnOverTheFloorWhateverTheWalk) {
  const CameraModel k = camera(false);
  const Eigen::Vector3d n(0, -1, 0);
  const Eigen::Matrix3d R = quaternionExp(Eigen::Vector3d(0.004, -0.006, 0.003)).toRotationMatrix();
  for (const Eigen::Vector3d& t : {Eigen::Vector3d(0, 0, -0.05), Eigen::Vector3d(0.03, 0.01, -0.02)}) {
    const Eigen::Matrix3d H = k.K() * (R + t * n.transpose() / 1.0) * k.K().inverse();
    Eigen::Matrix3d plane, turn;
    double rms_plane = -1, rms_turn = -1;
    ASSERT_TRUE(rotationFromPlaneHomography(k, H, -n, &plane, &rms_plane));  // either sign of the normal
    ASSERT_TRUE(rotationFromHomography(k, H, &turn, &rms_turn));
    std::printf("floor walk t (%.2f %.2f %.2f): plane turn off by %.5f deg (rms %.4f px), turn-and-zoom by %.3f deg "
                "(rms %.2f px)\n",
                t.x(), t.y(), t.z(), angleDeg(plane, R), rms_plane, angleDeg(turn, R), rms_turn);
    EXPECT_LT(angleDeg(plane, R), 1e-6);  // exact (the normal is the true one)
    EXPECT_LT(rms_plane, 1e-6);
    EXPECT_GT(angleDeg(turn, R), 0.1);  // the walk read as a turn
    // A wall's normal (the optical axis) instead of the floor's: the model
    // no longer explains the motion exactly (measured 0.17 and 3.55 px; a few
    // cm of walk move the image by a few px only).
    Eigen::Matrix3d wrong;
    double rms_wrong = -1;
    ASSERT_TRUE(rotationFromPlaneHomography(k, H, Eigen::Vector3d(0, 0, 1), &wrong, &rms_wrong));
    std::printf("  with a wall's normal: rms %.2f px\n", rms_wrong);
    EXPECT_GT(rms_wrong, 0.1);
  }
  // A pure turn (a distant scene) fits any normal exactly.
  const Eigen::Matrix3d H = k.K() * R * k.K().inverse();
  Eigen::Matrix3d found;
  double rms = -1;
  ASSERT_TRUE(rotationFromPlaneHomography(k, H, Eigen::Vector3d(0.3, 0.9, 0.1), &found, &rms));
  EXPECT_LT(angleDeg(found, R), 1e-6);
  EXPECT_LT(rms, 1e-6);
  // Unusable input: no answer.
  EXPECT_FALSE(rotationFromPlaneHomography(k, H, Eigen::Vector3d::Zero(), &found, &rms));
  EXPECT_FALSE(rotationFromPlaneHomography(k, Eigen::Matrix3d::Constant(NAN), n, &found, &rms));
  EXPECT_FALSE(rotationFromPlaneHomography(CameraModel(), H, n, &found, &rms));
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

// A camera travelling forward through a scene of points 3-30 m away while
// it turns about all three axes (a phone held in a car). The rays are exact
// but for 0.3 px of noise; a fifth of each frame's features sit on a
// dashboard and do not move in the image.
struct TravellingCamera {
  Eigen::Matrix3d R_cam_imu = quaternionExp(Eigen::Vector3d(0.4, -1.9, 1.2)).toRotationMatrix();
  double fps = 30, focal = 500;
  // The camera in the world at t (z forward).
  Eigen::Matrix3d orientation(double t, bool one_axis) const {
    const Eigen::Vector3d w = one_axis ? Eigen::Vector3d(0, 0.2 * std::sin(2.1 * t), 0)
                                       : Eigen::Vector3d(0.15 * std::sin(1.7 * t), 0.2 * std::sin(2.3 * t + 1),
                                                         0.08 * std::sin(3.1 * t + 2));
    return quaternionExp(w).toRotationMatrix();
  }
  Eigen::Vector3d position(double t) const { return Eigen::Vector3d(0.2 * std::sin(t), 0, 5 * t); }
  // The gyro's turn from s0 to s1, in the IMU's axes.
  Eigen::Vector3d gyro(double s0, double s1, bool one_axis) const {
    return R_cam_imu.transpose() * rotationVector(orientation(s0, one_axis).transpose() * orientation(s1, one_axis));
  }
  // `turning` false: the gyro reads no turn at all (a straight drive).
  EpipolarCamImuRotation feed(int frames, bool one_axis, uint32_t seed, bool turning = true) const {
    EpipolarCamImuRotation est;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(-1, 1), depth(3, 30);
    std::normal_distribution<double> noise(0, 0.3 / focal);
    for (int k = 0; k < frames; ++k) {
      const double t0 = k / fps, t1 = (k + 1) / fps;
      const Eigen::Matrix3d C0 = orientation(t0, one_axis), C1 = orientation(t1, one_axis);
      std::vector<EpipolarPair> pairs;
      for (int i = 0; i < 60; ++i) {
        EpipolarPair p;
        p.theta_imu = turning ? gyro(t0, t1, one_axis) : Eigen::Vector3d::Zero();
        Eigen::Vector3d r(0.6 * u(rng), 0.45 * u(rng), 1);
        if (i % 5 == 0) {  // the dashboard: fixed to the camera, in the bottom rows
          r.y() = 0.3 + 0.075 * (1 + u(rng));
          p.ray0 = r;
          p.ray1 = r + Eigen::Vector3d(noise(rng), noise(rng), 0);
        } else {
          const Eigen::Vector3d X = position(t0) + C0 * (r * depth(rng));
          const Eigen::Vector3d in1 = C1.transpose() * (X - position(t1));
          p.ray0 = r;
          p.ray1 = in1 / in1.z() + Eigen::Vector3d(noise(rng), noise(rng), 0);
        }
        pairs.push_back(p);
      }
      est.addFrame(pairs, focal);
    }
    return est;
  }
};

// Measured: found within 0.28 deg from a start 10 deg off (0.000 without
// the noise and the dashboard), the halves 0.28 deg apart; the dashboard's
// pairs are left out as fixed to the camera (4329 of 5400 pairs kept).
TEST(EpipolarCamImuRotation, FindsTheRotationOfATravellingCamera) {
  const TravellingCamera scene;
  const EpipolarCamImuRotation est = scene.feed(90, false, 3);
  EXPECT_EQ(est.frames(), 90u);
  const Eigen::Quaterniond start(quaternionExp(Eigen::Vector3d(0.1, -0.12, 0.08)).toRotationMatrix() * scene.R_cam_imu);
  ASSERT_GT(angleDeg(start.toRotationMatrix(), scene.R_cam_imu), 9.0);
  const auto fit = est.fit(start);
  ASSERT_TRUE(fit.has_value());
  const double err = angleDeg(fit->R_cam_imu.toRotationMatrix(), scene.R_cam_imu);
  std::printf("travelling camera: rotation %.3f deg off, halves %.3f deg apart, inliers %.2f of %d pairs\n", err,
              fit->spread_deg, fit->inlier_fraction, fit->pairs);
  // 0.3 px of noise on turns of 2-8 px a frame: a few tenths of a degree
  // (0.28 measured; 2.5 deg with the dashboard's pairs kept).
  EXPECT_LT(err, 0.5);
  EXPECT_TRUE(fit->sharp);
  EXPECT_GT(fit->inlier_fraction, 0.9);
  EXPECT_LT(fit->pairs, 0.85 * 90 * 60);  // the dashboard's fifth is left out
}

// Too few frames give nothing; turns about one axis leave the rotation about
// it free, and no turn at all fixes nothing: no fit.
TEST(EpipolarCamImuRotation, RefusesWhatDoesNotFixTheRotation) {
  const TravellingCamera scene;
  const Eigen::Quaterniond start(scene.R_cam_imu);
  EXPECT_FALSE(scene.feed(20, false, 4).fit(start).has_value());        // under min_frames
  EXPECT_FALSE(scene.feed(60, true, 4).fit(start).has_value());         // one axis
  EXPECT_FALSE(scene.feed(60, false, 4, false).fit(start).has_value());  // no turn
  // Bad input is dropped: non-finite rays or turns, rays behind the camera,
  // a focal length that is not positive, too few pairs.
  EpipolarCamImuRotation est;
  std::vector<EpipolarPair> bad(20);
  for (EpipolarPair& p : bad) {
    p.ray0 = Eigen::Vector3d(NAN, 0, 1);
    p.ray1 = Eigen::Vector3d(0, 0, 1);
  }
  est.addFrame(bad, 500);
  for (EpipolarPair& p : bad) p.ray0 = Eigen::Vector3d(0, 0, 1), p.theta_imu = Eigen::Vector3d(0, INFINITY, 0);
  est.addFrame(bad, 500);
  for (EpipolarPair& p : bad) p.theta_imu = Eigen::Vector3d::Zero(), p.ray1 = Eigen::Vector3d(0, 0, -1);
  est.addFrame(bad, 500);
  for (EpipolarPair& p : bad) p.ray1 = Eigen::Vector3d(0, 0, 1);
  est.addFrame(bad, 0);
  est.addFrame(bad, NAN);
  est.addFrame(std::vector<EpipolarPair>(bad.begin(), bad.begin() + 3), 500);
  EXPECT_EQ(est.frames(), 0u);
  est.addFrame(bad, 500);
  EXPECT_EQ(est.frames(), 1u);
}

// The wiring without ../shared: the travelling camera's frames as motion
// data (each frame's camera motion the least-squares homography of its
// features, as the motion analysis gives it: the travel's parallax in it),
// its gyro at 200 Hz, no tf. The turns read from those homographies give
// a rotation some degrees off, which their fit accepts early on; the
// epipolar fit disagrees with it by more than 5 deg and replaces it. The
// gyro coming in bursts 7 frames late gives the same rotation to the bit.
TEST(EpipolarCamImuRotation, TravellingCameraThroughTheAnchors) {
  const TravellingCamera scene;
  CameraModel k;
  k.fx = k.fy = scene.focal;
  k.cx = 320;
  k.cy = 240;
  k.width = 640;
  k.height = 480;
  k.valid = true;
  const Eigen::Matrix3d K = k.K();
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1), depth(3, 30);
  std::normal_distribution<double> noise(0, 0.3);
  std::vector<MotionData> mds;
  uint32_t next_id = 1;
  for (int f = 0; f < 150; ++f) {
    MotionData md;
    md.stamp = 100 + f / scene.fps;
    md.width = k.width;
    md.height = k.height;
    if (f > 0) {
      const double t0 = md.stamp - 100 - 1 / scene.fps, t1 = md.stamp - 100;
      const Eigen::Matrix3d C0 = scene.orientation(t0, false), C1 = scene.orientation(t1, false);
      std::vector<cv::Point2f> from, to;
      for (int i = 0; i < 80; ++i) {
        Eigen::Vector3d r(0.6 * u(rng), 0.45 * u(rng), 1);
        Eigen::Vector3d r1 = r;
        if (i % 5 != 0) {  // a fifth on the dashboard, fixed to the camera
          const Eigen::Vector3d X = scene.position(t0) + C0 * (r * depth(rng));
          r1 = C1.transpose() * (X - scene.position(t1));
          if (!(r1.z() > 0)) continue;
        }
        const Eigen::Vector2d p0 = (K * r).hnormalized(), p1 = (K * r1).hnormalized();
        from.emplace_back(p0.x(), p0.y());
        to.emplace_back(p1.x() + noise(rng), p1.y() + noise(rng));
      }
      const cv::Mat H = cv::findHomography(from, to, 0);
      ASSERT_FALSE(H.empty());
      md.camera.model = MotionModel::kHomography;
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) md.camera.H(r, c) = H.at<double>(r, c) / H.at<double>(2, 2);
      for (size_t i = 0; i < from.size(); ++i) {
        FeatureMotion fm;
        fm.id = next_id++;
        fm.x = to[i].x;
        fm.y = to[i].y;
        const Eigen::Vector2d at = (md.camera.H * Eigen::Vector3d(from[i].x, from[i].y, 1)).hnormalized();
        fm.dx = static_cast<float>(to[i].x - at.x());
        fm.dy = static_cast<float>(to[i].y - at.y());
        fm.age = 1;
        md.features.push_back(fm);
      }
    }
    mds.push_back(md);
  }
  std::vector<ImuSample> imu;
  for (double t = 99.9; t < 100 + 150 / scene.fps + 0.2; t += 0.005) {
    ImuSample s;
    s.stamp = t;
    s.gyro = scene.gyro(t - 100, t - 100 + 1e-4, false) / 1e-4;
    s.accel = Eigen::Vector3d(0, 0, 9.81);
    imu.push_back(s);
  }
  struct Run {
    AnchorManager::RotationSource source;
    Eigen::Quaterniond R = Eigen::Quaterniond::Identity();
    double spread_deg = -1;
    double turns_err_deg = -1;
  };
  auto run = [&](int lag_frames) {
    RegionManager regions(RegionTrackerOptions(), 10.0);
    AnchorManager anchors(AnchorOptions(), ImuOptions(), 60.0, &regions);
    anchors.setIntrinsics(k);
    size_t next = 0;
    const auto imuUpTo = [&](double t) {
      for (; next < imu.size() && imu[next].stamp <= t; ++next) anchors.addImu(imu[next]);
    };
    for (int f = 0; f < static_cast<int>(mds.size()); ++f) {
      if (lag_frames == 0)
        imuUpTo(mds[f].stamp + 0.01);
      else if (f % lag_frames == 0)
        imuUpTo(mds[f].stamp - lag_frames / scene.fps);
      regions.update(mds[f]);
      anchors.update();
    }
    imuUpTo(1e9);
    Run r{anchors.rotationSource()};
    if (anchors.videoRotation().bestFit())
      r.turns_err_deg = angleDeg(anchors.videoRotation().bestFit()->toRotationMatrix(), scene.R_cam_imu);
    if (const auto& q = anchors.imu().rotationCamImu()) r.R = *q;
    if (const auto& fit = anchors.epipolarRotationFit()) r.spread_deg = fit->spread_deg;
    return r;
  };
  const Run on_time = run(0), late = run(7);
  const double err = angleDeg(on_time.R.toRotationMatrix(), scene.R_cam_imu);
  std::printf("travelling camera through the anchors: the turns' fit %.2f deg off; the rotation in use (%s) %.3f deg "
              "off, the epipolar fit's halves %.3f deg from the whole\n",
              on_time.turns_err_deg, AnchorManager::rotationSourceName(on_time.source), err, on_time.spread_deg);
  // The failure class: the turns' fit, taken early, is several degrees off
  // (6.4 measured).
  EXPECT_GT(on_time.turns_err_deg, 3.0);
  EXPECT_EQ(on_time.source, AnchorManager::RotationSource::kVideo);
  // The first sharp epipolar fit (0.3 px of noise) replaced it: 0.47 deg
  // measured (0.52-0.60 with the scene 2-15 m away, where the turns' fit is
  // 11-14 deg off).
  EXPECT_LT(err, 1.0);
  EXPECT_EQ(late.source, on_time.source);
  EXPECT_EQ(late.R.coeffs(), on_time.R.coeffs());
}

// Real phone video with its own gyro (../shared/data/phone_gyro_cc9_clip,
// 103 frames at 800x600 over 3.4 s, 412 Hz gyro on the same clock, K given,
// no pose truth). The clip's README found the axis mapping by correlating
// flow with the gyro (horizontal flow = +f * integral of wx, vertical = -f *
// integral of wy; so the camera's y turn is -wx, its x turn -wy, and its z
// turn -wz for a proper rotation): R_cam_imu = [0 -1 0; -1 0 0; 0 0 -1].
// Its frame stamps are the frames' starts; the rolling shutter reads the
// rows over 33.3 ms after it (the middle row 16.7 ms after).
struct PhoneClip {
  std::string dir = test::sharedDataDir() + "/phone_gyro_cc9_clip";
  std::vector<double> frame_stamps;  // line k (1-based) <-> RE_frame-k.jpg
  struct Gyro {
    double t;
    Eigen::Vector3d w;
  };
  std::vector<Gyro> gyro;
  CameraModel k;
  const Eigen::Matrix3d R_cam_imu = (Eigen::Matrix3d() << 0, -1, 0, -1, 0, 0, 0, 0, -1).finished();

  bool present() const { return test::pathExists(dir + "/gyro.txt"); }
  void load() {
    std::ifstream fs(dir + "/framestamp.txt");
    for (double t; fs >> t;) frame_stamps.push_back(t);
    std::ifstream in(dir + "/gyro.txt");
    std::string line;
    while (std::getline(in, line)) {
      std::replace(line.begin(), line.end(), ',', ' ');
      std::istringstream ls(line);
      Gyro g;
      if (ls >> g.w.x() >> g.w.y() >> g.w.z() >> g.t) gyro.push_back(g);
    }
    k.fx = 573.8534;
    k.fy = 575.0448;
    k.cx = 406.0101 + 0.5;  // the source's pixel centres are integers; ours are at +0.5
    k.cy = 309.0112 + 0.5;
    k.width = 800;
    k.height = 600;
    k.valid = true;
  }
  // The gyro's turn from t0 to t1 (midpoint rule between samples, the ends
  // interpolated), rotation vector in the gyro's frame.
  Eigen::Vector3d gyroTurn(double t0, double t1) const {
    auto rate = [&](double t) {
      const auto it = std::lower_bound(gyro.begin(), gyro.end(), t, [](const Gyro& g, double x) { return g.t < x; });
      if (it == gyro.begin()) return it->w;
      if (it == gyro.end()) return gyro.back().w;
      const Gyro& a = *(it - 1);
      const double u = (t - a.t) / (it->t - a.t);
      return Eigen::Vector3d((1 - u) * a.w + u * it->w);
    };
    std::vector<double> ts = {t0};
    for (auto it = std::upper_bound(gyro.begin(), gyro.end(), t0, [](double x, const Gyro& g) { return x < g.t; });
         it != gyro.end() && it->t < t1; ++it)
      ts.push_back(it->t);
    ts.push_back(t1);
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    for (size_t i = 1; i < ts.size(); ++i) q = q * quaternionExp(0.5 * (rate(ts[i - 1]) + rate(ts[i])) * (ts[i] - ts[i - 1]));
    return rotationVector(q.toRotationMatrix());
  }
  // Frames 99..201 through the motion analysis: each frame's camera motion
  // (from the previous frame), index f - 100 for frame f.
  std::vector<MotionData> analyse() const {
    MotionAnalyzer analyzer{MotionAnalysisOptions()};
    std::vector<MotionData> out;
    for (int f = 99; f <= 201; ++f) {
      const cv::Mat gray = cv::imread(dir + "/img/RE_frame-" + std::to_string(f) + ".jpg", cv::IMREAD_GRAYSCALE);
      EXPECT_FALSE(gray.empty()) << f;
      const MotionData md = analyzer.process(gray, frame_stamps[f - 1]);
      if (f > 99) out.push_back(md);
    }
    return out;
  }
};

// Measured: 89 of 102 frame pairs read as turns; the best fit is 11.7 deg
// from that mapping (8.8 deg with the gyro shifted by 16.7 ms, half the
// rolling shutter's readout), and its residual 0.68 (0.54) is far over what
// the estimator accepts (0.25). So the estimator refuses: the anchors stay
// `calibrating` rather than say `tracked` with a rotation 12 deg off. Issue
// 14's goal (within a few degrees here) needs a rolling-shutter-aware turn.
TEST(CamImuRotationEstimator, PhoneClipRefusesWhatItCannotFindWell) {
  PhoneClip clip;
  if (!clip.present()) GTEST_SKIP() << clip.dir << " is absent";
  clip.load();
  ASSERT_GT(clip.frame_stamps.size(), 201u);
  ASSERT_GT(clip.gyro.size(), 1000u);
  const std::vector<MotionData> mds = clip.analyse();
  CamImuRotationEstimator est;
  int used = 0;
  for (int f = 100; f <= 201; ++f) {
    Eigen::Vector3d theta;
    if (!cameraTurn(clip.k, mds[f - 100].camera, &theta)) continue;
    est.add(theta, clip.gyroTurn(clip.frame_stamps[f - 2], clip.frame_stamps[f - 1]));
    ++used;
  }
  ASSERT_TRUE(est.bestFit().has_value()) << used << " turns";
  const Eigen::Matrix3d R = est.bestFit()->toRotationMatrix();
  const double err = angleDeg(R, clip.R_cam_imu);
  std::printf("phone clip: %d turns used, residual %.3f; best fit %.2f deg from the README's mapping:\n", used,
              est.residual(), err);
  for (int r = 0; r < 3; ++r) std::printf("  %7.4f %7.4f %7.4f\n", R(r, 0), R(r, 1), R(r, 2));
  EXPECT_GT(used, 60);  // most frames read as turns (89 measured)
  // The fit has the README's axes and signs (a wrong axis or sign is 90-180
  // deg off): within 15 deg (11.7 measured; see above).
  EXPECT_LT(err, 15.0);
  // And it is refused: no rotation for the anchors from this clip.
  EXPECT_GT(est.residual(), 0.25);
  EXPECT_FALSE(est.estimate().has_value());
}

// The phone clip was filmed from a car driving forward, a dashboard across
// the bottom third: the turn-and-zoom reading above takes part of the
// travel for a turn. Read from each feature's epipolar line with the gyro
// (EpipolarCamImuRotation), starting from that refused fit, the rotation is
// the README's mapping within a few degrees. The rows' times follow the
// rolling shutter (readout 33.3 ms, the README's; the correlation's offset
// at the middle row); the same with a global shutter is printed.
TEST(EpipolarCamImuRotation, PhoneClipFromACarFindsTheReadmesMapping) {
  PhoneClip clip;
  if (!clip.present()) GTEST_SKIP() << clip.dir << " is absent";
  clip.load();
  ASSERT_GT(clip.frame_stamps.size(), 201u);
  const std::vector<MotionData> mds = clip.analyse();
  CamImuRotationEstimator turns;
  for (int f = 100; f <= 201; ++f) {
    Eigen::Vector3d theta;
    if (cameraTurn(clip.k, mds[f - 100].camera, &theta))
      turns.add(theta, clip.gyroTurn(clip.frame_stamps[f - 2], clip.frame_stamps[f - 1]));
  }
  ASSERT_TRUE(turns.bestFit().has_value());
  const Eigen::Matrix3d K_inv = clip.k.K().inverse();
  auto feed = [&](double readout, double offset) {
    EpipolarCamImuRotation est;
    for (int f = 100; f <= 201; ++f) {
      const MotionData& md = mds[f - 100];
      if (md.camera.model == MotionModel::kInvalid) continue;
      const Eigen::Matrix3d H_inv = md.camera.H.inverse();
      std::vector<EpipolarPair> pairs;
      for (const FeatureMotion& fm : md.features) {
        if (fm.age == 0) continue;
        // Where the feature was: the camera motion's preimage of where it
        // would be without its own motion (see FeatureMotion).
        const Eigen::Vector2d p0 = (H_inv * Eigen::Vector3d(fm.x - fm.dx, fm.y - fm.dy, 1)).hnormalized();
        EpipolarPair p;
        p.ray0 = K_inv * p0.homogeneous();
        p.ray1 = K_inv * Eigen::Vector3d(fm.x, fm.y, 1);
        // The offset stands for the middle row (anchors.rolling_shutter_readout).
        p.theta_imu = clip.gyroTurn(clip.frame_stamps[f - 2] + offset + readout * (p0.y() / clip.k.height - 0.5),
                                    clip.frame_stamps[f - 1] + offset + readout * (fm.y / clip.k.height - 0.5));
        pairs.push_back(p);
      }
      est.addFrame(pairs, clip.k.fx);
    }
    return est.fit(*turns.bestFit());
  };
  // 14.2 ms: the offset the turns' correlation finds (the test below).
  const auto rolling = feed(0.0333, 0.0142), global = feed(0, 0.0142);
  ASSERT_TRUE(rolling.has_value());
  ASSERT_TRUE(global.has_value());
  const double start_err = angleDeg(turns.bestFit()->toRotationMatrix(), clip.R_cam_imu);
  const double rolling_err = angleDeg(rolling->R_cam_imu.toRotationMatrix(), clip.R_cam_imu);
  const double global_err = angleDeg(global->R_cam_imu.toRotationMatrix(), clip.R_cam_imu);
  std::printf("phone clip, epipolar fit: %.2f deg from the README's mapping with the rolling shutter (halves %.2f deg "
              "apart, inliers %.2f of %d pairs); %.2f deg with a global shutter at 14.2 ms (halves %.2f); "
              "the turn-and-zoom fit it started from: %.2f deg\n",
              rolling_err, rolling->spread_deg, rolling->inlier_fraction, rolling->pairs, global_err,
              global->spread_deg, start_err);
  EXPECT_TRUE(rolling->sharp);
  // Issue 14: within a few degrees of the README's mapping (itself read off
  // the flow's correlation with the gyro, the z axis inferred).
  EXPECT_LT(rolling_err, 4.0);
  EXPECT_LT(rolling_err, start_err - 5);
  EXPECT_LT(rolling_err, global_err);  // the rolling shutter modelled helps (issue 14, item 5)
}

// The same through the anchors as a user runs them: the clip's frames and
// gyro, camera_info's K, no tf, a rolling shutter of 33.3 ms. The turns'
// fit refuses, the epipolar fit takes over: the anchors get a rotation
// (source `video`) within a few degrees of the README's mapping instead of
// staying `calibrating`. Measured: 3.17 deg, halves 1.36 deg apart; from 0 ms
// the halves are 3.54 deg apart and the anchors stay `calibrating`.
TEST(EpipolarCamImuRotation, PhoneClipThroughTheAnchors) {
  PhoneClip clip;
  if (!clip.present()) GTEST_SKIP() << clip.dir << " is absent";
  clip.load();
  ASSERT_GT(clip.frame_stamps.size(), 201u);
  const std::vector<MotionData> mds = clip.analyse();
  struct Run {
    AnchorManager::RotationSource source;
    double err_deg = -1, spread_deg = -1;
    Eigen::Quaterniond R = Eigen::Quaterniond::Identity();
  };
  // `lag_frames` > 0: the gyro comes in bursts, up to that many frames
  // after the frames it covers (a live graph whose IMU lags).
  auto run = [&](double offset, int lag_frames = 0, double readout = 0.0333) {
    RegionManager regions(RegionTrackerOptions(), 10.0);
    AnchorOptions ao;
    ao.rolling_shutter_readout = readout;
    ao.imu_time_offset = offset;
    AnchorManager anchors(ao, ImuOptions(), 60.0, &regions);
    anchors.setIntrinsics(clip.k);
    size_t next = 0;
    const auto imuUpTo = [&](double t) {
      for (; next < clip.gyro.size() && clip.gyro[next].t <= t; ++next) {
        ImuSample s;
        s.stamp = clip.gyro[next].t;
        s.gyro = clip.gyro[next].w;
        s.accel = Eigen::Vector3d(0, 0, 9.81);
        anchors.addImu(s);
      }
    };
    imuUpTo(clip.frame_stamps[97]);
    for (int f = 100; f <= 201; ++f) {
      if (lag_frames == 0)
        imuUpTo(clip.frame_stamps[f - 1] + 0.02);
      else if ((f - 100) % lag_frames == 0)
        imuUpTo(clip.frame_stamps[f - 1 - lag_frames]);
      regions.update(mds[f - 100]);
      anchors.update();
    }
    imuUpTo(clip.frame_stamps[200] + 0.1);
    Run r{anchors.rotationSource()};
    if (const auto& fit = anchors.epipolarRotationFit()) {
      r.R = fit->R_cam_imu;
      r.err_deg = angleDeg(fit->R_cam_imu.toRotationMatrix(), clip.R_cam_imu);
      r.spread_deg = fit->spread_deg;
    }
    std::printf("phone clip through the anchors, readout %.1f ms, offset starting at %.1f ms: rotation from %s; the "
                "epipolar fit %.2f deg from the README's mapping, halves %.2f deg apart\n",
                1000 * readout, 1000 * offset, AnchorManager::rotationSourceName(r.source), r.err_deg, r.spread_deg);
    return r;
  };
  // Over 3.4 s the time offset estimator has too few turns to apply its
  // offset (its first fit, at 60 turns, had 57 the gyro covered, under its
  // 60; the next is due at 120, the clip has 89), so the run that starts
  // from the offset it finds (14.2 ms, the test below) is the one a longer
  // video would give.
  const Run found = run(0.0142);
  EXPECT_EQ(found.source, AnchorManager::RotationSource::kVideo);
  EXPECT_LT(found.err_deg, 4.0);  // as the fit above (issue 14: within a few degrees)
  // Started at 0 ms (16.7 ms off the rows' times), the halves disagree: no
  // rotation rather than a wrong one.
  const Run unaligned = run(0.0);
  EXPECT_GE(unaligned.spread_deg, 0);  // a fit was made,
  EXPECT_NE(unaligned.source, AnchorManager::RotationSource::kVideo);  // and refused
  // The gyro coming in bursts up to 7 frames late (live) changes nothing:
  // the frames' pairs are read in the same order with the same gyro turns.
  const Run lagging = run(0.0142, 7);
  EXPECT_EQ(lagging.source, found.source);
  EXPECT_EQ(lagging.R.coeffs(), found.R.coeffs());
  // With the defaults (no readout given, the offset starting at 0) the
  // frames' stamps stand for the whole frame: found too (1.99 deg measured;
  // 4.04 deg at 14.2 ms).
  const Run defaults = run(0.0, 0, 0.0);
  EXPECT_EQ(defaults.source, AnchorManager::RotationSource::kVideo);
  EXPECT_LT(defaults.err_deg, 4.0);
}

// The camera-IMU time offset on the phone clip: found from the turn angles
// alone (TimeOffsetEstimator), then the gyro's rotation homography
// K R K^-1 (the README's axis mapping) at that offset is held against the
// frames' background motion (the motion analysis's homography) over a grid
// of pixels, and against the same without the offset.
TEST(TimeOffsetEstimator, PhoneClipOffsetAndTheGyroHomography) {
  PhoneClip clip;
  if (!clip.present()) GTEST_SKIP() << clip.dir << " is absent";
  clip.load();
  ASSERT_GT(clip.frame_stamps.size(), 201u);
  const std::vector<MotionData> mds = clip.analyse();
  TimeOffsetEstimator::Options o;
  o.min_turns = 60;
  TimeOffsetEstimator est(o);
  for (int f = 100; f <= 201; ++f) {
    Eigen::Vector3d theta;
    if (cameraTurn(clip.k, mds[f - 100].camera, &theta))
      est.add(clip.frame_stamps[f - 2], clip.frame_stamps[f - 1], theta.norm());
  }
  const TimeOffsetFit fit = est.fit([&](double s0, double s1, double* angle) {
    *angle = clip.gyroTurn(s0, s1).norm();
    return true;
  });
  std::printf("phone clip time offset: %.1f ms over %d turns, correlation %.3f (%.3f at 0 ms)\n",
              1000 * fit.offset, fit.turns, fit.correlation, fit.at_zero);
  ASSERT_TRUE(fit.found);
  // Within a frame of the README's mapping (frame k <-> line k, 0 ms), and
  // near the rolling shutter's middle row (+16.7 ms).
  EXPECT_LE(std::abs(fit.offset), 1 / 30.0);
  // The gyro's homography against the frames' motion: median over frames
  // of the mean distance over a 5x5 grid (middle 80% of the image).
  auto prediction = [&](double offset, bool gyro = true) {
    std::vector<double> px;
    const Eigen::Matrix3d K = clip.k.K(), K_inv = K.inverse();
    for (int f = 100; f <= 201; ++f) {
      const MotionData& md = mds[f - 100];
      if (md.camera.model == MotionModel::kInvalid) continue;
      const Eigen::Vector3d theta_cam =
          clip.R_cam_imu * clip.gyroTurn(clip.frame_stamps[f - 2] + offset, clip.frame_stamps[f - 1] + offset);
      const Eigen::Matrix3d H =
          gyro ? Eigen::Matrix3d(K * quaternionExp(theta_cam).toRotationMatrix().transpose() * K_inv)
               : Eigen::Matrix3d::Identity();
      double sum = 0;
      for (int i = 0; i < 5; ++i)
        for (int j = 0; j < 5; ++j) {
          const Eigen::Vector3d p(80 + 160 * i, 60 + 120 * j, 1);
          sum += ((H * p).hnormalized() - (md.camera.H * p).hnormalized()).norm();
        }
      px.push_back(sum / 25);
    }
    std::nth_element(px.begin(), px.begin() + px.size() / 2, px.end());
    return px[px.size() / 2];
  };
  const double at_offset = prediction(fit.offset), at_zero = prediction(0), none = prediction(0, false);
  std::printf("gyro homography vs the frames' motion: median %.2f px at the offset, %.2f px at 0 ms (no "
              "rotation: %.2f px)\n",
              at_offset, at_zero, none);
  // Measured 14.2 ms, correlation 0.955 (0.833 at 0 ms); the homography
  // 2.20 px at the offset against 2.33 px at 0 ms, and 3.51 px for no
  // rotation at all. What the rotation leaves is the hand's forward motion
  // (a zoom of 2-5% per frame, which no rotation explains) and the rolling
  // shutter (a turn of 1 deg per frame shears the rows by up to ~10 px over a
  // readout of one frame). Bound: 2.5 px at the offset, and better than at 0.
  EXPECT_LT(at_offset, at_zero);
  EXPECT_LT(at_offset, 2.5);
}

}  // namespace
}  // namespace imt
