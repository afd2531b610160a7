// Rostest node: a generated `poster_orbit` bag (a poster on a textured wall,
// the camera orbiting it: oblique views, in-plane rotation, scale change,
// brightness change) played through motion analysis and the
// PlanarTargetNodelet (test/rostest/planar_target_nodelet.test). The poster
// is added through add_planar_target at a past frame with its ground-truth
// corners and size; the planar_targets topic and the tf2 frame
// planar_target_<id> are scored against the ground truth. Bad requests must
// be refused with a message, the nodelet living on.
#include "instant_motion_tracking/AddImageTarget.h"
#include "instant_motion_tracking/AddPlanarTarget.h"
#include "instant_motion_tracking/PlanarTargetArray.h"
#include "instant_motion_tracking/RemoveRegion.h"
#include "instant_motion_tracking/sim/scene.h"

#include "rostest_util.h"

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>
#include <Eigen/Geometry>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <string>

namespace {

using instant_motion_tracking::AddImageTarget;
using instant_motion_tracking::AddPlanarTarget;
using instant_motion_tracking::PlanarTargetArray;
using instant_motion_tracking::RemoveRegion;

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * v.size()))];
}

Eigen::Quaterniond quat(const nlohmann::json& q) { return Eigen::Quaterniond(q[3], q[0], q[1], q[2]); }
Eigen::Quaterniond quat(const geometry_msgs::Quaternion& q) { return Eigen::Quaterniond(q.w, q.x, q.y, q.z); }

AddPlanarTarget request(ros::Time stamp, uint32_t id, const nlohmann::json& corners, float w, float h) {
  AddPlanarTarget a;
  a.request.stamp = stamp;
  a.request.id = id;
  for (int i = 0; i < 4; ++i) {
    a.request.corners[i].x = corners[i][0].get<float>();
    a.request.corners[i].y = corners[i][1].get<float>();
  }
  a.request.width_m = w;
  a.request.height_m = h;
  return a;
}

