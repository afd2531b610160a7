// AnchorManager: requests (good and bad), the IMU's timing (waiting for it,
// missing, restarting), resets, and end to end on the rendered `floor_walk`
// scene against its ground truth, fed frame by frame as the nodelet is.
#include "instant_motion_tracking/core/anchor/anchor.h"
#include "instant_motion_tracking/core/anchor/anchor_manager.h"
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/options.h"
#include "instant_motion_tracking/core/tracking_session.h"
#include "instant_motion_tracking/sim/scene.h"

#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include <algorithm>
#include <cstdio>

namespace imt {
namespace {

using test::angleDeg;
using test::median;
using test::percentile;


// Motion data of a still, featureless 640x480 camera at 30 Hz.
MotionData still(int k) {
  MotionData md;
  md.stamp = 100.0 + k / 30.0;
  md.width = 640;
  md.height = 480;
  md.camera.model = k == 0 ? MotionModel::kInvalid : MotionModel::kTranslation;
  return md;
}

// An IMU at rest, level (z up), 200 Hz.
ImuSample restSample(double t) {
  ImuSample s;
  s.stamp = t;
  s.accel = Eigen::Vector3d(0, 0, 9.81);
  return s;
}

// The IMU's axes are the camera's (as the nodelet sets it when the IMU's
// frame is the camera's), unless `rotation` is false.
struct Fixture {
  explicit Fixture(bool rotation = true) {
    if (rotation) {
      EXPECT_TRUE(anchors.setRotationCamImu(Eigen::Quaterniond::Identity()));
    }
  }
  RegionManager regions{RegionTrackerOptions(), 10.0};
  AnchorManager anchors{AnchorOptions(), ImuOptions(), 60.0, &regions};
  void frames(int from, int to) {
    for (int k = from; k < to; ++k) {
      regions.update(still(k));
      anchors.update();
    }
  }
  void imu(double t0, double t1) {
    for (double t = t0; t <= t1 + 1e-9; t += 0.005) anchors.addImu(restSample(t));
  }
};

TEST(AnchorManager, BadRequestsAreRefusedWithAMessage) {
  Fixture f;
  uint32_t id = 0;
  std::string err;
  // No frame yet.
  EXPECT_FALSE(f.anchors.add(0, 0, {100, 100}, 0, &id, &err));
  EXPECT_NE(err.find("no motion data"), std::string::npos) << err;
  f.frames(0, 30);
  ASSERT_TRUE(f.anchors.add(3, 0, {100, 100}, 0, &id, &err)) << err;
  EXPECT_EQ(id, 3u);
  struct Bad {
    uint32_t id;
    double stamp, u, v, depth;
    const char* expected;
  };
  const std::vector<Bad> bad = {
      {3, 0, 10, 10, 0, "anchor id 3 is already tracked"},
      {0, 0, NAN, 10, 0, "NaN or infinite"},
      {0, 0, 10, INFINITY, 0, "NaN or infinite"},
      {0, 0, 700, 10, 0, "outside the 640x480 image"},
      {0, 0, 10, -1, 0, "outside the 640x480 image"},
      {0, 0, 10, 10, -2, "depth must be positive"},
      {0, 0, 10, 10, NAN, "depth must be positive"},
      {0, 5.0, 10, 10, 0, "outside the motion-data cache"},
      {0, NAN, 10, 10, 0, "stamp is not finite"},
  };
  for (const Bad& b : bad) {
    err.clear();
    EXPECT_FALSE(f.anchors.add(b.id, b.stamp, {b.u, b.v}, b.depth, &id, &err)) << b.expected;
    EXPECT_NE(err.find(b.expected), std::string::npos) << err;
  }
  EXPECT_EQ(f.anchors.size(), 1u);
  EXPECT_FALSE(f.anchors.remove(9, &err));
  EXPECT_EQ(err, "unknown anchor id 9");
  std::vector<AnchorState> st;
  EXPECT_FALSE(f.anchors.statesAt(0, {9}, &st, &err));
  EXPECT_EQ(err, "unknown anchor id 9");
  EXPECT_FALSE(f.anchors.statesAt(1.0, {}, &st, &err));
  EXPECT_NE(err.find("outside the motion-data cache"), std::string::npos) << err;
  // id 0 picks a free id; a removed anchor's region goes with it.
  ASSERT_TRUE(f.anchors.add(0, 0, {200, 100}, 2.0, &id, &err)) << err;
  EXPECT_EQ(id, 1u);
  EXPECT_EQ(f.regions.size(), 2u);
  EXPECT_TRUE(f.anchors.remove(3, &err));
  EXPECT_EQ(f.regions.size(), 1u);
  EXPECT_FALSE(f.anchors.contains(3));
}

TEST(AnchorManager, OptionsValidateAndParseTheRotation) {
  AnchorOptions o;
  EXPECT_EQ(o.validate(), "");
  o.region_size = 0;
  EXPECT_NE(o.validate().find("anchors.region_size"), std::string::npos);
  o = AnchorOptions();
  o.default_depth = -1;
  EXPECT_NE(o.validate().find("anchors.default_depth"), std::string::npos);
  o = AnchorOptions();
  o.rotation_cam_imu = "0 0 0";
  EXPECT_NE(o.validate().find("anchors.rotation_cam_imu"), std::string::npos);
  o.rotation_cam_imu = "0 0 0 2";  // not unit
  EXPECT_NE(o.validate().find("anchors.rotation_cam_imu"), std::string::npos);
  o.rotation_cam_imu = "0.5 -0.5 0.5 -0.5";
  EXPECT_EQ(o.validate(), "");
  Eigen::Quaterniond q;
  ASSERT_TRUE(o.rotationCamImu(&q));
  EXPECT_DOUBLE_EQ(q.w(), -0.5);
  EXPECT_DOUBLE_EQ(q.x(), 0.5);
  // Wired into the pipeline's options (config section `anchors:`).
  PipelineOptions p;
  p.anchors.imu_wait_seconds = -1;
  EXPECT_NE(p.validate().find("anchors.imu_wait_seconds"), std::string::npos);
  // A fixed rotation wins over tf.
  RegionManager regions(RegionTrackerOptions(), 10.0);
  AnchorManager fixed(o, ImuOptions(), 60.0, &regions);
  EXPECT_TRUE(fixed.rotationFromOptions());
  EXPECT_FALSE(fixed.setRotationCamImu(Eigen::Quaterniond::Identity()));
}

// A still camera: the anchor sits at the tap, depth along the ray; with an
// IMU at rest the anchor frame is z up and x the levelled optical axis.
TEST(AnchorManager, StillCameraGivesTheTapAndTheDepth) {
  Fixture f;
  f.imu(99.9, 101.0);
  f.frames(0, 10);
  uint32_t id;
  std::string err;
  ASSERT_TRUE(f.anchors.add(0, 100.0 + 5 / 30.0, {400, 300}, 2.5, &id, &err)) << err;
  std::vector<AnchorState> st;
  ASSERT_TRUE(f.anchors.statesAt(0, {}, &st, &err)) << err;
  ASSERT_EQ(st.size(), 1u);
  EXPECT_NEAR(st[0].pixel.x, 400, 1e-9);
  EXPECT_NEAR(st[0].pixel.y, 300, 1e-9);
  EXPECT_NEAR(st[0].T_cam_anchor.translation().norm(), 2.5, 1e-9);
  const CameraModel K = CameraModel::fromFieldOfView(640, 480, 60.0);
  const Eigen::Vector3d p = st[0].T_cam_anchor.translation();
  EXPECT_NEAR(K.fx * p.x() / p.z() + K.cx, 400, 1e-9);
  // Level IMU with identity R_cam_imu: world z (up) = IMU z = camera z
  // (forward); so the anchor's z axis is the camera's optical axis, and its
  // x (levelled view direction) comes from the camera's down axis.
  EXPECT_EQ(st[0].status, AnchorStatus::kTracked) << st[0].reason;
  EXPECT_TRUE(st[0].T_cam_anchor.linear().col(2).isApprox(Eigen::Vector3d::UnitZ(), 1e-6))
      << st[0].T_cam_anchor.linear();
  EXPECT_TRUE(st[0].T_cam_anchor.linear().col(0).isApprox(Eigen::Vector3d::UnitY(), 1e-6))
      << st[0].T_cam_anchor.linear();
  // Backwards to a frame before the placement: the same (still camera).
  ASSERT_TRUE(f.anchors.statesAt(100.0 + 1 / 30.0, {id}, &st, &err)) << err;
  EXPECT_NEAR(st[0].pixel.x, 400, 1e-9);
  EXPECT_NEAR(st[0].stamp, 100.0 + 1 / 30.0, 1e-12);
}

// Live timing: a frame's anchors wait for the IMU to pass its stamp, at most
// imu_wait_seconds of frames; without any IMU they do not wait, and say no_imu.
TEST(AnchorManager, FramesWaitForTheImuThenGiveUp) {
  Fixture f;
  f.frames(0, 5);
  uint32_t id;
  std::string err;
  ASSERT_TRUE(f.anchors.add(0, 0, {320, 240}, 0, &id, &err)) << err;
  const double t4 = 100.0 + 4 / 30.0;
  EXPECT_TRUE(f.anchors.ready(t4)) << "no IMU at all: nothing to wait for";
  std::vector<AnchorState> st;
  ASSERT_TRUE(f.anchors.statesAt(t4, {}, &st, &err));
  EXPECT_EQ(st[0].status, AnchorStatus::kNoImu);
  EXPECT_EQ(st[0].reason, "no IMU sample");
  EXPECT_NEAR(st[0].T_cam_anchor.translation().norm(), 1.0, 1e-9);  // default depth
  // The IMU starts, behind the frames.
  f.imu(100.0, t4 - 0.02);
  EXPECT_FALSE(f.anchors.ready(t4));
  ASSERT_TRUE(f.anchors.statesAt(t4, {}, &st, &err));
  EXPECT_EQ(st[0].status, AnchorStatus::kNoImu);
  f.imu(t4 - 0.015, t4 + 0.01);
  EXPECT_TRUE(f.anchors.ready(t4));
  ASSERT_TRUE(f.anchors.statesAt(t4, {}, &st, &err));
  EXPECT_EQ(st[0].status, AnchorStatus::kTracked) << st[0].reason;
  // The IMU stops: later frames wait 0.1 s of frames, then go.
  f.frames(5, 8);
  const double t5 = 100.0 + 5 / 30.0;
  EXPECT_FALSE(f.anchors.ready(t5));  // newest frame 7: 2/30 s later
  f.frames(8, 10);                    // newest frame 9: 4/30 s later
  EXPECT_TRUE(f.anchors.ready(t5));
  ASSERT_TRUE(f.anchors.statesAt(t5, {}, &st, &err));
  EXPECT_EQ(st[0].status, AnchorStatus::kNoImu);
  EXPECT_NE(st[0].reason.find("no IMU orientation at stamp"), std::string::npos) << st[0].reason;
}

// Without the IMU-to-camera rotation (no tf, no option) and a still camera
// (no turns for the video to show it by), the anchors are `calibrating`:
// translation only, never `tracked` with the IMU's axes taken for the
// camera's. Then tf gives it: tracked, from every frame.
TEST(AnchorManager, CalibratingUntilTheRotationIsKnown) {
  Fixture f(false);
  f.imu(99.9, 101.0);
  f.frames(0, 10);
  uint32_t id;
  std::string err;
  ASSERT_TRUE(f.anchors.add(0, 0, {400, 300}, 2.5, &id, &err)) << err;
  std::vector<AnchorState> st;
  ASSERT_TRUE(f.anchors.statesAt(0, {}, &st, &err)) << err;
  EXPECT_EQ(st[0].status, AnchorStatus::kCalibrating);
  EXPECT_FALSE(st[0].hasOrientation());
  EXPECT_NE(st[0].reason.find("IMU-to-camera rotation is not known yet"), std::string::npos) << st[0].reason;
  EXPECT_NEAR(st[0].T_cam_anchor.translation().norm(), 2.5, 1e-9);  // the translation is tracked
  EXPECT_EQ(f.anchors.rotationSource(), AnchorManager::RotationSource::kNone);
  EXPECT_STREQ(anchorStatusName(AnchorStatus::kCalibrating), "calibrating");
  ASSERT_TRUE(f.anchors.setRotationCamImu(Eigen::Quaterniond::Identity()));
  EXPECT_EQ(f.anchors.rotationSource(), AnchorManager::RotationSource::kTf);
  ASSERT_TRUE(f.anchors.statesAt(100.0 + 1 / 30.0, {}, &st, &err)) << err;
  EXPECT_EQ(st[0].status, AnchorStatus::kTracked) << st[0].reason;
  EXPECT_TRUE(st[0].T_cam_anchor.linear().col(2).isApprox(Eigen::Vector3d::UnitZ(), 1e-6));
}

// NaN and out-of-order IMU samples are dropped with a reason; a jump back
// (bag loop) restarts the orientation; time going backwards in the frames
// clears the anchors with the regions.
TEST(AnchorManager, ImuDropsRestartsAndFrameResets) {
  Fixture f;
  f.imu(99.9, 100.5);
  f.frames(0, 10);
  uint32_t id;
  std::string err, why;
  ASSERT_TRUE(f.anchors.add(0, 0, {320, 240}, 0, &id, &err)) << err;
  ImuSample nan = restSample(100.6);
  nan.gyro.x() = NAN;
  EXPECT_EQ(f.anchors.addImu(nan, &why), ImuInput::kDropped);
  EXPECT_NE(why.find("not finite"), std::string::npos) << why;
  EXPECT_EQ(f.anchors.addImu(restSample(100.4), &why), ImuInput::kDropped);
  EXPECT_NE(why.find("not after the previous one"), std::string::npos) << why;
  EXPECT_EQ(f.anchors.addImu(restSample(90.0), &why), ImuInput::kReset);
  EXPECT_NE(why.find("restarted"), std::string::npos) << why;
  EXPECT_EQ(f.anchors.imu().newestStamp(), 90.0);
  // The anchor's frame is no longer covered by the restarted IMU: no_imu, still tracked in 2D.
  std::vector<AnchorState> st;
  ASSERT_TRUE(f.anchors.statesAt(0, {}, &st, &err));
  EXPECT_EQ(st[0].status, AnchorStatus::kNoImu);
  // Frames going back in time: the region manager resets, the anchors go with it.
  f.regions.update(still(0));
  f.anchors.update();
  EXPECT_EQ(f.anchors.size(), 0u);
  EXPECT_EQ(f.regions.size(), 0u);
}

struct WalkFigures {
  std::vector<double> px_in_view, px_after_return, rot, range, rot_late;
  int out_frames = 0, out_status = 0, statuses = 0;
  std::vector<std::pair<double, double>> range_at;  // (s from the start, range error) in view
  std::vector<std::pair<double, double>> rot_at;    // (s from the start, orientation error deg) in view
  int calibrating = 0;          // anchor states without the IMU-to-camera rotation
  double found_at = -1;         // s from the start: the first state with it
  double rotation_error = -1;   // deg: the rotation in use at the end against the scene's
  bool tracked_while_calibrating = false;  // a `tracked` state before it was found
  std::string disagreement;               // AnchorManager::rotationDisagreement() at the end
  double time_offset = 0;                 // s, AnchorManager::timeOffset() at the end
  AnchorManager::OffsetSource offset_source = AnchorManager::OffsetSource::kParameter;
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();  // rad/s, the bias in use at the end
  ImuOrientation::BiasSource bias_source = ImuOrientation::BiasSource::kFixed;
  std::optional<VideoGyroBias::Estimate> video_bias;  // the video's at the end
  TimeOffsetFit offset_fit;               // AnchorManager::timeOffsetFit() at the end
};

// The orientation errors (deg) of a walk's states after `after` s.
std::vector<double> rotAfter(const WalkFigures& w, double after) {
  std::vector<double> out;
  for (const auto& [t, e] : w.rot_at)
    if (t > after) out.push_back(e);
  return out;
}

// How a frame looks when motion analysis finds no camera model: invalid,
// identity, the features' residuals their raw motion.
MotionData withoutCameraModel(MotionData md) {
  const Eigen::Matrix3d H_inv = md.camera.H.inverse();
  for (FeatureMotion& f : md.features) {
    if (f.age == 0) continue;
    const Eigen::Vector3d prev = H_inv * Eigen::Vector3d(f.x - f.dx, f.y - f.dy, 1);
    f.dx = static_cast<float>(f.x - prev.x() / prev.z());
    f.dy = static_cast<float>(f.y - prev.y() / prev.z());
  }
  md.camera.model = MotionModel::kInvalid;
  md.camera.H.setIdentity();
  return md;
}

enum class OutOfView { kVisual, kNoCameraModel, kNoCameraModelNoFallback };

// The last walk's motion data, frame by frame. A test that walks one scene
// several times (the IMU late, biased, mounted otherwise: none of it in the
// frames) renders and analyses its frames once: the same frames give the same
// motion data. Keyed by the options that shape the frames; the key's frames
// 0 and last are kept, and a walk uses the data only when its own two frames
// are the same to the pixel (an option the key left out would differ there).
struct WalkMotion {
  std::string key;
  cv::Mat first, last;
  std::vector<MotionData> frames;
};
WalkMotion& lastWalkMotion() {
  static WalkMotion cache;
  return cache;
}

std::string walkKey(const SceneOptions& o) {
  std::string key = o.preset + "|" + o.trajectory + "|" + o.distortion_model;
  char text[512];
  std::snprintf(text, sizeof(text), "|%.17g %.17g %d %d %.17g %llu %.17g %d %.17g %.17g %.17g %.17g %d %.17g %.17g %zu %zu",
                o.duration, o.fps, o.width, o.height, o.hfov_deg, static_cast<unsigned long long>(o.seed),
                o.start_time, o.supersample, o.noise_sigma, o.brightness_amplitude, o.brightness_period, o.exposure,
                o.blur_samples, o.void_gray, o.trajectory_amplitude, o.planes.size(), o.anchors.size());
  key += text;
  for (double d : o.distortion) key += " " + std::to_string(d);
  for (const std::string& f : o.texture_files) key += "|" + f;
  return key;
}

// The walk's motion data from the cache, when it holds this scene's (see WalkMotion).
const std::vector<MotionData>* cachedWalkMotion(const SceneGenerator& scene) {
  const WalkMotion& c = lastWalkMotion();
  const int n = scene.frameCount();
  if (c.key != walkKey(scene.options()) || static_cast<int>(c.frames.size()) != n || n == 0) return nullptr;
  const auto same = [](const cv::Mat& a, const cv::Mat& b) {
    return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
  };
  if (!same(scene.renderFrame(0), c.first) || !same(scene.renderFrame(n - 1), c.last)) return nullptr;
  return &c.frames;
}

// What a walk changes from floor_walk's defaults.
struct WalkSetup {
  std::function<void(SceneOptions*)> adjust;  // the scene's options
  double imu_late = 0;                        // s added to every IMU stamp (a driver stamping late)
  AnchorOptions anchors;
  ImuOptions imu;
};

// floor_walk frame by frame: the IMU fed as a live stream would be, frames
// answered once ready(); anchor 1 placed at frame 0 (the scene's anchor),
// anchor 2 at frame 30 in the past (given at frame 45) on the same point.
// `mode`: while the anchor is out of view the frames may lose their camera
// model (then the IMU rotation carries the regions, unless the fallback is off).
// `hidden_rotation`: the IMU is mounted so (R_cam_imu), and nobody says so
// (no tf, no option): the anchors must find it from the video; or tf says
// `told` instead (wrong, unless it is the same).
void runWalk(WalkFigures* out, OutOfView mode = OutOfView::kVisual,
             const std::optional<Eigen::Quaterniond>& hidden_rotation = std::nullopt,
             const std::optional<Eigen::Quaterniond>& told = std::nullopt, const WalkSetup& setup = WalkSetup()) {
  SceneOptions o = test::preset("floor_walk");
  if (setup.adjust) setup.adjust(&o);
  if (hidden_rotation) o.q_cam_imu = *hidden_rotation;
  auto scene = test::make(o);
  ASSERT_TRUE(scene);
  const CameraModel K = scene->intrinsics();
  RegionManager regions(RegionTrackerOptions(), 10.0);
  AnchorManager anchors(setup.anchors, setup.imu, 60.0, &regions);
  if (mode == OutOfView::kNoCameraModelNoFallback) regions.setCameraFallback(nullptr);
  anchors.setIntrinsics(K);
  if (!hidden_rotation) {
    ASSERT_TRUE(anchors.setRotationCamImu(scene->options().q_cam_imu));
  } else if (told) {
    ASSERT_TRUE(anchors.setRotationCamImu(*told));
  }
  std::vector<ImuSample> imu = scene->imuSamples();
  for (ImuSample& s : imu) s.stamp += setup.imu_late;
  size_t next_imu = 0;
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  const std::vector<MotionData>* cached = cachedWalkMotion(*scene);
  WalkMotion analysed;  // this walk's, for the cache (when it was not there)
  std::vector<int> pending;
  std::string err;
  const FrameTruth f0 = scene->frameTruth(0), f30 = scene->frameTruth(30);
  ASSERT_FALSE(f0.anchors.empty());
  bool was_out = false;
  double returned_at = -1;
  for (int i = 0; i < scene->frameCount(); ++i) {
    const double t = scene->frameStamp(i);
    // The IMU runs ahead of the frames by up to one sample here, and behind
    // them on every third frame (as a late driver would).
    while (next_imu < imu.size() && imu[next_imu].stamp <= t + (i % 3 == 1 ? -0.02 : 0.006))
      ASSERT_NE(anchors.addImu(imu[next_imu++]), ImuInput::kReset);
    MotionData md;
    if (cached) {
      md = (*cached)[i];
    } else {
      const cv::Mat frame = scene->renderFrame(i);
      md = analyzer.process(frame, t);
      analysed.frames.push_back(md);
      if (i == 0) analysed.first = frame;
      if (i == scene->frameCount() - 1) analysed.last = frame;
    }
    if (mode != OutOfView::kVisual && !scene->frameTruth(i).anchors[0].in_view) md = withoutCameraModel(md);
    regions.update(md);
    anchors.update();
    uint32_t id;
    if (i == 0) {
      ASSERT_TRUE(anchors.add(1, 0, f0.anchors[0].pixel,
                              f0.anchors[0].T_cam_anchor.translation().norm(), &id, &err))
          << err;
    }
    if (i == 45) {
      ASSERT_TRUE(anchors.add(2, scene->frameStamp(30), f30.anchors[0].pixel,
                              f30.anchors[0].T_cam_anchor.translation().norm(), &id, &err))
          << err;
    }
    pending.push_back(i);
    while (!pending.empty() && anchors.ready(scene->frameStamp(pending.front()))) {
      const int k = pending.front();
      pending.erase(pending.begin());
      std::vector<AnchorState> st;
      ASSERT_TRUE(anchors.statesAt(scene->frameStamp(k), {}, &st, &err)) << err;
      const FrameTruth truth = scene->frameTruth(k);
      const FrameTruth::Anchor& a = truth.anchors[0];
      for (const AnchorState& s : st) {
        ++out->statuses;
        ASSERT_NE(s.status, AnchorStatus::kLost) << "frame " << k << ": " << s.reason;
        // An IMU stamping late has no sample for the first frames' stamps.
        if (truth.stamp < imu.front().stamp) continue;
        EXPECT_NE(s.status, AnchorStatus::kNoImu) << "frame " << k << ": " << s.reason;
        if (s.status == AnchorStatus::kCalibrating) {
          ++out->calibrating;
          out->tracked_while_calibrating |= out->found_at >= 0;
          continue;
        }
        if (out->found_at < 0) out->found_at = truth.stamp - scene->frameStamp(0);
        if (s.id == 2) {
          // Its frame: x = levelled view direction at frame 30 (yaw-free, so
          // comparable through the truth's own world).
          const Eigen::Matrix3d R_wa = anchorOrientation(scene->T_world_cam(30 / o.fps).linear());
          const Eigen::Matrix3d R_expected = truth.T_world_cam.linear().transpose() * R_wa;
          if (a.in_view) out->rot_late.push_back(angleDeg(s.T_cam_anchor.linear(), R_expected));
          continue;
        }
        const double e = cv::norm(s.pixel - a.pixel);
        if (!a.in_view) {
          was_out = true;
          // Well outside the image (by the region's size): the status must say so.
          const double margin = 0.2 * 480;
          if (a.pixel.x < -margin || a.pixel.x > 640 + margin || a.pixel.y < -margin ||
              a.pixel.y > 480 + margin) {
            ++out->out_frames;
            out->out_status += s.status == AnchorStatus::kOutOfView;
          }
          continue;
        }
        out->px_in_view.push_back(e);
        if (was_out && returned_at < 0) returned_at = truth.stamp;
        if (returned_at >= 0 && truth.stamp - returned_at <= 1.0) out->px_after_return.push_back(e);
        out->rot.push_back(angleDeg(s.T_cam_anchor.linear(), a.T_cam_anchor.linear()));
        out->rot_at.emplace_back(truth.stamp - scene->frameStamp(0), out->rot.back());
        out->range.push_back(std::abs(
            s.T_cam_anchor.translation().norm() / a.T_cam_anchor.translation().norm() - 1));
        out->range_at.emplace_back(truth.stamp - scene->frameStamp(0), out->range.back());
        if (std::getenv("IMT_TEST_TRACE"))  // per-frame trace for tuning
          std::printf("%d est %.4f true %.4f nd %.4f cz %.4f\n", k, s.T_cam_anchor.translation().norm(),
                      a.T_cam_anchor.translation().norm(),
                      std::abs(s.T_cam_anchor.linear().col(2).dot(s.T_cam_anchor.translation().normalized())),
                      s.T_cam_anchor.translation().normalized().z());
      }
    }
  }
  if (!cached) {
    analysed.key = walkKey(scene->options());
    lastWalkMotion() = std::move(analysed);
  }
  out->disagreement = anchors.rotationDisagreement();
  out->time_offset = anchors.timeOffset();
  out->offset_source = anchors.timeOffsetSource();
  out->gyro_bias = anchors.gyroBias();
  out->bias_source = anchors.gyroBiasSource();
  out->video_bias = anchors.videoGyroBias();
  if (anchors.timeOffsetFit()) out->offset_fit = *anchors.timeOffsetFit();
  if (anchors.rotationSource() != AnchorManager::RotationSource::kNone)
    out->rotation_error = Eigen::AngleAxisd(anchors.imu().rotationCamImu()->toRotationMatrix().transpose() *
                                            scene->options().q_cam_imu.toRotationMatrix())
                              .angle() *
                          180 / M_PI;
  std::printf(
      "floor_walk AnchorManager: pixel median %.2f px in view, %.2f px first second back; "
      "orientation "
      "median %.3f deg (anchor placed in the past: %.3f deg); range median %.1f%%; out_of_view "
      "status on "
      "%d of %d frames far outside\n",
      median(out->px_in_view), median(out->px_after_return), median(out->rot),
      median(out->rot_late), 100 * median(out->range), out->out_status, out->out_frames);
}

// The bars: pixel median <= 3 px in view, <= 15 px over the first
// second back in view; orientation median <= 1 degree; relative range error
// median <= 5% (measured 4.3% with the horizontal-surface correction, 18.9%
// from the region's scale alone). The anchor placed in the past is held to
// the same orientation bar. Every frame is answered.
TEST(AnchorManager, FloorWalkAgainstGroundTruth) {
  WalkFigures f;
  runWalk(&f);
  const int frames = 360;
  EXPECT_GE(f.statuses, frames + (frames - 45) - 3)
      << "frames left waiting at the end are the only ones missing";
  ASSERT_FALSE(f.px_after_return.empty())
      << "the scene should take the anchor out of view and back";
  EXPECT_LE(median(f.px_in_view), 3.0);
  EXPECT_LE(median(f.px_after_return), 15.0);
  EXPECT_LE(median(f.rot), 1.0);
  EXPECT_LE(median(f.rot_late), 1.0);
  EXPECT_LE(median(f.range), 0.05);
  // Far outside the image the region is out of view: every such frame says so.
  ASSERT_GT(f.out_frames, 0);
  EXPECT_EQ(f.out_status, f.out_frames);
}

// No tf and no option, the IMU mounted at an arbitrary angle (128 deg about
// a tilted axis): the anchors are `calibrating` (translation only, never
// `tracked` with the IMU's axes taken for the camera's) until the video has
// shown the rotation (issue 14: within 1 deg after 5 s of ordinary motion),
// then tracked to the same bars as with the rotation given.
TEST(AnchorManager, FloorWalkFindsTheImuRotationFromTheVideo) {
  const Eigen::Quaterniond hidden(Eigen::AngleAxisd(128 * M_PI / 180, Eigen::Vector3d(1, -2, 0.5).normalized()));
  WalkFigures f;
  runWalk(&f, OutOfView::kVisual, hidden);
  std::printf("hidden IMU rotation: calibrating for %d states, found %.2f s in, %.3f deg off at the end\n",
              f.calibrating, f.found_at, f.rotation_error);
  ASSERT_GE(f.found_at, 0) << "never found";
  EXPECT_GT(f.calibrating, 0);  // not known from the first frame
  EXPECT_LE(f.found_at, 5.0);
  EXPECT_FALSE(f.tracked_while_calibrating);
  EXPECT_LE(f.rotation_error, 1.0);
  // Measured: found 1.13 s in (34 states calibrating), 0.214 deg off at the
  // end: at 2.1 s the epipolar fit (EpipolarCamImuRotation) found the turns'
  // rotation 5.1 deg from its own and replaced it, and the turns read over
  // the floor refine within 0.2 deg of it no further (0.059 deg before
  // 2026-11-27, 0.341 before its turns were read over the floor). From
  // then on, the bars of FloorWalkAgainstGroundTruth for the pixel and the
  // orientation (measured 0.63 px, 0.134 deg, 0.147 before; 0.60 px, 0.08
  // deg with the rotation given). The range error is compared over the same frames with
  // the rotation given (the walk's later part is harder than its start: 4.8%
  // there, 4.4% over the whole walk): measured 4.6%; within a point.
  EXPECT_LE(median(f.px_in_view), 3.0);
  EXPECT_LE(median(f.rot), 1.0);
  WalkFigures given;
  runWalk(&given);
  std::vector<double> same_frames;
  for (const auto& [t, e] : given.range_at)
    if (t >= f.found_at) same_frames.push_back(e);
  std::printf("range median %.1f%%, with the rotation given over the same frames %.1f%%\n", 100 * median(f.range),
              100 * median(same_frames));
  EXPECT_LE(median(f.range), median(same_frames) + 0.01);
}

// Issue 14's slow-turn drift and its goal: the walk at a fifth of its
// motion (turns under 5 deg/s, never still) for 60 s, with a constant gyro
// bias of 0.49 deg/s. The IMU alone took a stretch of slow turning for
// stillness and its rate for the bias (the error grew 1.16 deg/s). Stillness
// needing the video's agreement stopped that, and the error then grew with
// the bias itself (0.31 deg/s over 18 s with a 0.32 deg/s bias). Now the
// video tracks the bias while the camera moves (imu.video_bias): the gyro's
// turn between frames against the camera's, read off the floor's motion with
// the IMU's up as its normal. Goal: the anchor's orientation within 1 deg
// after 60 s.
TEST(AnchorManager, FloorWalkSlowTurnsWithAGyroBias) {
  const Eigen::Vector3d bias(0.005, -0.006, 0.0035);  // rad/s, 0.49 deg/s
  WalkSetup setup;
  setup.adjust = [&](SceneOptions* o) {
    o->trajectory_amplitude = 0.2;
    o->duration = 60.0;
    o->gyro_bias = bias;
  };
  WalkFigures f, without;
  runWalk(&f, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
  setup.imu.video_bias = false;
  runWalk(&without, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
  const std::vector<double> last = rotAfter(f, 58), last_without = rotAfter(without, 58);
  ASSERT_FALSE(last.empty());
  ASSERT_FALSE(last_without.empty());
  ASSERT_TRUE(f.video_bias);
  std::printf("slow walk, 60 s, gyro bias %.3f deg/s: orientation median over the last 2 s %.3f deg (without the "
              "video's bias %.3f deg); bias in use (%s) off by %.4f deg/s, the video's sigma %.4f deg/s over %d "
              "frames\n",
              bias.norm() * 180 / M_PI, median(last), median(last_without),
              ImuOrientation::biasSourceName(f.bias_source), (f.gyro_bias - bias).norm() * 180 / M_PI,
              f.video_bias->sigma.norm() * 180 / M_PI, f.video_bias->frames);
  EXPECT_EQ(f.bias_source, ImuOrientation::BiasSource::kVideo);
  // Issue 14's goal.
  EXPECT_LE(median(last), 1.0);
  // The bias itself to within 3 of the video's own standard errors (and
  // what it says of itself is no overstatement: 3 sigma under 0.05 deg/s).
  EXPECT_LE((f.gyro_bias - bias).norm(), 3 * f.video_bias->sigma.norm());
  EXPECT_LE(3 * f.video_bias->sigma.norm() * 180 / M_PI, 0.05);
  // Without it the error grows with the bias (about 0.49 deg/s).
  EXPECT_GE(median(last_without), 10.0);
}

// The slow walk with the IMU-to-camera rotation hidden (no tf), 30 s, the
// gyro biased by 0.49 deg/s: its turns are under the rotation estimator's
// 0.2 deg per frame on most frames, and the bias is a tenth of them. Before
// (2026-11-24) the rotation was never found: the anchors stayed calibrating.
// Slow frames are composed until they turn 0.2 deg together. The bias is
// tracked as with the rotation given: its readings outlive the video's
// rotation refining itself, and the rotation's own turns are read over the
// floor once it is first found.
TEST(AnchorManager, FloorWalkSlowTurnsFindTheImuRotation) {
  const Eigen::Vector3d bias(0.005, -0.006, 0.0035);  // rad/s, 0.49 deg/s
  const Eigen::Quaterniond hidden(Eigen::AngleAxisd(128 * M_PI / 180, Eigen::Vector3d(1, -2, 0.5).normalized()));
  WalkSetup setup;
  setup.adjust = [&](SceneOptions* o) {
    o->trajectory_amplitude = 0.2;
    o->duration = 30.0;
    o->gyro_bias = bias;
  };
  WalkFigures f;
  runWalk(&f, OutOfView::kVisual, hidden, std::nullopt, setup);
  const std::vector<double> last = rotAfter(f, 28);
  ASSERT_FALSE(last.empty());
  std::printf("slow walk, rotation hidden: calibrating for %d states, found %.2f s in, %.3f deg off at the end; "
              "orientation median %.3f deg, over the last 2 s %.3f deg; bias from %s, off by %.4f deg/s\n",
              f.calibrating, f.found_at, f.rotation_error, median(f.rot), median(last),
              ImuOrientation::biasSourceName(f.bias_source), (f.gyro_bias - bias).norm() * 180 / M_PI);
  std::printf("  orientation median per 3 s:");
  for (int w = 0; w < 30; w += 3) {
    std::vector<double> e;
    for (const auto& [t, x] : f.rot_at)
      if (t >= w && t < w + 3) e.push_back(x);
    std::printf(" %.2f", e.empty() ? NAN : median(e));
  }
  std::printf(" deg\n");
  // Measured: found 2.83 s in, 0.39 deg off at the end. Issue 14: within a
  // few deg; 1 deg as for the ordinary walk.
  ASSERT_GE(f.found_at, 0) << "never found";
  EXPECT_LE(f.found_at, 5.0);
  EXPECT_FALSE(f.tracked_while_calibrating);
  EXPECT_LE(f.rotation_error, 1.0);
  // Measured: bias from the video, 0.013 deg/s off; orientation 0.32 deg
  // over the last 2 s (0.55 deg median over the walk: the first seconds
  // drift with the bias until it is found; 0.40 / 0.65 deg with the time
  // offset not applied). Before, each move of the
  // video's rotation dropped the bias's readings and the bias was never
  // tracked: 7.8 deg median, 14.0 over the last 2 s. Issue 14's goal (1 deg,
  // given for the rotation known) holds with the rotation found too; the
  // bias within the slow walk's bar with the rotation given (0.05 deg/s).
  EXPECT_EQ(f.bias_source, ImuOrientation::BiasSource::kVideo);
  EXPECT_LE((f.gyro_bias - bias).norm() * 180 / M_PI, 0.05);
  EXPECT_LE(median(last), 1.0);
}

// Issue 14: IMU stamps late by -30, 0 and +40 ms against the frames' (the
// rendered IMU is exact otherwise). The offset is estimated from the video
// on every walk; anchors.estimate_imu_time_offset applies it.
TEST(AnchorManager, FloorWalkTimeOffsetFromTheVideo) {
  std::map<int, TimeOffsetFit> fits;
  std::map<int, std::optional<VideoGyroBias::Estimate>> bias_fits;
  for (const int late_ms : {-30, 0, 40}) {
    WalkFigures f;
    WalkSetup setup;
    setup.imu_late = late_ms / 1000.0;
    setup.anchors.estimate_imu_time_offset = false;  // the estimators alone, against the offset 0
    runWalk(&f, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
    fits[late_ms] = f.offset_fit;
    bias_fits[late_ms] = f.video_bias;
    std::printf("IMU %+d ms late: estimated %.1f ms (correlation %.3f; %.3f at 0 ms) over %d turns; gyro bias %.4f "
                "deg/s from %s; the bias fit's lateness %.1f +- %.1f ms\n",
                late_ms, 1000 * f.offset_fit.offset, f.offset_fit.correlation, f.offset_fit.at_zero, f.offset_fit.turns,
                f.gyro_bias.norm() * 180 / M_PI, ImuOrientation::biasSourceName(f.bias_source),
                f.video_bias ? 1000 * f.video_bias->lateness : NAN, f.video_bias ? 1000 * f.video_bias->lateness_sigma : NAN);
    ASSERT_TRUE(f.offset_fit.found) << late_ms << " ms";
    EXPECT_EQ(f.time_offset, 0.0) << "not applied when anchors.estimate_imu_time_offset is off";
  }
  // Measured -16.3, +13.7 and +53.6 ms: each offset to 0.1 ms, plus the same
  // +13.6 ms. That bias is this scene's: the camera moves over the floor 1-2 m
  // below it, and the floor's flow reads as a turn that follows the camera's
  // pitch angle (not its rate), as a phase shift would. The differences
  // hold to 2 ms (a third of an IMU sample's 5 ms); the bias to 20 ms.
  EXPECT_NEAR(1000 * (fits[40].offset - fits[0].offset), 40, 2);
  EXPECT_NEAR(1000 * (fits[-30].offset - fits[0].offset), -30, 2);
  EXPECT_LE(std::abs(fits[0].offset), 0.020);
  // The gyro bias's fit reads the offset too, as the lateness of the gyro
  // against the frames (VideoGyroBias), without the scene's bias: measured
  // +29.8, +0.2 and -39.2 ms (the offset in use, 0, less the true one),
  // each +- 0.1-0.3 ms. 2 ms: its linear model (a rate plus the lateness
  // times the rate's change) is 2% short at 40 ms.
  for (const auto& [late_ms, e] : bias_fits) {
    ASSERT_TRUE(e) << late_ms << " ms";
    EXPECT_NEAR(1000 * e->lateness, -late_ms, 2) << "the offset in use (0) less the true one";
  }
  // Applied, with the IMU 40 ms late: the correlation's offset first, then
  // the bias fit's refinement of it; the orientation error against the
  // offset left alone.
  WalkFigures ignored, applied;
  WalkSetup setup;
  setup.imu_late = 0.04;
  setup.anchors.estimate_imu_time_offset = false;
  runWalk(&ignored, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
  setup.anchors.estimate_imu_time_offset = true;  // the default
  runWalk(&applied, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
  std::printf("IMU 40 ms late: orientation median %.3f deg with the offset applied (%.1f ms from %s; the bias fit's "
              "lateness then %.1f ms), %.3f deg without\n",
              median(applied.rot), 1000 * applied.time_offset, AnchorManager::offsetSourceName(applied.offset_source),
              applied.video_bias ? 1000 * applied.video_bias->lateness : NAN, median(ignored.rot));
  EXPECT_EQ(applied.offset_source, AnchorManager::OffsetSource::kBiasFit);
  EXPECT_NEAR(applied.time_offset, 0.040, 0.002);  // issue 14's goal: within 2 ms, rendered
  // Measured 0.236 deg against 0.640 without.
  EXPECT_LT(median(applied.rot), 0.5 * median(ignored.rot));
  // 30 ms early: within the bias fit's reach, so the bias fit alone sets it.
  WalkFigures early;
  setup.imu_late = -0.03;
  runWalk(&early, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
  std::printf("IMU 30 ms early: orientation median %.3f deg with the offset applied (%.1f ms from %s)\n",
              median(early.rot), 1000 * early.time_offset, AnchorManager::offsetSourceName(early.offset_source));
  EXPECT_EQ(early.offset_source, AnchorManager::OffsetSource::kBiasFit);
  EXPECT_NEAR(early.time_offset, -0.030, 0.002);
  // On time: the correlation's +13.7 ms is within the bias fit's reach
  // (kOffsetCorrelationReach), so it is not applied, and the bias fit finds
  // nothing to change (its lateness 0.2 ms, under a millisecond): no loss
  // against the offset left alone (measured 0.076 deg either way; 0.081
  // when the correlation's offset was applied first).
  WalkFigures on_time, on_time_applied;
  setup.imu_late = 0;
  runWalk(&on_time_applied, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
  setup.anchors.estimate_imu_time_offset = false;
  runWalk(&on_time, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
  std::printf("IMU on time: orientation median %.3f deg with the offset applied (%.1f ms from %s), %.3f deg without\n",
              median(on_time_applied.rot), 1000 * on_time_applied.time_offset,
              AnchorManager::offsetSourceName(on_time_applied.offset_source), median(on_time.rot));
  EXPECT_EQ(on_time_applied.offset_source, AnchorManager::OffsetSource::kParameter);  // nothing applied
  EXPECT_EQ(on_time_applied.time_offset, 0.0);
  EXPECT_LE(median(on_time_applied.rot), median(on_time.rot) + 0.005);  // the last digits' noise
}

// Issue 14's calibration-free case in full: no tf, the IMU mounted 128 deg
// about a tilted axis, and its stamps 40 ms late or 30 ms early. The video
// finds both: 40 ms by the correlation's offset first (beyond the bias
// fit's reach), then the bias fit's; 30 ms by the bias fit alone; the bias
// fit's once its last two fits agree.
TEST(AnchorManager, FloorWalkLateImuAndHiddenRotation) {
  const Eigen::Quaterniond hidden(Eigen::AngleAxisd(128 * M_PI / 180, Eigen::Vector3d(1, -2, 0.5).normalized()));
  for (const int late_ms : {40, -30}) {
    WalkFigures f, given;
    WalkSetup setup;
    setup.imu_late = late_ms / 1000.0;
    runWalk(&f, OutOfView::kVisual, hidden, std::nullopt, setup);
    runWalk(&given, OutOfView::kVisual, std::nullopt, std::nullopt, setup);
    std::printf("IMU %+d ms late, rotation hidden: found %.2f s in, %.3f deg off at the end; offset %.1f ms from %s; "
                "orientation median %.3f deg (rotation given: %.3f deg, offset %.1f ms)\n",
                late_ms, f.found_at, f.rotation_error, 1000 * f.time_offset,
                AnchorManager::offsetSourceName(f.offset_source), median(f.rot), median(given.rot),
                1000 * given.time_offset);
    ASSERT_GE(f.found_at, 0) << "never found";
    EXPECT_LE(f.found_at, 5.0);
    EXPECT_FALSE(f.tracked_while_calibrating);
    EXPECT_LE(f.rotation_error, 1.0);                       // issue 14: within 1 deg
    EXPECT_NEAR(1000 * f.time_offset, late_ms, 2.0);        // and 2 ms
    // In the end the bias fit's, as the comment above says.
    EXPECT_EQ(f.offset_source, AnchorManager::OffsetSource::kBiasFit)
        << AnchorManager::offsetSourceName(f.offset_source);
    // Measured 0.409 deg at +40 ms, 0.475 at -30 ms (0.236 / 0.192 with the
    // rotation given; the rotation found 0.41 / 0.67 deg off; with a 3-s
    // wait for the rotation to settle, tried first: 0.617 deg at +40 ms,
    // the offset left at 59.2 ms). 0.75 deg: half again the worst measured,
    // under issue 14's 1 deg.
    EXPECT_LE(median(f.rot), 0.75) << late_ms << " ms";
  }
}

// A rotation the video showed is the rig's: after a bag loop (frames and IMU
// going back to stamps before it was found) an anchor is tracked at once, on
// the loop's first frame (before the fix: calibrating, as the rotation
// applied only from the stamp it was found at).
TEST(AnchorManager, RotationFromTheVideoOutlivesABagLoop) {
  SceneOptions o = test::preset("floor_walk");
  o.q_cam_imu = Eigen::Quaterniond(Eigen::AngleAxisd(128 * M_PI / 180, Eigen::Vector3d(1, -2, 0.5).normalized()));
  o.duration = 3.0;
  auto scene = test::make(o);
  ASSERT_TRUE(scene);
  RegionManager regions(RegionTrackerOptions(), 10.0);
  AnchorManager anchors(AnchorOptions(), ImuOptions(), 60.0, &regions);
  anchors.setIntrinsics(scene->intrinsics());
  const std::vector<ImuSample> imu = scene->imuSamples();
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  // Frames [from, to), the IMU fed up to each.
  size_t next = 0;
  auto play = [&](int from, int to) {
    if (from == 0) next = 0;
    for (int i = from; i < to; ++i) {
      while (next < imu.size() && imu[next].stamp <= scene->frameStamp(i) + 0.006) anchors.addImu(imu[next++]);
      regions.update(analyzer.process(scene->renderFrame(i), scene->frameStamp(i)));
      anchors.update();
    }
  };
  // Found after the first second, so the loop's first frames are before it.
  int found = -1;
  for (int i = 0; i < scene->frameCount() && found < 0; ++i) {
    play(i, i + 1);
    if (anchors.rotationSource() == AnchorManager::RotationSource::kVideo) found = i;
  }
  std::printf("found at frame %d\n", found);
  ASSERT_GT(found, 1);
  analyzer.reset();
  play(0, 1);  // the loop: back to the start (on its first frame no turn is read yet)
  EXPECT_EQ(regions.cachedFrames(), 1u);  // the loop reset the cache
  uint32_t id;
  std::string err;
  ASSERT_TRUE(anchors.add(0, 0, scene->frameTruth(0).anchors[0].pixel, 1.0, &id, &err)) << err;
  std::vector<AnchorState> st;
  ASSERT_TRUE(anchors.statesAt(0, {}, &st, &err)) << err;
  EXPECT_EQ(st[0].status, AnchorStatus::kTracked) << st[0].reason;
}

// tf says the IMU's axes are the camera's, but the IMU is mounted 128 deg
// about a tilted axis: tf is used (the user's word), and the video's own
// estimate makes a warning that names both. A tf the video agrees with makes
// none.
TEST(AnchorManager, TfTheVideoDisagreesWithIsWarnedAbout) {
  const Eigen::Quaterniond mounted(Eigen::AngleAxisd(128 * M_PI / 180, Eigen::Vector3d(1, -2, 0.5).normalized()));
  WalkFigures wrong, right;
  runWalk(&wrong, OutOfView::kVisual, mounted, Eigen::Quaterniond::Identity());
  runWalk(&right, OutOfView::kVisual, mounted, mounted);
  std::printf("%s\n", wrong.disagreement.c_str());
  EXPECT_NE(wrong.disagreement.find("the IMU-to-camera rotation from tf (qx qy qz qw [0.000 0.000 0.000 1.000])"),
            std::string::npos)
      << wrong.disagreement;
  EXPECT_NE(wrong.disagreement.find("differ by 128"), std::string::npos) << wrong.disagreement;
  EXPECT_EQ(right.disagreement, "");
  EXPECT_EQ(wrong.calibrating, 0);  // tf gave a rotation from the start
  // The rotation in use is tf's, warned about, not the video's: 128 deg from
  // the mounting (0.1 deg: the two angles' rounding), the right tf's within
  // issue 14's 1 deg.
  EXPECT_NEAR(wrong.rotation_error, 128, 0.1);
  EXPECT_LE(right.rotation_error, 1.0);
}

// The fallback: while the anchor is out of view every frame loses its
// camera model (as behind heavy blur or on a blank wall); the IMU rotation,
// plus the features' median residual for the walk's translation, then
// predicts the anchor, and it comes back where it was: the same 15 px bar
// over the first second back (measured 14.4 px; 18 px from the rotation
// alone: the camera walks ~0.4 m meanwhile). Without the fallback the region
// stands still while the camera yaws and comes back far off (checked, so the
// scenario is one the fallback is needed for).
TEST(AnchorManager, OutOfViewOnTheImuWhenTheCameraModelFails) {
  WalkFigures imu, none;
  runWalk(&imu, OutOfView::kNoCameraModel);
  runWalk(&none, OutOfView::kNoCameraModelNoFallback);
  std::printf("no camera model while out of view: first second back %.1f px with the IMU fallback, %.1f px without\n",
              median(imu.px_after_return), median(none.px_after_return));
  ASSERT_FALSE(imu.px_after_return.empty());
  EXPECT_LE(median(imu.px_after_return), 15.0);
  EXPECT_GT(median(none.px_after_return), 30.0);
  // The IMU stamped 40 ms late, and the offset known (anchors.imu_time_offset):
  // a frame is stepped when it comes, before the samples it needs (its stamp
  // plus 40 ms; the walk's IMU leads the frames by 6 ms at most). The turn is
  // then extrapolated from the last samples' rate; before, the fallback had
  // none and the region stayed where it left the view (213 px off when back).
  WalkFigures late;
  WalkSetup setup;
  setup.imu_late = 0.04;
  setup.anchors.imu_time_offset = 0.04;
  setup.anchors.estimate_imu_time_offset = false;  // known: the video's estimate does not move it
  runWalk(&late, OutOfView::kNoCameraModel, std::nullopt, std::nullopt, setup);
  std::printf("IMU 40 ms late, offset given: first second back %.1f px with the IMU fallback\n",
              median(late.px_after_return));
  ASSERT_FALSE(late.px_after_return.empty());
  EXPECT_LE(median(late.px_after_return), 15.0);
}

// Moving regions: an anchor tapped on the centre of a card that slides over
// the wall (cards scene, card 1) follows the card, not the wall: its pixel is
// scored against the centre of the card's projected box while the card is
// whole in view and unoccluded (the tap: the centre of its whole projected
// box at frame 0, where it is partly outside the image). A wall-bound anchor
// would be hundreds of pixels off.
TEST(AnchorManager, AnchorOnAMovingCardFollowsIt) {
  auto scene = test::make(test::preset("cards"));
  ASSERT_TRUE(scene);
  RegionManager regions(RegionTrackerOptions(), 10.0);
  AnchorManager anchors(AnchorOptions(), ImuOptions(), 60.0, &regions);
  anchors.setIntrinsics(scene->intrinsics());
  ASSERT_TRUE(anchors.setRotationCamImu(scene->options().q_cam_imu));
  const std::vector<ImuSample> imu = scene->imuSamples();
  size_t next_imu = 0;
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  auto card = [&](const FrameTruth& f) -> const FrameTruth::Region* {
    for (const auto& r : f.regions)
      if (r.id == 1) return &r;
    return nullptr;
  };
  auto centre = [](const cv::Rect2d& b) { return cv::Point2d(b.x + b.width / 2, b.y + b.height / 2); };
  std::vector<double> err, wall;
  std::string e;
  const int n = std::min(scene->frameCount(), 150);
  cv::Point2d tap, wall_pt;
  for (int i = 0; i < n; ++i) {
    const double t = scene->frameStamp(i);
    while (next_imu < imu.size() && imu[next_imu].stamp <= t + 0.006) anchors.addImu(imu[next_imu++]);
    regions.update(analyzer.process(scene->renderFrame(i), t));
    anchors.update();
    const FrameTruth truth = scene->frameTruth(i);
    const FrameTruth::Region* c = card(truth);
    ASSERT_NE(c, nullptr);
    uint32_t id;
    if (i == 0) {
      tap = wall_pt = centre(c->box_unclipped);
      ASSERT_TRUE(anchors.add(1, 0, tap, 1.0, &id, &e)) << e;
      continue;
    }
    std::vector<AnchorState> st;
    ASSERT_TRUE(anchors.statesAt(t, {}, &st, &e)) << e;
    ASSERT_EQ(st.size(), 1u);
    // Where the wall point first under the tap is now (the background's motion).
    ASSERT_TRUE(truth.background_homography.has_value());
    const Eigen::Vector3d p = *truth.background_homography * Eigen::Vector3d(wall_pt.x, wall_pt.y, 1);
    wall_pt = cv::Point2d(p.x() / p.z(), p.y() / p.z());
    if (c->visible_fraction < 0.999 || c->occluded_fraction > 0.001) continue;
    err.push_back(cv::norm(st[0].pixel - centre(c->box_unclipped)));
    if (std::getenv("IMT_TEST_TRACE"))  // per-frame trace for tuning
      std::printf("%d err %.1f anchor %.0f %.0f card %.0f %.0f (%.0fx%.0f) status %d\n", i, err.back(), st[0].pixel.x,
                  st[0].pixel.y, centre(c->box_unclipped).x, centre(c->box_unclipped).y, c->box_unclipped.width, c->box_unclipped.height,
                  static_cast<int>(st[0].status));
    wall.push_back(cv::norm(wall_pt - centre(c->box_unclipped)));
  }
  std::printf("anchor on moving card 1: pixel error median %.2f px over %zu frames (the wall point under the tap "
              "is %.1f px away, median)\n",
              median(err), err.size(), median(wall));
  ASSERT_GT(err.size(), 60u);
  EXPECT_LE(median(err), 3.0);  // the in-view bar (measured 1.0 px)
  EXPECT_GT(median(wall), 20.0);  // the card does move relative to the wall
}

// An anchor tapped on the wall of the cards scene, clear of the cards (the
// point scripts/demo_live.py places its anchor at), holds the wall point
// under the tap: its pixel is scored against the wall's true motion from the
// tap on every frame where the point is in view and no card is within 30 px
// of it (one passing in front would hide it), as the demo scores it. The
// whole pipeline, live (the regions' look needs the session's frames).
TEST(AnchorManager, AnchorOnTheWallHoldsItsPoint) {
  auto scene = test::make(test::preset("cards"));
  ASSERT_TRUE(scene);
  TrackingSession session(PipelineOptions(), TrackingSession::Mode::kLive);
  session.setCameraInfo(scene->intrinsics());
  ASSERT_TRUE(session.setRotationCamImu(scene->options().q_cam_imu));
  const std::vector<ImuSample> imu = scene->imuSamples();
  size_t next_imu = 0;
  const cv::Size image = scene->renderFrame(0).size();
  const auto clear = [&](const FrameTruth& f, const cv::Point2d& p) {
    if (p.x < 10 || p.y < 10 || p.x >= image.width - 10 || p.y >= image.height - 10) return false;
    for (const auto& r : f.regions) {
      const cv::Rect2d& b = r.box_unclipped;
      if (std::hypot(std::max({b.x - p.x, 0.0, p.x - b.br().x}), std::max({b.y - p.y, 0.0, p.y - b.br().y})) < 30)
        return false;
    }
    return true;
  };
  std::map<double, cv::Point2d> wall;  // stamp -> the wall point under the tap, where clear
  cv::Point2d wall_pt(80.5, 300.5);
  std::vector<double> err;
  std::string e;
  for (int i = 0; i < scene->frameCount(); ++i) {
    const double t = scene->frameStamp(i);
    const FrameTruth truth = scene->frameTruth(i);
    if (i > 0) {
      ASSERT_TRUE(truth.background_homography.has_value());
      const Eigen::Vector3d p = *truth.background_homography * Eigen::Vector3d(wall_pt.x, wall_pt.y, 1);
      wall_pt = cv::Point2d(p.x() / p.z(), p.y() / p.z());
      if (clear(truth, wall_pt)) wall[t] = wall_pt;
    }
    while (next_imu < imu.size() && imu[next_imu].stamp <= t + 0.006) session.addImu(imu[next_imu++]);
    session.analyze(scene->renderFrame(i), t);
    if (i == 0) {
      ASSERT_TRUE(clear(truth, wall_pt));
      session.takeResults();
      uint32_t id;
      ASSERT_TRUE(session.addAnchor(1, t, wall_pt, 0.0, &id, &e)) << e;
      continue;
    }
    for (const FrameResult& fr : session.takeResults()) {
      const auto w = wall.find(fr.motion.stamp);
      if (w == wall.end()) continue;
      ASSERT_EQ(fr.anchors.size(), 1u);
      err.push_back(cv::norm(fr.anchors[0].pixel - w->second));
    }
  }
  const double p95 = err.empty() ? 0 : percentile(err, 0.95);
  std::printf("anchor on the wall: pixel error median %.2f px, p95 %.2f px over %zu frames\n", median(err), p95,
              err.size());
  ASSERT_GT(err.size(), 150u);
  // Measured 0.32 / 0.64 px (2026-12-01). Before a region still against the
  // background and matched strongly by its template was held from its
  // filter's moves: 2.11 / 2.81 px, drifting 2 px in 6 s.
  EXPECT_LE(median(err), 0.6);
  EXPECT_LE(p95, 1.2);
}

}  // namespace
}  // namespace imt
