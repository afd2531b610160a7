// Rostest node (test/rostest/replay_loop.test.in): launch/replay.launch plays a
// generated `cards` bag in a loop on sim time through the live graph
// (launch/tracking.launch). In each of two passes a region (card 2) and a
// planar target (the static patch 4) are added through the services at a past
// stamp. Checks:
//  - the second pass is tracked as well as the first (mean IoU against the
//    scene's ground truth, same frames);
//  - at the jump back every tracker resets (empty outputs), and each nodelet
//    logs it exactly once;
//  - a tf2_ros listener on sim time sees no TF_REPEATED_DATA, and every tf is
//    stamped with an image stamp.
#include "instant_motion_tracking/AddPlanarTarget.h"
#include "../box_metrics.h"
#include "instant_motion_tracking/AddRegion.h"
#include "instant_motion_tracking/PlanarTargetArray.h"
#include "instant_motion_tracking/TrackedRegionArray.h"

#include "rostest_util.h"

#include <console_bridge/console.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <ros/ros.h>
#include <rosgraph_msgs/Log.h>
#include <tf2_msgs/TFMessage.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <fstream>
#include <map>
#include <mutex>
#include <set>
#include <string>
#include <vector>

namespace {

using instant_motion_tracking::AddPlanarTarget;
using instant_motion_tracking::AddRegion;
using instant_motion_tracking::PlanarTargetArray;
using instant_motion_tracking::TrackedRegionArray;
using imt::test::spinUntil;

// Counts console_bridge warnings naming TF_REPEATED_DATA (tf2 reports them
// through console_bridge, from the listener's own thread).
class TfWarningCounter : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel, const char*, int) override {
    if (text.find("TF_REPEATED_DATA") != std::string::npos) ++repeated;
  }
  std::atomic<int> repeated{0};
};

cv::Rect2d clip(const cv::Rect2d& b) { return imt::test::clipToImage(b, cv::Size(640, 480)); }
using imt::test::iou;

struct Truth {
  nlohmann::json json;
  std::map<ros::Time, size_t> frame_of;
  size_t frames() const { return json["frames"].size(); }
  ros::Time stamp(size_t k) const { return ros::Time(json["frames"][k]["stamp"].get<double>()); }
  const nlohmann::json* region(size_t k, uint32_t id) const {
    for (const auto& r : json["frames"][k]["regions"])
      if (r["id"] == id) return &r;
    return nullptr;
  }
  cv::Rect2d box(size_t k, uint32_t id) const {
    const auto* r = region(k, id);
    return r ? cv::Rect2d((*r)["box"][0], (*r)["box"][1], (*r)["box"][2], (*r)["box"][3]) : cv::Rect2d();
  }
};

// Messages of one pass through the bag.
struct Pass {
  std::vector<TrackedRegionArray> regions;
  std::vector<PlanarTargetArray> targets;
};