TEST(PlanarTargetNodelet, PosterAddedThroughTheServiceMatchesGroundTruthOnTopicAndTf) {
  // 8 s of the 20 s orbit: oblique views up to ~40 degrees and a brightness swing.
  imt::test::SceneBag scene;
  std::string why;
  ASSERT_TRUE(imt::test::makeSceneBag("--preset poster_orbit --duration 8 --seed 4", &scene, &why)) << why;
  const nlohmann::json& truth = scene.truth;
  const size_t n = scene.frames();
  ASSERT_EQ(n, 240u);
  const std::string frame_id = truth["frame_id"];
  auto stampOf = [&](size_t k) { return scene.stamp(k); };
  std::map<ros::Time, size_t> frame_of = scene.frame_of;
  const std::string bag = scene.bag;

  ros::NodeHandle nh;
  tf2_ros::Buffer tf_buffer(ros::Duration(60));
  tf2_ros::TransformListener tf_listener(tf_buffer);
  ASSERT_TRUE(ros::service::waitForService("add_planar_target", ros::Duration(60)));
  std::vector<PlanarTargetArray> received;
  ros::Subscriber sub = nh.subscribe<PlanarTargetArray>(
      "planar_targets", 1000, [&](const instant_motion_tracking::PlanarTargetArrayConstPtr& m) {
        received.push_back(*m);
      });
  const pid_t player = imt::test::playTopics(bag, {"/camera/image_raw", "/camera/camera_info"});
  ASSERT_GT(player, 0);
  ASSERT_TRUE(imt::test::spinUntil([&] { return received.size() >= 15; }, 60.0)) << received.size() << " frames";

  // The poster, given at the first frame the nodelet saw (in the past by now).
  ASSERT_TRUE(frame_of.count(received.front().header.stamp));
  const size_t k0 = frame_of[received.front().header.stamp];
  const nlohmann::json& t0 = truth["frames"][k0]["planar_targets"][0];
  AddPlanarTarget add = request(stampOf(k0), 0, t0["corners"], t0["size"][0], t0["size"][1]);
  ASSERT_TRUE(imt::test::callService("add_planar_target", add));
  ASSERT_TRUE(add.response.success) << add.response.message;
  const uint32_t id = add.response.id;
  // Frames published before the add carry no target (it is tracked through
  // the cache from k0 to the present, then live).
  ASSERT_TRUE(frame_of.count(received.back().header.stamp));
  const size_t k_added = frame_of[received.back().header.stamp];
  const std::string child = "planar_target_" + std::to_string(id);

  // Bad requests: refused with a message that names the problem.
  const nlohmann::json bowtie = {{100, 100}, {200, 200}, {200, 100}, {100, 200}};
  const nlohmann::json line = {{100, 100}, {200, 100}, {300, 100}, {150, 100}};
  struct Bad {
    AddPlanarTarget req;
    const char* expected;
  };
  std::vector<Bad> bad = {
      {request(ros::Time(0), 0, bowtie, 0.3f, 0.2f), "convex"},
      {request(ros::Time(0), 0, line, 0.3f, 0.2f), "collinear"},
      {request(ros::Time(0), 0, t0["corners"], -0.3f, 0.2f), "must be positive"},
      {request(ros::Time(0), 0, t0["corners"], 0.3f, NAN), "must be positive"},
      {request(ros::Time(0), id, t0["corners"], 0.3f, 0.2f), "already tracked"},
      {request(ros::Time(5.0), 0, t0["corners"], 0.3f, 0.2f), "outside the motion-data cache"},
  };
  for (Bad& b : bad) {
    ASSERT_TRUE(imt::test::callService("add_planar_target", b.req)) << "the service died on: " << b.expected;
    EXPECT_FALSE(b.req.response.success) << b.expected;
    EXPECT_NE(b.req.response.message.find(b.expected), std::string::npos) << b.req.response.message;
  }
  RemoveRegion rm;
  rm.request.id = 99;
  ASSERT_TRUE(imt::test::callService("remove_planar_target", rm));
  EXPECT_FALSE(rm.response.success);
  EXPECT_NE(rm.response.message.find("99"), std::string::npos) << rm.response.message;

  const bool all = imt::test::spinUntil(
      [&] { return !received.empty() && received.back().header.stamp == stampOf(n - 1); }, 90.0);
  imt::test::spinUntil([] { return false; }, 0.5);
  imt::test::stopPlayer(player);
  ASSERT_TRUE(all) << received.size() << " of " << n;

  std::vector<double> err, rot, trans;
  int scored_tf = 0;
  for (const PlanarTargetArray& m : received) {
    if (!frame_of.count(m.header.stamp) || m.targets.empty()) continue;
    const size_t k = frame_of[m.header.stamp];
    if (k <= k0) continue;
    EXPECT_EQ(m.header.frame_id, frame_id);
    const instant_motion_tracking::PlanarTarget& p = m.targets[0];
    ASSERT_EQ(p.id, id);
    EXPECT_EQ(p.status, "tracked") << "frame " << k;
    const nlohmann::json& t = truth["frames"][k]["planar_targets"][0];
    double sq = 0;
    for (int c = 0; c < 4; ++c)
      sq += std::pow(p.corners[c].x - t["corners"][c][0].get<double>(), 2) +
            std::pow(p.corners[c].y - t["corners"][c][1].get<double>(), 2);
    err.push_back(std::sqrt(sq / 4));
    const Eigen::Quaterniond q_true = quat(t["q"]);
    rot.push_back(q_true.angularDistance(quat(p.pose.orientation)) * 180 / M_PI);
    const Eigen::Vector3d t_true(t["t"][0], t["t"][1], t["t"][2]);
    trans.push_back((Eigen::Vector3d(p.pose.position.x, p.pose.position.y, p.pose.position.z) - t_true).norm() /
                    t_true.norm());
    // tf2: the message's pose at the image stamp, child of the image frame.
    if (k % 10 == 0) {
      geometry_msgs::TransformStamped tf;
      try {
        tf = tf_buffer.lookupTransform(frame_id, child, m.header.stamp);
      } catch (const tf2::TransformException& ex) {
        ADD_FAILURE() << "frame " << k << ": " << ex.what();
        continue;
      }
      EXPECT_NEAR(tf.transform.translation.x, p.pose.position.x, 1e-6) << "frame " << k;
      EXPECT_NEAR(tf.transform.translation.z, p.pose.position.z, 1e-6) << "frame " << k;
      EXPECT_LT(quat(tf.transform.rotation).angularDistance(quat(p.pose.orientation)), 1e-5) << "frame " << k;
      ++scored_tf;
    }
  }
  std::fprintf(stderr, "PlanarTargetNodelet on poster_orbit: %zu frames, corner error median %.3f p95 %.3f last %.3f px, "
              "rotation median %.3f deg, translation median %.3f%%; %d tf lookups\n",
              err.size(), percentile(err, 0.5), percentile(err, 0.95), err.empty() ? NAN : err.back(),
              percentile(rot, 0.5), 100 * percentile(trans, 0.5), scored_tf);
  // Every frame after the add, live: the published stream must be complete.
  ASSERT_GE(err.size(), n - k_added - 2);
  // The bars (alignment median <= 0.5 px, p95 <= 1.5 px, the last
  // frame <= 1.0 px, rotation median <= 0.5 deg, translation <= 1%); the
  // same scene in the core measures ~0.02 px, so a frame tracked without its
  // image (a late image) may cost accuracy but not these.
  EXPECT_LE(percentile(err, 0.5), 0.5);
  EXPECT_LE(percentile(err, 0.95), 1.5);
  EXPECT_LE(err.back(), 1.0);
  EXPECT_LE(percentile(rot, 0.5), 0.5);
  EXPECT_LE(percentile(trans, 0.5), 0.01);
  EXPECT_GT(scored_tf, 10);

  // Removed: the next frames carry no target.
  rm.request.id = id;
  ASSERT_TRUE(imt::test::callService("remove_planar_target", rm));
  EXPECT_TRUE(rm.response.success) << rm.response.message;
}

