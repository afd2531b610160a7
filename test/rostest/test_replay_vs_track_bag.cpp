// Rostest node (test/rostest/replay_vs_track_bag.test.in): launch/replay.launch
// plays a generated `cards` bag once on sim time through the live graph.
// Mid-stream a region is added through add_region at a past stamp; the live
// `regions` output (frames after the add) and seek_regions (every earlier
// frame, backwards from the given one) are compared with track_bag run on the
// same bag with the same INIT entry.
#include "instant_motion_tracking/AddRegion.h"
#include "instant_motion_tracking/SeekRegions.h"
#include "instant_motion_tracking/TrackedRegionArray.h"

#include "rostest_util.h"

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <ros/ros.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

namespace {

using instant_motion_tracking::AddRegion;
using instant_motion_tracking::SeekRegions;
using instant_motion_tracking::TrackedRegionArray;
using imt::test::spinUntil;

struct Box {
  double x = NAN, y = NAN, w = NAN, h = NAN;
  std::string status;
};

// regions.csv of track_bag: stamp,id,x,y,width,height,status,confidence.
std::map<std::string, Box> readRegionsCsv(const std::string& path, uint32_t id) {
  std::map<std::string, Box> rows;  // by stamp text with 6 decimals
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) f.push_back(cell);
    if (f.size() < 7 || std::stoul(f[1]) != id) continue;
    Box b;
    auto num = [](const std::string& s) { return s.empty() ? NAN : std::stod(s); };
    b.x = num(f[2]);
    b.y = num(f[3]);
    b.w = num(f[4]);
    b.h = num(f[5]);
    b.status = f[6];
    char key[32];
    std::snprintf(key, sizeof key, "%.6f", std::stod(f[0]));
    rows[key] = b;
  }
  return rows;
}

std::string key(const ros::Time& t) {
  char k[32];
  std::snprintf(k, sizeof k, "%.6f", t.toSec());
  return k;
}

Box fromMsg(const instant_motion_tracking::TrackedRegion& r) {
  Box b;
  b.x = r.x;
  b.y = r.y;
  b.w = r.width;
  b.h = r.height;
  b.status = r.status;
  return b;
}

// Largest coordinate difference (0 when both have no box, inf when one has).
double boxDifference(const Box& a, const Box& b) {
  const double va[4] = {a.x, a.y, a.w, a.h}, vb[4] = {b.x, b.y, b.w, b.h};
  double d = 0;
  for (int i = 0; i < 4; ++i) {
    if (std::isnan(va[i]) && std::isnan(vb[i])) continue;
    if (std::isnan(va[i]) || std::isnan(vb[i])) return INFINITY;
    d = std::max(d, std::abs(va[i] - vb[i]));
  }
  return d;
}

