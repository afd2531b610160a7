// Tracker output messages back to core states (what MotionAnalysisNodelet
// draws on debug_image): round trips, lost items, unknown statuses, bad poses.
#include "instant_motion_tracking/ros/conversions.h"

#include <gtest/gtest.h>

#include <cmath>

namespace imt {
namespace {

std_msgs::Header header(double stamp) {
  std_msgs::Header h;
  h.stamp.fromSec(stamp);
  h.frame_id = "camera";
  return h;
}

Eigen::Isometry3d pose() {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(0.1, -0.2, 1.5);
  return T;
}

TEST(TrackerOutputConversions, RegionsRoundTrip) {
  RegionState a = RegionState::start(3, cv::Rect2d(10.5, 20.25, 30, 40), 1000.5);
  a.status = RegionStatus::kFeatureless;
  a.confidence = 0.5;
  RegionState b = RegionState::start(4, cv::Rect2d(1, 2, 3, 4), 1000.5);
  b.status = RegionStatus::kLost;
  const std::vector<RegionState> back =
      fromMsg(toMsg(std::vector<RegionState>{a, b}, header(1000.5)));
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].id, 3u);
  EXPECT_DOUBLE_EQ(back[0].stamp, 1000.5);
  EXPECT_EQ(back[0].box, a.box);
  EXPECT_EQ(back[0].status, RegionStatus::kFeatureless);
  EXPECT_FLOAT_EQ(back[0].confidence, 0.5);
  EXPECT_EQ(back[1].status, RegionStatus::kLost);
  EXPECT_TRUE(std::isnan(back[1].box.x));  // no estimate
  // A turned region: its extent goes out as the box, its own rectangle and
  // turn beside it, and both come back (to float32).
  RegionState c = RegionState::start(5, cv::Rect2d(100, 50, 80, 40), 1000.5);
  c.angle = 0.6;
  const instant_motion_tracking::TrackedRegion m = toMsg(c);
  EXPECT_NEAR(m.width, c.extent().width, 1e-4);
  EXPECT_GT(m.height, 60);  // the turned extent, taller than its own box (40) here
  EXPECT_FLOAT_EQ(m.angle, 0.6);
  EXPECT_FLOAT_EQ(m.rect_width, 80);
  const RegionState c2 = fromMsg(m, 1000.5);
  EXPECT_NEAR(c2.angle, 0.6, 1e-6);
  EXPECT_NEAR(c2.box.x, 100, 1e-4);
  EXPECT_NEAR(c2.box.width, 80, 1e-4);
  EXPECT_NEAR(c2.extent().width, c.extent().width, 1e-3);
  EXPECT_TRUE(std::isnan(toMsg(b).angle));
  instant_motion_tracking::TrackedRegion odd;
  odd.status = "teleported";
  EXPECT_EQ(fromMsg(odd, 0.0).status, RegionStatus::kLost);
}

TEST(TrackerOutputConversions, PlanarTargetsRoundTrip) {
  PlanarTargetState t;
  t.id = 2;
  t.corners = {cv::Point2d(1, 2), cv::Point2d(30, 2.5), cv::Point2d(31, 40), cv::Point2d(0.5, 41)};
  t.T_cam_target = pose();
  t.width_m = 0.5;
  t.height_m = 0.4;
  t.status = TargetStatus::kOutOfView;
  const std::vector<PlanarTargetState> back =
      fromMsg(toMsg(std::vector<PlanarTargetState>{t}, header(7.0)));
  ASSERT_EQ(back.size(), 1u);
  for (int i = 0; i < 4; ++i) EXPECT_EQ(back[0].corners[i], t.corners[i]);
  EXPECT_TRUE(back[0].T_cam_target.isApprox(t.T_cam_target, 1e-9));
  EXPECT_EQ(back[0].status, TargetStatus::kOutOfView);
  EXPECT_FLOAT_EQ(back[0].width_m, 0.5);
  // Every status comes back by its name (predicted is this package's own).
  for (TargetStatus st : {TargetStatus::kTracked, TargetStatus::kPredicted, TargetStatus::kOutOfView,
                          TargetStatus::kLost, TargetStatus::kNotFound}) {
    t.status = st;
    EXPECT_EQ(fromMsg(toMsg(std::vector<PlanarTargetState>{t}, header(7.0)))[0].status, st)
        << targetStatusName(st);
  }
  t.status = TargetStatus::kOutOfView;
  // A zero quaternion is no pose.
  instant_motion_tracking::PlanarTarget m = toMsg(t);
  m.pose.orientation = geometry_msgs::Quaternion();
  m.pose.orientation.w = 0;
  EXPECT_FALSE(fromMsg(m, 7.0).T_cam_target.matrix().allFinite());
}

TEST(TrackerOutputConversions, AnchorsRoundTrip) {
  AnchorState a;
  a.id = 9;
  a.pixel = cv::Point2d(100.25, 50.75);
  a.T_cam_anchor = pose();
  a.status = AnchorStatus::kNoImu;
  AnchorState lost = a;
  lost.status = AnchorStatus::kLost;
  const std::vector<AnchorState> back =
      fromMsg(toMsg(std::vector<AnchorState>{a, lost}, header(3.0)));
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(back[0].pixel, a.pixel);
  EXPECT_TRUE(back[0].T_cam_anchor.isApprox(a.T_cam_anchor, 1e-9));
  EXPECT_EQ(back[0].status, AnchorStatus::kNoImu);
  EXPECT_EQ(back[1].status, AnchorStatus::kLost);
  EXPECT_FALSE(back[1].T_cam_anchor.matrix().allFinite());  // NaN pose in the message
  EXPECT_TRUE(std::isnan(back[1].pixel.x));
}

}  // namespace
}  // namespace imt
