#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/markers.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <vector>

namespace imt {
namespace {

TEST(Conversions, MotionDataRoundTrip) {
  MotionData md;
  md.stamp = 1000.25;
  md.width = 640;
  md.height = 480;
  md.analysis_scale = 2;
  md.camera.model = MotionModel::kSimilarity;
  md.camera.H << 1.01, -0.02, 3.5, 0.02, 1.01, -2.25, 0, 0, 1;
  md.camera.features = 120;
  md.camera.inliers = 100;
  for (uint32_t i = 0; i < 5; ++i) {
    FeatureMotion f;
    f.id = 10 + i;
    f.x = 1.5f * i;
    f.y = 2.5f * i;
    f.dx = 0.25f * i;
    f.dy = -0.5f * i;
    f.bg_weight = 0.2f * i;
    f.foreground = i % 2;
    f.age = static_cast<uint16_t>(3 * i);
    f.patch_error = 1.5f * i;
    md.features.push_back(f);
  }
  std_msgs::Header h;
  h.stamp.fromSec(md.stamp);
  h.frame_id = "camera";
  const MotionData back = fromMsg(toMsg(md, h));
  EXPECT_NEAR(back.stamp, md.stamp, 1e-9);
  EXPECT_EQ(back.width, 640);
  EXPECT_FLOAT_EQ(back.analysis_scale, 2);
  EXPECT_EQ(back.camera.model, MotionModel::kSimilarity);
  EXPECT_TRUE(back.camera.H.isApprox(md.camera.H));
  EXPECT_EQ(back.camera.inliers, 100);
  ASSERT_EQ(back.features.size(), md.features.size());
  for (size_t i = 0; i < md.features.size(); ++i) {
    EXPECT_EQ(back.features[i].id, md.features[i].id);
    EXPECT_FLOAT_EQ(back.features[i].dy, md.features[i].dy);
    EXPECT_EQ(back.features[i].foreground, md.features[i].foreground);
    EXPECT_EQ(back.features[i].age, md.features[i].age);
    EXPECT_FLOAT_EQ(back.features[i].patch_error, md.features[i].patch_error);
  }
}

TEST(Conversions, MalformedMotionDataIsSanitised) {
  instant_motion_tracking::MotionData m;
  m.model = 42;  // unknown model
  m.homography = {1, 0, NAN, 0, 1, 0, 0, 0, 1};
  m.ids = {1, 2, 3};
  m.x = {1, NAN, 3};
  m.y = {1, 2, 3};
  m.dx = {0, 0, 0};
  m.dy = {0, 0, 0};
  m.background_weight = {1, 1};  // shorter than the rest
  m.foreground = {0, 0, 0};
  m.age = {1, 1, 1};
  m.analysis_scale = NAN;
  const MotionData md = fromMsg(m);
  EXPECT_EQ(md.analysis_scale, 1.f);  // unknown: full resolution
  EXPECT_EQ(md.camera.model, MotionModel::kInvalid);
  EXPECT_TRUE(md.camera.H.isIdentity());
  ASSERT_EQ(md.features.size(), 1u);  // common prefix of 2, minus the NaN one
  EXPECT_EQ(md.features[0].id, 1u);
  EXPECT_EQ(md.features[0].patch_error, 0.f);  // none given (an older publisher): unknown
}

// The patch errors are optional: a short array, NaN or a negative value
// reads as unknown (0) and keeps the feature.
TEST(Conversions, MissingOrBadPatchErrorsReadAsUnknown) {
  instant_motion_tracking::MotionData m;
  m.ids = {1, 2, 3};
  m.x = m.y = m.dx = m.dy = {1, 2, 3};
  m.background_weight = {1, 1, 1};
  m.foreground = {0, 0, 0};
  m.age = {1, 1, 1};
  m.patch_error = {NAN, -2};
  const MotionData md = fromMsg(m);
  ASSERT_EQ(md.features.size(), 3u);
  for (const FeatureMotion& f : md.features) EXPECT_EQ(f.patch_error, 0.f) << f.id;
  m.patch_error = {0.5f, 4, 2};
  const MotionData ok = fromMsg(m);
  ASSERT_EQ(ok.features.size(), 3u);
  EXPECT_FLOAT_EQ(ok.features[1].patch_error, 4.f);
}

TEST(Conversions, BadBackgroundWeightsReadAsBackground) {
  instant_motion_tracking::MotionData m;
  m.ids = {1, 2, 3, 4, 5, 6};
  m.x = m.y = m.dx = m.dy = {1, 2, 3, 4, 5, 6};
  m.background_weight = {NAN, INFINITY, -INFINITY, 7, -3, 0.25f};
  m.foreground = {0, 0, 0, 0, 0, 1};
  m.age = {1, 1, 1, 1, 1, 1};
  const MotionData md = fromMsg(m);
  ASSERT_EQ(md.features.size(), 6u);
  const float expected[] = {1, 1, 1, 1, 0, 0.25f};  // no number: background; else clamped to 0..1
  for (size_t i = 0; i < 6; ++i) EXPECT_FLOAT_EQ(md.features[i].bg_weight, expected[i]) << md.features[i].id;
}

TEST(Conversions, CameraInfoShiftsThePrincipalPointByHalfAPixel) {
  CameraModel k = CameraModel::fromFieldOfView(640, 480, 60.0);
  std_msgs::Header h;
  const sensor_msgs::CameraInfo info = toCameraInfo(k, h);
  EXPECT_DOUBLE_EQ(info.K[2], 319.5);  // OpenCV convention: centre of a 640 px row
  CameraModel back;
  std::string why;
  ASSERT_TRUE(fromCameraInfo(info, &back, &why, false)) << why;
  EXPECT_DOUBLE_EQ(back.cx, 320.0);
  EXPECT_DOUBLE_EQ(back.fx, k.fx);
  EXPECT_FALSE(back.hasDistortion()) << "plumb_bob with a zero D";
  sensor_msgs::CameraInfo bad = info;
  bad.K[0] = 0;
  EXPECT_FALSE(fromCameraInfo(bad, &back, &why, false));
  EXPECT_NE(why.find("focal"), std::string::npos);
}

// What fuzzing put into camera_info (issue 16) is refused with the reason,
// never turned into a silently wrong camera: NaN or infinite entries, zero
// or absurd focal lengths, a principal point far off, a broken K, sizes of
// 4e9 px; and, checked against the frames, a size other than theirs.
TEST(Conversions, CameraInfoRefusesImplausibleValuesAndAnotherSizeThanTheFrames) {
  const sensor_msgs::CameraInfo good = toCameraInfo(CameraModel::fromFieldOfView(640, 480, 60.0), std_msgs::Header());
  CameraModel k;
  std::string why;
  ASSERT_TRUE(fromCameraInfo(good, &k, &why, false)) << why;
  struct Case {
    const char* name;
    std::function<void(sensor_msgs::CameraInfo&)> edit;
    const char* reason;
  };
  const double nan = std::numeric_limits<double>::quiet_NaN(), inf = std::numeric_limits<double>::infinity();
  for (const Case& c : std::vector<Case>{
           {"nan fx", [&](auto& m) { m.K[0] = nan; }, "camera_info K has a NaN or infinite entry"},
           {"nan skew", [&](auto& m) { m.K[1] = nan; }, "camera_info K has a NaN or infinite entry"},
           {"inf cy", [&](auto& m) { m.K[5] = inf; }, "camera_info K has a NaN or infinite entry"},
           {"zero K", [](auto& m) { m.K.fill(0.0); }, "camera_info K has no usable focal length"},
           {"negative fy", [](auto& m) { m.K[4] = -500; }, "camera_info K has no usable focal length"},
           {"tiny fx", [](auto& m) { m.K[0] = 1e-300; },
            "camera_info K focal length (fx 1e-300, fy 554.256) is implausible for a 640x480 image"},
           {"huge fy", [](auto& m) { m.K[4] = 1e300; },
            "camera_info K focal length (fx 554.256, fy 1e+300) is implausible for a 640x480 image"},
           {"principal point far off", [](auto& m) { m.K[2] = -5000; },
            "camera_info K principal point (-5000, 239.5) is far outside the 640x480 image"},
           {"K[8] zero", [](auto& m) { m.K[8] = 0; }, "camera_info K is not a camera matrix"},
           {"K[6] set", [](auto& m) { m.K[6] = 1e300; }, "camera_info K is not a camera matrix"},
           {"size 4e9", [](auto& m) { m.width = 4294967295u; }, "camera_info size 4294967295x480 is over 65536 px"},
           {"no size", [](auto& m) { m.height = 0; }, "camera_info has no image size"},
       }) {
    sensor_msgs::CameraInfo m = good;
    c.edit(m);
    why.clear();
    EXPECT_FALSE(fromCameraInfo(m, &k, &why, false)) << c.name;
    EXPECT_EQ(why.rfind(c.reason, 0), 0u) << c.name << ": " << why;
  }
  // Checked as it comes: against the frames' size once there are frames.
  ASSERT_TRUE(cameraInfoForFrames(good, false, cv::Size(), &k, &why)) << why;  // no frame yet
  ASSERT_TRUE(cameraInfoForFrames(good, false, cv::Size(640, 480), &k, &why)) << why;
  EXPECT_EQ(k.width, 640);
  EXPECT_FALSE(cameraInfoForFrames(good, false, cv::Size(320, 240), &k, &why));
  EXPECT_EQ(why, "camera_info size 640x480 differs from the images' 320x240");
  sensor_msgs::CameraInfo nan_info = good;
  nan_info.K[0] = nan;
  EXPECT_FALSE(cameraInfoForFrames(nan_info, false, cv::Size(640, 480), &k, &why));
  EXPECT_EQ(why, "camera_info K has a NaN or infinite entry");
}

// A calibrated camera's camera_info: K with D under each supported model; P
// (a different pinhole, as image_proc's rectification chooses) is used
// instead, and D ignored, when the images are already rectified.
TEST(Conversions, CameraInfoReadsTheDistortionOrPForRectifiedImages) {
  sensor_msgs::CameraInfo info;
  info.width = 640;
  info.height = 480;
  info.K = {550, 0, 321.5, 0, 552, 243.5, 0, 0, 1};
  info.P = {500, 0, 318.5, 0, 0, 501, 240.5, 0, 0, 0, 1, 0};
  struct Case {
    const char* model;
    std::vector<double> D;
    CameraModel::Distortion expected;
  };
  for (const Case& c : {Case{"plumb_bob", {-0.28, 0.07, 0.001, -0.0005, 0.0}, CameraModel::Distortion::kPlumbBob},
                        Case{"rational_polynomial", {0.6, -0.05, 0.0005, 0.0008, 0, 0.9, 0.05, 0},
                             CameraModel::Distortion::kRationalPolynomial},
                        Case{"equidistant", {-0.05, 0.01, -0.003, 0.0005}, CameraModel::Distortion::kEquidistant}}) {
    info.distortion_model = c.model;
    info.D = c.D;
    CameraModel k;
    std::string why;
    ASSERT_TRUE(fromCameraInfo(info, &k, &why, false)) << c.model << ": " << why;
    EXPECT_EQ(k.distortion, c.expected) << c.model;
    EXPECT_EQ(k.D, c.D) << c.model;
    EXPECT_TRUE(k.hasDistortion()) << c.model;
    EXPECT_DOUBLE_EQ(k.fx, 550);
    EXPECT_DOUBLE_EQ(k.cy, 244.0);
    // The way back keeps the model and the coefficients.
    const sensor_msgs::CameraInfo again = toCameraInfo(k, std_msgs::Header());
    EXPECT_EQ(again.distortion_model, c.model);
    EXPECT_EQ(again.D, c.D);
    // Rectified input: P's pinhole, no distortion.
    ASSERT_TRUE(fromCameraInfo(info, &k, &why, true)) << why;
    EXPECT_DOUBLE_EQ(k.fx, 500);
    EXPECT_DOUBLE_EQ(k.fy, 501);
    EXPECT_DOUBLE_EQ(k.cx, 319.0);
    EXPECT_DOUBLE_EQ(k.cy, 241.0);
    EXPECT_FALSE(k.hasDistortion()) << c.model;
  }
  // An unknown model with a non-zero D is refused (the caller warns and falls back)...
  info.distortion_model = "fov";
  info.D = {0.9};
  CameraModel k;
  std::string why;
  EXPECT_FALSE(fromCameraInfo(info, &k, &why, false));
  EXPECT_NE(why.find("'fov' is not supported"), std::string::npos) << why;
  // ...but not for rectified images (D ignored), nor with an all-zero or empty D.
  EXPECT_TRUE(fromCameraInfo(info, &k, &why, true)) << why;
  info.D = {0, 0, 0, 0, 0};
  EXPECT_TRUE(fromCameraInfo(info, &k, &why, false)) << why;
  EXPECT_FALSE(k.hasDistortion());
  info.D.clear();
  EXPECT_TRUE(fromCameraInfo(info, &k, &why, false)) << why;
  // A D of the wrong length or with a NaN is refused with the reason.
  info.distortion_model = "plumb_bob";
  info.D = {0.1, 0, 0, 0, 0, 0, 0, 0};
  EXPECT_FALSE(fromCameraInfo(info, &k, &why, false));
  EXPECT_NE(why.find("takes 5 coefficients, got 8"), std::string::npos) << why;
  info.D = {0.1, NAN, 0, 0, 0};
  EXPECT_FALSE(fromCameraInfo(info, &k, &why, false));
  EXPECT_NE(why.find("NaN"), std::string::npos) << why;
  // A rectified image without a usable P.
  info.P[0] = 0;
  EXPECT_FALSE(fromCameraInfo(info, &k, &why, true));
  EXPECT_NE(why.find("P has no usable focal length"), std::string::npos) << why;
}

TEST(Conversions, ImuRejectsNaNAndReadsMissingOrientation) {
  ImuSample s;
  s.stamp = 5.0;
  s.gyro = {0.1, 0.2, 0.3};
  s.accel = {0, 0, 9.81};
  s.has_orientation = false;
  std_msgs::Header h;
  h.stamp.fromSec(5.0);
  sensor_msgs::Imu m = toImuMsg(s, h);
  ImuSample back;
  std::string why;
  ASSERT_TRUE(fromImuMsg(m, &back, &why));
  EXPECT_FALSE(back.has_orientation);
  EXPECT_TRUE(back.gyro.isApprox(s.gyro));
  m.angular_velocity.y = NAN;
  EXPECT_FALSE(fromImuMsg(m, &back, &why));
  EXPECT_NE(why.find("NaN"), std::string::npos);
}

// Anchors: message fields, tf frames `<prefix>anchor_<id>` under the image
// frame, axes markers; a lost anchor has NaN fields, no tf and no marker.
TEST(Conversions, AnchorsToMessagesTfAndMarkers) {
  AnchorState a;
  a.id = 7;
  a.pixel = {100.5, 50.25};
  a.T_cam_anchor.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  a.T_cam_anchor.translation() = Eigen::Vector3d(0.1, -0.2, 1.5);
  a.status = AnchorStatus::kOutOfView;
  a.confidence = 0.5;
  AnchorState lost = a;
  lost.id = 8;
  lost.status = AnchorStatus::kLost;
  std_msgs::Header h;
  h.frame_id = "cam_optical";
  h.stamp.fromSec(12.5);
  const auto m = toMsg(std::vector<AnchorState>{a, lost}, h);
  ASSERT_EQ(m.anchors.size(), 2u);
  EXPECT_EQ(m.header.frame_id, "cam_optical");
  EXPECT_FLOAT_EQ(m.anchors[0].u, 100.5f);
  EXPECT_EQ(m.anchors[0].status, "out_of_view");
  EXPECT_DOUBLE_EQ(m.anchors[0].pose.position.z, 1.5);
  EXPECT_NEAR(m.anchors[0].pose.orientation.y, std::sin(0.15), 1e-12);
  EXPECT_EQ(m.anchors[1].status, "lost");
  EXPECT_TRUE(std::isnan(m.anchors[1].u) && std::isnan(m.anchors[1].pose.position.x));
  const auto tf = anchorTransforms({a, lost}, h, "robot1/");
  ASSERT_EQ(tf.size(), 1u);
  EXPECT_EQ(tf[0].child_frame_id, "robot1/anchor_7");
  EXPECT_EQ(tf[0].header.frame_id, "cam_optical");
  EXPECT_EQ(tf[0].header.stamp, h.stamp);
  EXPECT_DOUBLE_EQ(tf[0].transform.translation.y, -0.2);
  const auto markers = anchorMarkers({a, lost}, h, 0.1);
  ASSERT_EQ(markers.markers.size(), 2u);  // axes + label of anchor 7
  const auto& axes = markers.markers[0];
  ASSERT_EQ(axes.points.size(), 6u);
  // The z axis (blue) ends 0.1 m along the anchor's z.
  const Eigen::Vector3d tip = a.T_cam_anchor * Eigen::Vector3d(0, 0, 0.1);
  EXPECT_NEAR(axes.points[5].x, tip.x(), 1e-12);
  EXPECT_NEAR(axes.points[5].z, tip.z(), 1e-12);
  EXPECT_EQ(axes.colors[5].b, 1.0f);
  EXPECT_EQ(markers.markers[1].text, "7 out_of_view");
  // The label 0.3 axis lengths above the origin (optical y points down).
  EXPECT_DOUBLE_EQ(markers.markers[1].pose.position.x, 0.1);
  EXPECT_DOUBLE_EQ(markers.markers[1].pose.position.y, -0.2 - 0.3 * 0.1);
  EXPECT_DOUBLE_EQ(markers.markers[1].pose.position.z, 1.5);
}

TEST(Conversions, PlanarTargetsToTfAndMarkers) {
  PlanarTargetState t;
  t.id = 3;
  t.width_m = 0.4;
  t.height_m = 0.2;
  t.T_cam_target.linear() = Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  t.T_cam_target.translation() = Eigen::Vector3d(-0.1, 0.05, 2.0);
  t.status = TargetStatus::kTracked;
  PlanarTargetState lost = t;
  lost.id = 4;
  lost.status = TargetStatus::kLost;
  std_msgs::Header h;
  h.frame_id = "cam_optical";
  h.stamp.fromSec(3.25);
  const auto tf = planarTargetTransforms({t, lost}, h, "");
  ASSERT_EQ(tf.size(), 1u);  // a lost target has no pose to broadcast
  EXPECT_EQ(tf[0].child_frame_id, "planar_target_3");
  EXPECT_EQ(tf[0].header.frame_id, "cam_optical");
  EXPECT_EQ(tf[0].header.stamp, h.stamp);
  EXPECT_DOUBLE_EQ(tf[0].transform.translation.x, -0.1);
  EXPECT_DOUBLE_EQ(tf[0].transform.translation.z, 2.0);
  EXPECT_NEAR(tf[0].transform.rotation.x, std::sin(0.1), 1e-12);
  const auto markers = planarTargetMarkers({t, lost}, h);
  ASSERT_EQ(markers.markers.size(), 1u);
  const auto& quad = markers.markers[0];
  EXPECT_EQ(quad.id, 3);
  EXPECT_EQ(quad.ns, "planar_targets");
  EXPECT_EQ(quad.header.frame_id, "cam_optical");
  ASSERT_EQ(quad.points.size(), 5u);  // closed: the first corner again
  // The third corner is the target's (+w/2, +h/2) on its plane.
  const Eigen::Vector3d br = t.T_cam_target * Eigen::Vector3d(0.2, 0.1, 0);
  EXPECT_NEAR(quad.points[2].x, br.x(), 1e-12);
  EXPECT_NEAR(quad.points[2].y, br.y(), 1e-12);
  EXPECT_NEAR(quad.points[2].z, br.z(), 1e-12);
  EXPECT_EQ(quad.points[4].x, quad.points[0].x);
  EXPECT_EQ(quad.color.g, 1.0f);  // tracked: green
}

}  // namespace
}  // namespace imt
