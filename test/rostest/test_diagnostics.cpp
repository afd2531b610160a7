// Rostest node (test/rostest/diagnostics.test.in): launch/replay.launch plays a
// generated 30 fps `cards` bag (paused at first) through the live graph; a
// region and a planar target are added. /diagnostics must carry, per nodelet,
// the input rate, the processing time and the items by status.
#include "instant_motion_tracking/AddPlanarTarget.h"
#include "instant_motion_tracking/AddRegion.h"
#include "instant_motion_tracking/PlanarTargetArray.h"
#include "instant_motion_tracking/TrackedRegionArray.h"

#include "rostest_util.h"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <nodelet/NodeletUnload.h>
#include <ros/ros.h>

#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <string>

namespace {

using diagnostic_msgs::DiagnosticStatus;
using imt::test::spinUntil;

// The latest status of each name, with its values by key.
struct Diagnostics {
  std::map<std::string, DiagnosticStatus> latest;
  bool has(const std::string& name) const { return latest.count(name) > 0; }
  std::string value(const std::string& name, const std::string& key) const {
    if (!has(name)) return "";
    for (const auto& kv : latest.at(name).values)
      if (kv.key == key) return kv.value;
    return "";
  }
  double number(const std::string& name, const std::string& key) const {
    const std::string v = value(name, key);
    return v.empty() ? NAN : std::stod(v);
  }
};

TEST(Diagnostics, RatesLatencyAndItemsByStatus) {
  ros::NodeHandle nh, pnh("~");
  std::string truth_path;
  ASSERT_TRUE(pnh.getParam("truth", truth_path));
  nlohmann::json truth;
  std::ifstream(truth_path) >> truth;

  Diagnostics diag;
  ros::Subscriber sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 100, [&](const diagnostic_msgs::DiagnosticArrayConstPtr& m) {
        for (const auto& s : m->status) diag.latest[s.name] = s;
      });
  size_t frames = 0;
  ros::Subscriber regions = nh.subscribe<instant_motion_tracking::TrackedRegionArray>(
      "regions", 100, [&](const instant_motion_tracking::TrackedRegionArrayConstPtr&) { ++frames; });
  // The planar tracker is lazy too: its output is wanted before the target
  // is added, so its cache holds the frame the target is given at.
  size_t target_msgs = 0;
  ros::Subscriber targets = nh.subscribe<instant_motion_tracking::PlanarTargetArray>(
      "planar_targets", 100, [&](const instant_motion_tracking::PlanarTargetArrayConstPtr&) { ++target_msgs; });
  ASSERT_TRUE(spinUntil([] { return imt::test::topicHasSubscriber("/camera/image_raw"); }, 60.0));
  spinUntil([] { return false; }, 1.0);  // the player connects to the new subscriber

  // Subscribed but paused: the input is reported missing (WARN), after at
  // most two periods (1 s default).
  const std::string input = "motion_analysis: input";
  diag.latest.clear();
  ASSERT_TRUE(spinUntil([&] { return diag.has(input) && diag.value(input, "subscribed") == "True"; }, 10.0))
      << "no diagnostics from the motion analysis";
  EXPECT_EQ(diag.latest[input].level, DiagnosticStatus::WARN);
  EXPECT_NE(diag.latest[input].message.find("no input"), std::string::npos) << diag.latest[input].message;

  ASSERT_TRUE(imt::test::setPlayerPaused(false));
  ASSERT_TRUE(spinUntil([&] { return frames >= 20; }, 30.0));
  // A region (card 2) and a planar target (the static patch 4) at frame 10.
  const auto& f10 = truth["frames"][10];
  const ros::Time stamp(f10["stamp"].get<double>());
  instant_motion_tracking::AddRegion add;
  add.request.stamp = stamp;
  add.request.x = f10["regions"][1]["box"][0];
  add.request.y = f10["regions"][1]["box"][1];
  add.request.width = f10["regions"][1]["box"][2];
  add.request.height = f10["regions"][1]["box"][3];
  // As the other rostests: the services are waited for before the first call.
  ASSERT_TRUE(ros::service::waitForService("add_region", ros::Duration(30)));
  ASSERT_TRUE(ros::service::waitForService("add_planar_target", ros::Duration(30)));
  ASSERT_TRUE(imt::test::callService("add_region", add));
  ASSERT_TRUE(add.response.success) << add.response.message;
  const auto& p = f10["regions"][3]["box"];
  auto pt = imt::test::planarTargetRequest(stamp, cv::Rect2d(p[0], p[1], p[2], p[3]), 0.5f, 0.4f);
  ASSERT_TRUE(imt::test::callService("add_planar_target", pt));
  ASSERT_TRUE(pt.response.success) << pt.response.message;