TEST(ReplayLoop, SecondPassTrackedAsWellAsTheFirst) {
  ros::NodeHandle nh, pnh("~");
  std::string truth_path;
  ASSERT_TRUE(pnh.getParam("truth", truth_path));
  Truth truth;
  std::ifstream(truth_path) >> truth.json;
  const size_t n = truth.frames();
  ASSERT_EQ(n, 120u);
  for (size_t k = 0; k < n; ++k) truth.frame_of[truth.stamp(k)] = k;

  // The detector must be able to fail: a duplicate stamp in a plain buffer
  // is reported through the handler.
  TfWarningCounter tf_warnings;
  console_bridge::useOutputHandler(&tf_warnings);
  {
    tf2::BufferCore probe;
    geometry_msgs::TransformStamped t;
    t.header.frame_id = "a";
    t.child_frame_id = "b";
    t.header.stamp = ros::Time(1.0);
    t.transform.rotation.w = 1;
    probe.setTransform(t, "probe");
    probe.setTransform(t, "probe");
    ASSERT_EQ(tf_warnings.repeated, 1) << "TF_REPEATED_DATA is not seen through console_bridge";
    tf_warnings.repeated = 0;
  }
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);  // on sim time: clears on a jump back

  // Messages by pass: a stamp lower than the last one starts the next pass.
  std::mutex mutex;
  std::vector<Pass> passes(1);
  ros::Time last_stamp;
  auto passFor = [&](const ros::Time& stamp) -> Pass& {
    if (!last_stamp.isZero() && stamp < last_stamp) passes.emplace_back();
    last_stamp = stamp;
    return passes.back();
  };
  ros::Subscriber regions_sub = nh.subscribe<TrackedRegionArray>(
      "regions", 1000, [&](const instant_motion_tracking::TrackedRegionArrayConstPtr& m) {
        std::lock_guard<std::mutex> l(mutex);
        passFor(m->header.stamp).regions.push_back(*m);
      });
  // Planar targets by the stamp of the regions pass they belong to (the two
  // topics come from different nodelets; a stamp identifies the frame).
  std::vector<PlanarTargetArray> targets;
  ros::Subscriber targets_sub = nh.subscribe<PlanarTargetArray>(
      "planar_targets", 1000, [&](const instant_motion_tracking::PlanarTargetArrayConstPtr& m) {
        std::lock_guard<std::mutex> l(mutex);
        targets.push_back(*m);
      });
  std::set<std::string> tf_stamps_unknown;
  ros::Subscriber tf_sub = nh.subscribe<tf2_msgs::TFMessage>("/tf", 1000, [&](const tf2_msgs::TFMessageConstPtr& m) {
    for (const auto& t : m->transforms)
      if (!truth.frame_of.count(t.header.stamp)) tf_stamps_unknown.insert(t.child_frame_id);
  });
  // Reset logs per source file (each nodelet logs from its own file), read
  // from /rosout, where every node publishes its log.
  std::map<std::string, int> reset_logs;
  ros::Subscriber log_sub = nh.subscribe<rosgraph_msgs::Log>("/rosout", 1000, [&](const rosgraph_msgs::LogConstPtr& m) {
    if (m->msg.find("did not increase") != std::string::npos || m->msg.find("does not follow") != std::string::npos)
      ++reset_logs[m->file.substr(m->file.rfind('/') + 1)];
  });

  ASSERT_TRUE(ros::service::waitForService("add_region", ros::Duration(60)));
  ASSERT_TRUE(ros::service::waitForService("add_planar_target", ros::Duration(60)));
  // The lazy chain: regions wanted -> motion_data wanted -> image subscribed.
  ASSERT_TRUE(spinUntil([] { return imt::test::topicHasSubscriber("/camera/image_raw"); }, 60.0));
  spinUntil([] { return false; }, 1.0);  // the player connects to the new subscriber
  ASSERT_TRUE(imt::test::setPlayerPaused(false));

  const uint32_t kCard = 2, kPatch = 4;
  const size_t kGiven = 30;  // frame whose stamp the items are given at (in the past when added)
  auto framesIn = [&](size_t pass) {
    std::lock_guard<std::mutex> l(mutex);
    return passes.size() > pass ? passes[pass].regions.size() : 0;
  };
  auto addItems = [&](size_t pass) {
    SCOPED_TRACE("pass " + std::to_string(pass + 1));
    const cv::Rect2d b = truth.box(kGiven, kCard);
    AddRegion add;
    add.request.stamp = truth.stamp(kGiven);
    add.request.x = b.x;
    add.request.y = b.y;
    add.request.width = b.width;
    add.request.height = b.height;
    ASSERT_TRUE(imt::test::callService("add_region", add));
    ASSERT_TRUE(add.response.success) << add.response.message;
    // The static patch is a fronto-parallel rectangle: its box corners are
    // its corners (used for tf only; its accuracy is tested elsewhere). Given
    // at frame 10, where it is wholly in view.
    const size_t kPatchGiven = 10;
    AddPlanarTarget pt =
        imt::test::planarTargetRequest(truth.stamp(kPatchGiven), truth.box(kPatchGiven, kPatch), 0.5f, 0.4f);
    ASSERT_TRUE(imt::test::callService("add_planar_target", pt));
    ASSERT_TRUE(pt.response.success) << pt.response.message;
  };

  // Pass 1: add once frame 60 has gone by; pass 2: the same.
  ASSERT_TRUE(spinUntil([&] { return framesIn(0) >= 60; }, 60.0)) << framesIn(0) << " frames";
  addItems(0);
  ASSERT_TRUE(spinUntil([&] { return framesIn(1) >= 60; }, 60.0)) << "no second pass";
  addItems(1);
  // Until pass 2 ends (a third pass starts), then stop the player.
  ASSERT_TRUE(spinUntil([&] { return framesIn(2) > 0; }, 60.0)) << "pass 2 never ended";
  imt::test::setPlayerPaused(true);
  spinUntil([] { return false; }, 1.0);  // the last logs arrive

  std::lock_guard<std::mutex> l(mutex);
  // Mean IoU per pass over the same frames: after the add in both passes,
  // where the card is at least half in view.
  std::map<size_t, cv::Rect2d> boxes[2];
  for (int p = 0; p < 2; ++p) {
    const Pass& pass = passes[p];
    ASSERT_FALSE(pass.regions.empty());
    // At the jump back the tracker reset: the pass starts without regions.
    EXPECT_TRUE(pass.regions.front().regions.empty()) << "pass " << p + 1 << " began with regions";
    // Every frame of the pass was analysed (none dropped under load), so both
    // passes saw the same frames.
    EXPECT_EQ(pass.regions.size(), n) << "pass " << p + 1;
    EXPECT_EQ(pass.regions.front().header.stamp, truth.stamp(0)) << "pass " << p + 1;
    for (const auto& m : pass.regions) {
      if (m.regions.empty() || !truth.frame_of.count(m.header.stamp)) continue;
      const auto& r = m.regions[0];
      EXPECT_NE(r.status, "lost");
      boxes[p][truth.frame_of[m.header.stamp]] = cv::Rect2d(r.x, r.y, r.width, r.height);
    }
  }
  double sum[2] = {0, 0};
  int scored = 0;
  for (const auto& [k, box1] : boxes[0]) {
    if (!boxes[1].count(k) || (*truth.region(k, kCard))["visible_fraction"].get<double>() < 0.5) continue;
    const cv::Rect2d t = clip(truth.box(k, kCard));
    sum[0] += iou(clip(box1), t);
    sum[1] += iou(clip(boxes[1][k]), t);
    ++scored;
  }
  ASSERT_GT(scored, 30);
  const double iou1 = sum[0] / scored, iou2 = sum[1] / scored;
  RecordProperty("mean_iou_pass1", std::to_string(iou1));
  RecordProperty("mean_iou_pass2", std::to_string(iou2));
  std::printf("mean IoU over %d frames: pass 1 %.4f, pass 2 %.4f\n", scored, iou1, iou2);
  // Both passes meet the tracker's 0.85 bar (tracker_services.test; measured
  // 0.859 on these frames), and the second is as good as the first: the same
  // frames (checked above) through a reset analysis give the same motion
  // data. Measured difference 1e-4; 0.005 is far below what one dropped or
  // differently analysed frame costs (0.02 was seen when pass 1 lost its
  // first frames).
  EXPECT_NEAR(iou2, iou1, 0.005);

  // The planar tracker reset as well: its first output after the jump back
  // is empty, and it tracked the target in both passes.
  int jumps = 0, with_target[2] = {0, 0};
  ros::Time prev;
  for (const auto& m : targets) {
    const bool jump = !prev.isZero() && m.header.stamp < prev;
    prev = m.header.stamp;
    if (jump) {
      ++jumps;
      EXPECT_TRUE(m.targets.empty()) << "planar targets survived the jump back";
    }
    if (jumps < 2 && !m.targets.empty() && m.targets[0].status != "lost") ++with_target[jumps];
  }
  EXPECT_GE(jumps, 1);
  EXPECT_GT(with_target[0], 30);
  EXPECT_GT(with_target[1], 30);

  // Logged once per nodelet for the one jump back (pass 3 started right at
  // the end: a second jump may have been logged too, hence 1 or 2).
  for (const char* file : {"motion_analysis_nodelet.cpp", "region_tracker_nodelet.cpp", "planar_target_nodelet.cpp"}) {
    EXPECT_GE(reset_logs[file], 1) << file << " did not log the reset";
    EXPECT_LE(reset_logs[file], 2) << file << " logged the reset more than once per jump";
  }
  EXPECT_EQ(tf_warnings.repeated, 0) << "TF_REPEATED_DATA seen by a sim-time listener";
  EXPECT_TRUE(tf_stamps_unknown.empty()) << "tf not stamped with an image stamp: " << *tf_stamps_unknown.begin();
  EXPECT_TRUE(tf_buffer._frameExists("planar_target_1"));
  console_bridge::restorePreviousOutputHandler();
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_replay_loop");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