// The poster painted from a picture (make_scene --target-texture) and given
// through add_image_target as a sensor_msgs/Image: found within the issue's
// 0.5 s, then tracked. The previous test's bag ended; this one starts at the
// same stamps, so the graph resets first (time going backwards).
TEST(PlanarTargetNodelet, ImageTargetFoundThroughTheService) {
  char tmpl[] = "/tmp/imt_image_target_XXXXXX";
  ASSERT_TRUE(mkdtemp(tmpl));
  const std::string dir = tmpl, png = dir + "/poster.png";
  const cv::Mat picture = imt::proceduralTexture(1024, 7)(cv::Rect(0, 0, 1024, 768)).clone();
  ASSERT_TRUE(cv::imwrite(png, picture));
  imt::test::SceneBag scene;
  std::string why;
  ASSERT_TRUE(imt::test::makeSceneBag("--preset poster_orbit --duration 4 --seed 4 --target-texture " + png, &scene,
                                      &why))
      << why;
  const size_t n = scene.frames();
  ros::NodeHandle nh;
  ASSERT_TRUE(ros::service::waitForService("add_image_target", ros::Duration(60)));
  std::vector<PlanarTargetArray> received;
  ros::Subscriber sub = nh.subscribe<PlanarTargetArray>(
      "planar_targets", 1000, [&](const instant_motion_tracking::PlanarTargetArrayConstPtr& m) {
        if (scene.frame_of.count(m->header.stamp)) received.push_back(*m);
      });
  const pid_t player = imt::test::playTopics(scene.bag, {"/camera/image_raw", "/camera/camera_info"});
  ASSERT_GT(player, 0);
  ASSERT_TRUE(imt::test::spinUntil([&] { return received.size() >= 5; }, 60.0)) << received.size() << " frames";

  // Bad requests: refused with a message that names the problem.
  AddImageTarget add;
  add.request.width_m = 0.6f;
  add.request.height_m = 0.45f;
  ASSERT_TRUE(imt::test::callService("add_image_target", add));
  EXPECT_FALSE(add.response.success);
  EXPECT_NE(add.response.message.find("no picture"), std::string::npos) << add.response.message;
  add.request.image_path = dir + "/missing.png";
  ASSERT_TRUE(imt::test::callService("add_image_target", add));
  EXPECT_FALSE(add.response.success);
  EXPECT_NE(add.response.message.find("cannot read image"), std::string::npos) << add.response.message;
  add.request.image_path = "";
  add.request.image.encoding = "bogus";
  add.request.image.width = add.request.image.height = add.request.image.step = 4;
  add.request.image.data.assign(16, 0);
  ASSERT_TRUE(imt::test::callService("add_image_target", add));
  EXPECT_FALSE(add.response.success);
  EXPECT_NE(add.response.message.find("bogus"), std::string::npos) << add.response.message;

  // The picture as a message, at the latest frame.
  add.request.image.encoding = "mono8";
  add.request.image.width = picture.cols;
  add.request.image.height = picture.rows;
  add.request.image.step = picture.cols;
  add.request.image.data.assign(picture.data, picture.data + picture.total());
  ASSERT_TRUE(imt::test::callService("add_image_target", add));
  ASSERT_TRUE(add.response.success) << add.response.message;
  const uint32_t id = add.response.id;
  const size_t k_added = scene.frame_of[received.back().header.stamp];

  const bool all = imt::test::spinUntil(
      [&] { return !received.empty() && received.back().header.stamp == scene.stamp(n - 1); }, 90.0);
  imt::test::spinUntil([] { return false; }, 0.5);
  imt::test::stopPlayer(player);
  ASSERT_TRUE(all) << received.size() << " of " << n;

  int found = -1;
  std::vector<double> err;
  for (const PlanarTargetArray& m : received) {
    const size_t k = scene.frame_of[m.header.stamp];
    if (k <= k_added || m.targets.empty()) continue;
    const instant_motion_tracking::PlanarTarget& p = m.targets[0];
    ASSERT_EQ(p.id, id);
    if (p.status == "not_found") {
      EXPECT_LT(found, 0) << "frame " << k << ": not_found after it was found";
      continue;
    }
    if (found < 0) found = static_cast<int>(k);
    EXPECT_EQ(p.status, "tracked") << "frame " << k;
    const nlohmann::json& t = scene.frame(k)["planar_targets"][0];
    double sq = 0;
    for (int c = 0; c < 4; ++c)
      sq += std::pow(p.corners[c].x - t["corners"][c][0].get<double>(), 2) +
            std::pow(p.corners[c].y - t["corners"][c][1].get<double>(), 2);
    err.push_back(std::sqrt(sq / 4));
  }
  std::fprintf(stderr, "PlanarTargetNodelet image target: added at frame %zu, found at %d; %zu frames, corner error "
                       "median %.3f px, last %.3f px\n",
               k_added, found, err.size(), percentile(err, 0.5), err.empty() ? NAN : err.back());
  ASSERT_GE(found, 0) << "never found";
  // The poster is in view when given: found within the 0.5 s (15
  // frames at 30 frames/s).
  EXPECT_LE(found - static_cast<int>(k_added), 15);
  // The bars of the target given by its corners above (the core measures
  // ~0.02 px on this scene; a frame whose image comes late costs accuracy).
  EXPECT_LE(percentile(err, 0.5), 0.5);
  EXPECT_LE(err.back(), 1.0);

  RemoveRegion rm;
  rm.request.id = id;
  ASSERT_TRUE(imt::test::callService("remove_planar_target", rm));
  EXPECT_TRUE(rm.response.success) << rm.response.message;
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_planar_target_nodelet");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
