// Tests of the IMU-to-camera rotation found from the video (issue 14):
// rotations read off camera-motion homographies, and the estimator that
// aligns them with the gyro's.
#include "instant_motion_tracking/core/anchor/cam_imu_rotation.h"
#include "instant_motion_tracking/core/anchor/imu_orientation.h"
#include "instant_motion_tracking/core/motion/motion_analysis.h"

#include "shared_data.h"

#include <gtest/gtest.h>
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

// Real phone video with its own gyro (../shared/data/phone_gyro_cc9_clip,
// 103 frames at 800x600 over 3.4 s, 412 Hz gyro on the same clock, K given,
// no pose truth). The clip's README found the axis mapping by correlating
// flow with the gyro (horizontal flow = +f * integral of wx, vertical = -f *
// integral of wy; so the camera's y turn is -wx, its x turn -wy, and its z
// turn -wz for a proper rotation): R_cam_imu = [0 -1 0; -1 0 0; 0 0 -1].
//
// Measured: 89 of 102 frame pairs read as turns; the best fit is 11.7 deg
// from that mapping (8.8 deg with the gyro shifted by 16.7 ms, half the
// rolling shutter's readout: the camera-IMU time offset, not estimated yet),
// and its residual 0.68 (0.54) is far over what the estimator accepts
// (0.25). So the estimator refuses: the anchors stay `calibrating` rather
// than say `tracked` with a rotation 12 deg off. Issue 14's goal (within a
// few degrees here) needs the time offset and a rolling-shutter-aware turn.
TEST(CamImuRotationEstimator, PhoneClipRefusesWhatItCannotFindWell) {
  const std::string dir = test::sharedDataDir() + "/phone_gyro_cc9_clip";
  if (!test::pathExists(dir + "/gyro.txt")) GTEST_SKIP() << dir << " is absent";
  std::vector<double> frame_stamps;  // line k (1-based) <-> RE_frame-k.jpg
  {
    std::ifstream in(dir + "/framestamp.txt");
    for (double t; in >> t;) frame_stamps.push_back(t);
  }
  struct Gyro {
    double t;
    Eigen::Vector3d w;
  };
  std::vector<Gyro> gyro;
  {
    std::ifstream in(dir + "/gyro.txt");
    std::string line;
    while (std::getline(in, line)) {
      std::replace(line.begin(), line.end(), ',', ' ');
      std::istringstream ls(line);
      Gyro g;
      if (ls >> g.w.x() >> g.w.y() >> g.w.z() >> g.t) gyro.push_back(g);
    }
  }
  ASSERT_GT(frame_stamps.size(), 201u);
  ASSERT_GT(gyro.size(), 1000u);
  // The gyro's turn from t0 to t1 (midpoint rule between samples, the ends interpolated).
  auto gyroTurn = [&](double t0, double t1) {
    auto rate = [&](double t) {
      const auto it = std::lower_bound(gyro.begin(), gyro.end(), t, [](const Gyro& g, double x) { return g.t < x; });
      if (it == gyro.begin()) return it->w;
      if (it == gyro.end()) return gyro.back().w;
      const Gyro& a = *(it - 1);
      const double u = (t - a.t) / (it->t - a.t);
      return Eigen::Vector3d((1 - u) * a.w + u * it->w);
    };
    std::vector<double> ts = {t0};
    for (const Gyro& g : gyro)
      if (g.t > t0 && g.t < t1) ts.push_back(g.t);
    ts.push_back(t1);
    Eigen::Quaterniond q = Eigen::Quaterniond::Identity();
    for (size_t i = 1; i < ts.size(); ++i) q = q * quaternionExp(0.5 * (rate(ts[i - 1]) + rate(ts[i])) * (ts[i] - ts[i - 1]));
    const Eigen::AngleAxisd a(q);
    return Eigen::Vector3d(a.angle() * a.axis());
  };
  CameraModel k;
  k.fx = 573.8534;
  k.fy = 575.0448;
  k.cx = 406.0101 + 0.5;  // the source's pixel centres are integers; ours are at +0.5
  k.cy = 309.0112 + 0.5;
  k.width = 800;
  k.height = 600;
  k.valid = true;
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  CamImuRotationEstimator est;
  int used = 0;
  for (int f = 99; f <= 201; ++f) {
    const cv::Mat gray = cv::imread(dir + "/img/RE_frame-" + std::to_string(f) + ".jpg", cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(gray.empty()) << f;
    const MotionData md = analyzer.process(gray, frame_stamps[f - 1]);
    Eigen::Vector3d theta;
    if (f == 99 || !cameraTurn(k, md.camera, &theta)) continue;
    est.add(theta, gyroTurn(frame_stamps[f - 2], frame_stamps[f - 1]));
    ++used;
  }
  ASSERT_TRUE(est.bestFit().has_value()) << used << " turns";
  const Eigen::Matrix3d R = est.bestFit()->toRotationMatrix();
  const Eigen::Matrix3d expected = (Eigen::Matrix3d() << 0, -1, 0, -1, 0, 0, 0, 0, -1).finished();
  const double err = angleDeg(R, expected);
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

}  // namespace
}  // namespace imt
