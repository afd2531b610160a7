// Rostest node: a generated `floor_walk` bag (images, camera_info, a 200 Hz
// IMU rotated relative to the camera, /tf_static) played through motion
// analysis and the AnchorNodelet (test/rostest/anchor_nodelet.test). An
// anchor is placed through add_anchor at a past frame on the scene's anchor
// point; the `anchors` topic and the tf2 frame anchor_1 are scored against
// the ground truth while the camera walks, yaws the anchor out of view and
// back. Bad requests must be refused with a message, the nodelet living on.
#include "instant_motion_tracking/AddAnchor.h"
#include "instant_motion_tracking/AnchorArray.h"
#include "instant_motion_tracking/RemoveRegion.h"
#include "instant_motion_tracking/core/anchor/anchor.h"

#include "rostest_util.h"

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <sensor_msgs/Imu.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>

namespace {

using instant_motion_tracking::AddAnchor;
using instant_motion_tracking::AnchorArray;
using instant_motion_tracking::RemoveRegion;

double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

Eigen::Quaterniond quat(const nlohmann::json& q) {
  return Eigen::Quaterniond(q[3], q[0], q[1], q[2]);
}
Eigen::Quaterniond quat(const geometry_msgs::Quaternion& q) {
  return Eigen::Quaterniond(q.w, q.x, q.y, q.z);
}

double angleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180 / M_PI;
}

AddAnchor request(ros::Time stamp, uint32_t id, float u, float v, float depth) {
  AddAnchor a;
  a.request.stamp = stamp;
  a.request.id = id;
  a.request.u = u;
  a.request.v = v;
  a.request.depth = depth;
  return a;
}