TEST(ReplayVsTrackBag, LiveRegionsAgreeWithTrackBag) {
  ros::NodeHandle nh, pnh("~");
  std::string bag, truth_path;
  ASSERT_TRUE(pnh.getParam("bag", bag));
  ASSERT_TRUE(pnh.getParam("truth", truth_path));
  nlohmann::json truth;
  std::ifstream(truth_path) >> truth;
  const size_t n = truth["frames"].size();
  ASSERT_EQ(n, 120u);
  auto stampOf = [&](size_t k) { return ros::Time(truth["frames"][k]["stamp"].get<double>()); };

  std::vector<TrackedRegionArray> received;
  ros::Subscriber sub = nh.subscribe<TrackedRegionArray>(
      "regions", 1000, [&](const instant_motion_tracking::TrackedRegionArrayConstPtr& m) { received.push_back(*m); });
  ASSERT_TRUE(ros::service::waitForService("add_region", ros::Duration(60)));
  ASSERT_TRUE(spinUntil([] { return imt::test::topicHasSubscriber("/camera/image_raw"); }, 60.0));
  spinUntil([] { return false; }, 1.0);  // the player connects to the new subscriber
  ASSERT_TRUE(imt::test::setPlayerPaused(false));

  // Card 2 at frame 30, added once frame 60 has gone by.
  ASSERT_TRUE(spinUntil([&] { return received.size() >= 60; }, 60.0)) << received.size() << " frames";
  const size_t kGiven = 30;
  const auto& box = truth["frames"][kGiven]["regions"][1]["box"];
  ASSERT_EQ(truth["frames"][kGiven]["regions"][1]["id"], 2);
  AddRegion add;
  add.request.stamp = stampOf(kGiven);
  add.request.id = 7;
  add.request.x = box[0].get<float>();
  add.request.y = box[1].get<float>();
  add.request.width = box[2].get<float>();
  add.request.height = box[3].get<float>();
  ASSERT_TRUE(ros::service::call("add_region", add));
  ASSERT_TRUE(add.response.success) << add.response.message;
  const size_t frames_at_add = received.size();

  const bool all = spinUntil([&] { return received.size() >= n; }, 60.0);
  spinUntil([] { return false; }, 0.5);
  ASSERT_TRUE(all) << received.size() << " of " << n << " frames";
  // Every image was processed: nothing dropped, so live and offline saw the
  // same frames (a dropped frame would be a real difference, not a bug).
  EXPECT_EQ(received.size(), n);

  // Live states: the topic after the add, seek_regions for every earlier frame.
  std::map<std::string, Box> live;
  size_t from_topic = 0;
  for (size_t i = frames_at_add; i < received.size(); ++i) {
    if (received[i].regions.empty()) continue;
    live[key(received[i].header.stamp)] = fromMsg(received[i].regions[0]);
    ++from_topic;
  }
  size_t seeks = 0;
  for (size_t k = 0; k < n; ++k) {
    if (live.count(key(stampOf(k)))) continue;
    SeekRegions seek;
    seek.request.stamp = stampOf(k);
    ASSERT_TRUE(ros::service::call("seek_regions", seek));
    ASSERT_TRUE(seek.response.success) << "frame " << k << ": " << seek.response.message;
    ASSERT_EQ(seek.response.regions.regions.size(), 1u);
    live[key(stampOf(k))] = fromMsg(seek.response.regions.regions[0]);
    ++seeks;
  }
  EXPECT_GT(from_topic, 40u);
  EXPECT_GT(seeks, 30u);

  // track_bag with the same entry (the request's float values, the stamp exact).
  char tmpl[] = "/tmp/imt_replay_vs_track_bag_XXXXXX";
  const std::string dir = mkdtemp(tmpl) ? tmpl : "";
  ASSERT_FALSE(dir.empty());
  {
    std::ofstream init(dir + "/init.yaml");
    char line[256];
    std::snprintf(line, sizeof line, "regions:\n  - id: 7\n    stamp: %.9f\n    box: [%.9g, %.9g, %.9g, %.9g]\n",
                  stampOf(kGiven).toSec(), add.request.x, add.request.y, add.request.width, add.request.height);
    init << line;
  }
  const std::string cmd = std::string(IMT_BIN_DIR) + "/track_bag --quiet --bag " + bag + " --init " + dir +
                          "/init.yaml --out-dir " + dir + " > " + dir + "/track_bag.log 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  const std::map<std::string, Box> offline = readRegionsCsv(dir + "/regions.csv", 7);
  ASSERT_EQ(offline.size(), n);

  double worst = 0;
  std::string worst_at;
  int status_mismatches = 0;
  for (const auto& [stamp, b] : live) {
    ASSERT_TRUE(offline.count(stamp)) << "track_bag has no row at " << stamp;
    const Box& o = offline.at(stamp);
    if (b.status != o.status) ++status_mismatches;
    const double d = boxDifference(b, o);
    if (d > worst) worst = d, worst_at = stamp;
  }
  std::printf("live vs track_bag over %zu frames (%zu from the topic, %zu by seek): worst box difference %.2g px at %s\n",
              live.size(), from_topic, seeks, worst, worst_at.c_str());
  RecordProperty("worst_box_difference_px", std::to_string(worst));
  // The same core code on the same frames (none dropped: checked above), so
  // the states agree up to the float32 of the messages (MotionData features,
  // TrackedRegion boxes: ~3e-5 px at 640 px). Measured worst 1.5e-5 px over
  // the 120 frames; 1e-3 px leaves room for that rounding to move one IRLS
  // weight, and still fails on any real divergence (a dropped or differently
  // analysed frame moves the box by a pixel or more).
  EXPECT_LT(worst, 1e-3) << "at " << worst_at;
  EXPECT_EQ(status_mismatches, 0);
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_replay_vs_track_bag");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