  // Two full periods of playback after the adds (the bag lasts 4 s).
  diag.latest.clear();
  spinUntil([] { return false; }, 2.2);
  for (const char* name : {"motion_analysis: input", "motion_analysis: processing", "region_tracker: input",
                           "region_tracker: processing", "region_tracker: regions", "planar_targets: input",
                           "planar_targets: processing", "planar_targets: planar targets"}) {
    ASSERT_TRUE(diag.has(name)) << name;
  }
  // Input rates: the bag's 30 fps at rate 1. A period of 1 s wall time counts
  // 29-31 frames; a frame batch delayed by a loaded machine lands in the next
  // period: 41.2 Hz was measured with test_core running beside it (ctest -j2,
  // 2026-11-26). 20-60 still catches a rate in the wrong unit or never counted.
  for (const char* nodelet : {"motion_analysis", "region_tracker", "planar_targets"}) {
    const std::string name = std::string(nodelet) + ": input";
    const double rate = diag.number(name, "rate (Hz)");
    EXPECT_GE(rate, 20.0) << name;
    EXPECT_LE(rate, 60.0) << name;
    EXPECT_EQ(diag.latest[name].level, DiagnosticStatus::OK) << name << ": " << diag.latest[name].message;
    EXPECT_EQ(diag.value(name, "topic"), std::string(nodelet) == "motion_analysis" ? "/camera/image_raw" : "/motion_data");
    // The time rules' outcomes (README), and camera_info refused: none on a
    // clean bag, but counted.
    for (const char* key : {"dropped", "resets", "gaps", "camera_info refused"})
      EXPECT_EQ(diag.value(name, key), "0") << name << " " << key;
    // Processing: a frame takes ~2 ms here, ~9 ms in the planar tracker
    // (README). Speed is the benchmarks' business, not a test's (a loaded CI
    // machine once measured 40 ms): above 0 and below 1 s only catches a
    // value in the wrong unit or never measured. Delay after the stamp:
    // replay.launch's /clock ticks at 1 kHz, so a few ms; 0.5 s catches stamps
    // that are not the image's.
    const std::string proc = std::string(nodelet) + ": processing";
    EXPECT_GT(diag.number(proc, "processing mean (ms)"), 0.0) << proc;
    EXPECT_LT(diag.number(proc, "processing mean (ms)"), 1000.0) << proc;
    EXPECT_LT(std::abs(diag.number(proc, "delay after the image stamp mean (ms)")), 500.0) << proc;
  }
  // Items by status: one region and one target, none lost; every status is listed.
  EXPECT_EQ(diag.number("region_tracker: regions", "total"), 1.0);
  EXPECT_EQ(diag.number("region_tracker: regions", "lost"), 0.0);
  EXPECT_EQ(diag.number("region_tracker: regions", "tracked") + diag.number("region_tracker: regions", "featureless") +
                diag.number("region_tracker: regions", "out_of_view"),
            1.0);
  EXPECT_EQ(diag.number("planar_targets: planar targets", "total"), 1.0);
  EXPECT_EQ(diag.number("planar_targets: planar targets", "lost"), 0.0);
  EXPECT_FALSE(std::isnan(diag.number("planar_targets: planar targets", "out_of_view")));
  EXPECT_GT(target_msgs, 0u);
  // The anchors' IMU-to-camera rotation: the bag's /tf_static gives it once
  // the IMU flows: "tf (video: ...)", what the video shows of it beside.
  ASSERT_TRUE(diag.has("anchor_tracker: anchors"));
  const std::string rotation = diag.value("anchor_tracker: anchors", "IMU-to-camera rotation");
  std::printf("anchor_tracker: IMU-to-camera rotation: %s\n", rotation.c_str());
  EXPECT_EQ(rotation.rfind("tf (video: ", 0), 0u) << rotation;

  // graph_watchdog: every nodelet loaded and working ...
  for (const char* nodelet : {"motion_analysis", "region_tracker", "planar_targets", "anchor_tracker"}) {
    const std::string name = std::string("graph_watchdog: ") + nodelet;
    ASSERT_TRUE(diag.has(name)) << name;
    EXPECT_EQ(diag.latest[name].level, DiagnosticStatus::OK) << name << ": " << diag.latest[name].message;
  }
  // ... until one is unloaded behind its back (as a broken bond does): ERROR
  // within a few periods (1 s each), naming it; the others stay OK.
  // An unload is not to be repeated: CI met its answer lost with the unload
  // done (2026-12-01), and the repeat then failed on the missing nodelet. So
  // it is called once, and what counts is the manager's list afterwards.
  nodelet::NodeletUnload unload;
  unload.request.name = "/planar_targets";
  if (!ros::service::call("/imt_manager/unload_nodelet", unload) || !unload.response.success)
    ROS_WARN("/imt_manager/unload_nodelet: no answer of success; asking the manager's list");
  std::set<std::string> loaded;
  ASSERT_TRUE(imt::test::loadedNodelets("/imt_manager", &loaded)) << "the manager does not answer";
  ASSERT_EQ(loaded.count("/planar_targets"), 0u) << "/planar_targets is still loaded";
  const std::string gone = "graph_watchdog: planar_targets";
  diag.latest.clear();
  EXPECT_TRUE(spinUntil([&] { return diag.has(gone) && diag.latest[gone].level == DiagnosticStatus::ERROR; }, 5.0))
      << (diag.has(gone) ? diag.latest[gone].message : "no verdict");
  EXPECT_NE(diag.latest[gone].message.find("not loaded"), std::string::npos) << diag.latest[gone].message;
  ASSERT_TRUE(diag.has("graph_watchdog: region_tracker"));
  EXPECT_EQ(diag.latest["graph_watchdog: region_tracker"].level, DiagnosticStatus::OK)
      << diag.latest["graph_watchdog: region_tracker"].message;
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_diagnostics");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