TEST(AnchorNodelet, AddedThroughTheServiceMatchesGroundTruthOnTopicAndTf) {
  // 8 s: the anchor leaves the view at 4.2 s and is back at 6.3 s.
  imt::test::SceneBag scene;
  std::string err;
  ASSERT_TRUE(imt::test::makeSceneBag("--preset floor_walk --duration 8 --seed 3", &scene, &err)) << err;
  const nlohmann::json& truth = scene.truth;
  const size_t n = scene.frames();
  ASSERT_EQ(n, 240u);
  const std::string frame_id = truth["frame_id"];
  auto stampOf = [&](size_t k) { return scene.stamp(k); };
  auto R_world_cam = [&](size_t k) {
    return quat(truth["frames"][k]["T_world_cam"]["q"]).toRotationMatrix();
  };
  std::map<ros::Time, size_t> frame_of = scene.frame_of;
  const std::string bag = scene.bag;

  ros::NodeHandle nh;
  tf2_ros::Buffer tf_buffer(ros::Duration(60));
  tf2_ros::TransformListener tf_listener(tf_buffer);
  std::vector<std::string> warnings;  // of the anchor tracker, from /rosout
  ros::Subscriber log_sub =
      nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000, [&](const rosgraph_msgs::LogConstPtr& m) {
        if (m->level >= rosgraph_msgs::Log::WARN && m->name.find("manager") != std::string::npos)
          warnings.push_back(m->msg);
      });
  ros::Publisher imu_pub = nh.advertise<sensor_msgs::Imu>("/imu/data", 10);
  ASSERT_TRUE(ros::service::waitForService("add_anchor", ros::Duration(60)));

  // Before any frame: refused, with a hint to retry. Nothing subscribes to
  // the nodelet's outputs yet (a tf-only user): the refusal itself must make
  // it subscribe to its inputs, else the bag would not start playing.
  AddAnchor early = request(ros::Time(0), 0, 100, 100, 0);
  ASSERT_TRUE(imt::test::callService("add_anchor", early));
  EXPECT_FALSE(early.response.success);
  EXPECT_NE(early.response.message.find("retry shortly"), std::string::npos)
      << early.response.message;
  EXPECT_TRUE(imt::test::spinUntil([&] { return imu_pub.getNumSubscribers() > 0; }, 10.0))
      << "the refused add_anchor should have subscribed the nodelet to imu";
  std::vector<AnchorArray> received;
  ros::Subscriber sub = nh.subscribe<AnchorArray>(
      "anchors", 1000,
      [&](const instant_motion_tracking::AnchorArrayConstPtr& m) { received.push_back(*m); });

  const pid_t player = imt::test::playTopics(
      bag, {"/camera/image_raw", "/camera/camera_info", "/imu/data", "/tf_static"});
  ASSERT_GT(player, 0);
  ASSERT_TRUE(imt::test::spinUntil([&] { return received.size() >= 20; }, 60.0))
      << received.size() << " frames";

  // The anchor, given at the first frame the nodelet saw (in the past by
  // now): the scene anchor's pixel there and its distance as the depth.
  ASSERT_TRUE(frame_of.count(received.front().header.stamp));
  const size_t k0 = frame_of[received.front().header.stamp];
  const nlohmann::json& a0 = truth["frames"][k0]["anchors"][0];
  const Eigen::Vector3d t0(a0["t"][0], a0["t"][1], a0["t"][2]);
  AddAnchor add = request(stampOf(k0), 1, a0["pixel"][0].get<double>(),
                          a0["pixel"][1].get<double>(), t0.norm());
  ASSERT_TRUE(imt::test::callService("add_anchor", add));
  ASSERT_TRUE(add.response.success) << add.response.message;
  EXPECT_EQ(add.response.id, 1u);

  // Bad requests: refused with a message that names the problem.
  struct Bad {
    AddAnchor req;
    const char* expected;
  };
  std::vector<Bad> bad = {
      {request(ros::Time(0), 1, 10, 10, 0), "anchor id 1 is already tracked"},
      {request(ros::Time(0), 0, NAN, 10, 0), "NaN"},
      {request(ros::Time(0), 0, 5000, 10, 0), "outside the 640x480 image"},
      {request(ros::Time(0), 0, 10, 10, -1), "depth must be positive"},
      {request(ros::Time(0), 0, 10, 10, NAN), "depth must be positive"},
      {request(ros::Time(5.0), 0, 10, 10, 0), "outside the motion-data cache"},
  };
  for (Bad& b : bad) {
    ASSERT_TRUE(imt::test::callService("add_anchor", b.req)) << "the service died on: " << b.expected;
    EXPECT_FALSE(b.req.response.success) << b.expected;
    EXPECT_NE(b.req.response.message.find(b.expected), std::string::npos) << b.req.response.message;
  }
  RemoveRegion rm;
  rm.request.id = 99;
  ASSERT_TRUE(imt::test::callService("remove_anchor", rm));
  EXPECT_FALSE(rm.response.success);
  EXPECT_EQ(rm.response.message, "unknown anchor id 99");
  // A second anchor (id chosen, default depth) comes and goes.
  AddAnchor second = request(ros::Time(0), 0, 320, 400, 0);
  ASSERT_TRUE(imt::test::callService("add_anchor", second));
  ASSERT_TRUE(second.response.success) << second.response.message;
  EXPECT_EQ(second.response.id, 2u);
  rm.request.id = 2;
  ASSERT_TRUE(imt::test::callService("remove_anchor", rm));
  EXPECT_TRUE(rm.response.success) << rm.response.message;

  // Bad IMU samples among the bag's: a NaN one and one from the past are
  // dropped with a warning; the anchor carries on (scored below).
  ASSERT_TRUE(imt::test::spinUntil([&] { return imu_pub.getNumSubscribers() > 0; }, 10.0));
  sensor_msgs::Imu bad_imu;
  bad_imu.header.frame_id = "imu_link";
  bad_imu.header.stamp = received.back().header.stamp;
  bad_imu.orientation_covariance[0] = -1;
  bad_imu.angular_velocity.x = NAN;
  imu_pub.publish(bad_imu);
  bad_imu.angular_velocity.x = 0;
  bad_imu.linear_acceleration.z = 9.81;
  // Behind the stream, but by less than anchors/imu_reset_seconds.
  bad_imu.header.stamp -= ros::Duration(0.5);
  imu_pub.publish(bad_imu);

  // Play to the end.
  const bool all = imt::test::spinUntil(
      [&] { return !received.empty() && received.back().header.stamp == stampOf(n - 1); }, 90.0);
  imt::test::spinUntil([] { return false; }, 0.5);
  imt::test::stopPlayer(player);
  ASSERT_TRUE(all) << received.size() << " of " << n;

  // Score anchor 1 on every frame after the add. Its frame: z up, x the
  // levelled viewing direction at k0 (the truth's own world, yaw-free).
  const Eigen::Matrix3d R_world_anchor = imt::anchorOrientation(R_world_cam(k0));
  std::vector<double> px, px_back, rot, range;
  int out_of_view = 0, far_out = 0, scored_tf = 0;
  bool was_out = false;
  double returned_at = -1;
  for (const AnchorArray& m : received) {
    if (!frame_of.count(m.header.stamp)) continue;
    const size_t k = frame_of[m.header.stamp];
    EXPECT_EQ(m.header.frame_id, frame_id);
    const auto it =
        std::find_if(m.anchors.begin(), m.anchors.end(), [](const auto& a) { return a.id == 1; });
    if (it == m.anchors.end()) continue;
    const instant_motion_tracking::Anchor& a = *it;
    ASSERT_NE(a.status, "lost") << "frame " << k;
    EXPECT_NE(a.status, "no_imu") << "frame " << k << ": the bag has an IMU and /tf_static";
    const nlohmann::json& t = truth["frames"][k]["anchors"][0];
    const cv::Point2d pixel(t["pixel"][0], t["pixel"][1]);
    if (!t["in_view"].get<bool>()) {
      was_out = true;
      // The anchor's region size: well outside the image beyond it.
      const double margin = 0.2 * 480;
      if (pixel.x < -margin || pixel.x > 640 + margin || pixel.y < -margin ||
          pixel.y > 480 + margin) {
        ++far_out;
        out_of_view += a.status == "out_of_view";
      }
      continue;
    }
    const double e = std::hypot(a.u - pixel.x, a.v - pixel.y);
    px.push_back(e);
    if (was_out && returned_at < 0) returned_at = m.header.stamp.toSec();
    if (returned_at >= 0 && m.header.stamp.toSec() - returned_at <= 1.0) px_back.push_back(e);
    const Eigen::Matrix3d R_expected = R_world_cam(k).transpose() * R_world_anchor;
    rot.push_back(angleDeg(quat(a.pose.orientation).toRotationMatrix(), R_expected));
    const Eigen::Vector3d p(a.pose.position.x, a.pose.position.y, a.pose.position.z);
    range.push_back(
        std::abs(p.norm() / Eigen::Vector3d(t["t"][0], t["t"][1], t["t"][2]).norm() - 1));
    // tf2: the same pose as the message, at the image stamp, child of the image frame.
    if (k % 10 == 0) {
      geometry_msgs::TransformStamped tf;
      try {
        tf = tf_buffer.lookupTransform(frame_id, "anchor_1", m.header.stamp);
      } catch (const tf2::TransformException& ex) {
        ADD_FAILURE() << "frame " << k << ": " << ex.what();
        continue;
      }
      EXPECT_NEAR(tf.transform.translation.x, a.pose.position.x, 1e-6) << "frame " << k;
      EXPECT_NEAR(tf.transform.translation.z, a.pose.position.z, 1e-6) << "frame " << k;
      EXPECT_LT(angleDeg(quat(tf.transform.rotation).toRotationMatrix(), R_expected), 1.0)
          << "frame " << k;
      ++scored_tf;
    }
  }
  std::fprintf(
      stderr, "AnchorNodelet on floor_walk: %zu frames in view, pixel median %.2f px, first second back "
      "%.2f px "
      "(%zu frames), orientation median %.3f deg, range median %.1f%%; out_of_view on %d of %d "
      "frames far "
      "outside; %d tf lookups\n",
      px.size(), median(px), median(px_back), px_back.size(), median(rot), 100 * median(range),
      out_of_view, far_out, scored_tf);
  // The bars: pixel median <= 3 px in view, <= 15 px over the first
  // second back in view, orientation median <= 1 degree.
  ASSERT_GT(px.size(), 100u);
  EXPECT_LE(median(px), 3.0);
  ASSERT_GT(px_back.size(), 10u) << "the anchor should leave the view and come back";
  EXPECT_LE(median(px_back), 15.0);
  EXPECT_LE(median(rot), 1.0);
  // Range: the 5% (measured 1.0% here, 7.7% before the
  // horizontal-surface correction of the region's scale).
  EXPECT_LE(median(range), 0.05);
  ASSERT_GT(far_out, 0);
  EXPECT_EQ(out_of_view, far_out);
  EXPECT_GT(scored_tf, 10);
  auto warned = [&](const std::string& what) {
    return std::any_of(warnings.begin(), warnings.end(),
                       [&](const std::string& w) { return w.find(what) != std::string::npos; });
  };
  EXPECT_TRUE(warned("dropping IMU sample: IMU sample with NaN/Inf"))
      << warnings.size() << " warnings";
  EXPECT_TRUE(warned("is not after the previous one")) << warnings.size() << " warnings";
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_anchor_nodelet");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
