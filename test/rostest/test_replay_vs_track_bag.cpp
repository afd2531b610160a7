// Rostest node (test/rostest/replay_vs_track_bag.test.in): launch/replay.launch
// plays a generated `cards` bag once on sim time through the live graph.
// Mid-stream a region, a planar target and an anchor are added through the
// services at a past stamp; the four live outputs (motion_data for every
// frame; regions, planar_targets and anchors from the frames after the add,
// and seek_regions for every earlier frame) are compared with track_bag run on
// the same bag with the same INIT entries.
#include "instant_motion_tracking/AddAnchor.h"
#include "instant_motion_tracking/AddPlanarTarget.h"
#include "instant_motion_tracking/AddRegion.h"
#include "instant_motion_tracking/AnchorArray.h"
#include "instant_motion_tracking/MotionData.h"
#include "instant_motion_tracking/PlanarTargetArray.h"
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

// Rows of a track_bag CSV for item `id` (column 1; -1: no id column), by
// stamp text with 6 decimals: the numeric columns from `first` on (NAN for
// empty cells) and the text of column `status_col` (-1: none).
struct Row {
  std::vector<double> values;
  std::string status;
};
std::map<std::string, Row> readCsv(const std::string& path, long id, size_t first, size_t last, int status_col) {
  std::map<std::string, Row> rows;
  std::ifstream in(path);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::stringstream ss(line);
    std::string cell;
    while (std::getline(ss, cell, ',')) f.push_back(cell);
    if (line.back() == ',') f.push_back("");
    if (f.size() <= last || (id >= 0 && std::stol(f[1]) != id)) continue;
    Row r;
    for (size_t i = first; i <= last; ++i) r.values.push_back(f[i].empty() ? NAN : std::stod(f[i]));
    if (status_col >= 0 && status_col < int(f.size())) r.status = f[status_col];
    char key[32];
    std::snprintf(key, sizeof key, "%.6f", std::stod(f[0]));
    rows[key] = r;
  }
  return rows;
}

// Largest difference between two rows' values (0 when both are NAN, inf when one is).
double rowDifference(const std::vector<double>& a, const std::vector<double>& b) {
  if (a.size() != b.size()) return INFINITY;
  double d = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    if (std::isnan(a[i]) && std::isnan(b[i])) continue;
    if (std::isnan(a[i]) || std::isnan(b[i])) return INFINITY;
    d = std::max(d, std::abs(a[i] - b[i]));
  }
  return d;
}

// Live rows against track_bag's: the worst difference and the status mismatches.
struct Agreement {
  double worst = 0;
  std::string worst_at;
  int status_mismatches = 0, missing = 0;
};
Agreement compare(const std::map<std::string, Row>& live, const std::map<std::string, Row>& offline) {
  Agreement a;
  for (const auto& [stamp, r] : live) {
    const auto it = offline.find(stamp);
    if (it == offline.end()) {
      ++a.missing;
      continue;
    }
    if (r.status != it->second.status) ++a.status_mismatches;
    const double d = rowDifference(r.values, it->second.values);
    if (d > 1e-3 && std::getenv("IMT_TEST_TRACE")) {
      std::printf("  %s: %.3g\n   live   ", stamp.c_str(), d);
      for (double v : r.values) std::printf(" %.9g", v);
      std::printf("\n   offline");
      for (double v : it->second.values) std::printf(" %.9g", v);
      std::printf("\n");
    }
    if (d > a.worst) a.worst = d, a.worst_at = stamp;
  }
  return a;
}

std::string key(const ros::Time& t) {
  char k[32];
  std::snprintf(k, sizeof k, "%.6f", t.toSec());
  return k;
}

Row rowOf(const instant_motion_tracking::TrackedRegion& r) { return {{r.x, r.y, r.width, r.height}, r.status}; }

Row rowOf(const instant_motion_tracking::PlanarTarget& t) {
  Row r;
  for (const auto& c : t.corners) r.values.insert(r.values.end(), {c.x, c.y});
  const auto& p = t.pose;
  r.values.insert(r.values.end(), {p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y,
                                   p.orientation.z, p.orientation.w});
  r.status = t.status;
  return r;
}

Row rowOf(const instant_motion_tracking::Anchor& a) {
  const auto& p = a.pose;
  return {{a.u, a.v, p.position.x, p.position.y, p.position.z, p.orientation.x, p.orientation.y, p.orientation.z,
           p.orientation.w},
          a.status};
}

Row rowOf(const instant_motion_tracking::MotionData& m) {
  static const char* kModels[] = {"invalid", "translation", "similarity", "homography"};
  return {std::vector<double>(m.homography.begin(), m.homography.end()), m.model < 4 ? kModels[m.model] : "?"};
}

// Every output message received, by kind.
struct Received {
  std::vector<instant_motion_tracking::MotionData> motion;
  std::vector<instant_motion_tracking::TrackedRegionArray> regions;
  std::vector<instant_motion_tracking::PlanarTargetArray> targets;
  std::vector<instant_motion_tracking::AnchorArray> anchors;
};

// The live rows of item `id` in the messages from index `from` on.
template <class Array, class Items>
std::map<std::string, Row> liveRows(const std::vector<Array>& msgs, size_t from, uint32_t id, Items Array::*items) {
  std::map<std::string, Row> rows;
  for (size_t i = from; i < msgs.size(); ++i)
    for (const auto& item : msgs[i].*items)
      if (item.id == id) rows[key(msgs[i].header.stamp)] = rowOf(item);
  return rows;
}

void expectAgreement(const char* what, const std::map<std::string, Row>& live,
                     const std::map<std::string, Row>& offline, size_t min_rows) {
  const Agreement a = compare(live, offline);
  std::printf("live vs track_bag, %s: %zu frames, worst difference %.2g at %s\n", what, live.size(), a.worst,
              a.worst_at.c_str());
  ::testing::Test::RecordProperty(std::string("worst_") + what, std::to_string(a.worst));
  EXPECT_GE(live.size(), min_rows) << what;
  EXPECT_EQ(a.missing, 0) << what << ": frames without a track_bag row";
  // The same core code (one TrackingSession) on the same frames (none
  // dropped: checked by the caller), so the states agree up to the float32
  // of the messages (MotionData features, boxes, corners: ~3e-5 px at 640
  // px). Measured worst 1.5e-5 px for the regions before the session was
  // shared; 1e-3 px (and m, and quaternion units) leaves room for that
  // rounding to move one IRLS weight, and still fails on any real
  // divergence (a dropped or differently analysed frame moves an item by a
  // pixel or more).
  EXPECT_LT(a.worst, 1e-3) << what << " at " << a.worst_at;
  EXPECT_EQ(a.status_mismatches, 0) << what;
}

TEST(ReplayVsTrackBag, LiveOutputsAgreeWithTrackBag) {
  ros::NodeHandle nh, pnh("~");
  std::string bag, truth_path;
  ASSERT_TRUE(pnh.getParam("bag", bag));
  ASSERT_TRUE(pnh.getParam("truth", truth_path));
  nlohmann::json truth;
  std::ifstream(truth_path) >> truth;
  const size_t n = truth["frames"].size();
  ASSERT_EQ(n, 120u);
  auto stampOf = [&](size_t k) { return ros::Time(truth["frames"][k]["stamp"].get<double>()); };

  Received got;
  auto keep = [](auto* v) { return [v](const auto& m) { v->push_back(*m); }; };
  ros::Subscriber subs[] = {
      nh.subscribe<instant_motion_tracking::MotionData>("motion_data", 1000, keep(&got.motion)),
      nh.subscribe<TrackedRegionArray>("regions", 1000, keep(&got.regions)),
      nh.subscribe<instant_motion_tracking::PlanarTargetArray>("planar_targets", 1000, keep(&got.targets)),
      nh.subscribe<instant_motion_tracking::AnchorArray>("anchors", 1000, keep(&got.anchors))};
  for (const char* srv : {"add_region", "add_planar_target", "add_anchor"})
    ASSERT_TRUE(ros::service::waitForService(srv, ros::Duration(60))) << srv;
  ASSERT_TRUE(spinUntil([] { return imt::test::topicHasSubscriber("/camera/image_raw"); }, 60.0));
  spinUntil([] { return false; }, 1.0);  // the player connects to the new subscriber
  ASSERT_TRUE(imt::test::setPlayerPaused(false));

  // Given at frame 30, added once frame 60 has gone by: card 2 as a region;
  // the static textured patch (region 4 of the scene, 0.5 x 0.4 m) as a
  // planar target, and an anchor at its centre.
  ASSERT_TRUE(spinUntil([&] { return got.regions.size() >= 60; }, 60.0)) << got.regions.size() << " frames";
  const size_t kGiven = 30;
  const auto& regions = truth["frames"][kGiven]["regions"];
  ASSERT_EQ(regions[1]["id"], 2);
  ASSERT_EQ(regions[3]["id"], 4);
  const auto& box = regions[1]["box"];
  const auto& patch = regions[3]["box"];
  AddRegion add;
  add.request.stamp = stampOf(kGiven);
  add.request.id = 7;
  add.request.x = box[0].get<float>();
  add.request.y = box[1].get<float>();
  add.request.width = box[2].get<float>();
  add.request.height = box[3].get<float>();
  instant_motion_tracking::AddPlanarTarget target;
  target.request.stamp = stampOf(kGiven);
  target.request.id = 8;
  const float px = patch[0].get<float>(), py = patch[1].get<float>(), pw = patch[2].get<float>(),
              ph = patch[3].get<float>();
  const float corners[4][2] = {{px, py}, {px + pw, py}, {px + pw, py + ph}, {px, py + ph}};
  for (int i = 0; i < 4; ++i) {
    target.request.corners[i].x = corners[i][0];
    target.request.corners[i].y = corners[i][1];
  }
  target.request.width_m = 0.5f;
  target.request.height_m = 0.4f;
  instant_motion_tracking::AddAnchor anchor;
  anchor.request.stamp = stampOf(kGiven);
  anchor.request.id = 9;
  anchor.request.u = px + pw / 2;
  anchor.request.v = py + ph / 2;
  ASSERT_TRUE(imt::test::callService("add_region", add));
  ASSERT_TRUE(add.response.success) << add.response.message;
  const size_t regions_at_add = got.regions.size();
  ASSERT_TRUE(imt::test::callService("add_planar_target", target));
  ASSERT_TRUE(target.response.success) << target.response.message;
  const size_t targets_at_add = got.targets.size();
  ASSERT_TRUE(imt::test::callService("add_anchor", anchor));
  ASSERT_TRUE(anchor.response.success) << anchor.response.message;
  const size_t anchors_at_add = got.anchors.size();

  const bool all = spinUntil([&] { return got.regions.size() >= n && got.anchors.size() >= n; }, 60.0);
  spinUntil([] { return false; }, 0.5);
  ASSERT_TRUE(all) << got.regions.size() << " and " << got.anchors.size() << " of " << n << " frames";
  // Every image was processed: nothing dropped, so live and offline saw the
  // same frames (a dropped frame would be a real difference, not a bug).
  EXPECT_EQ(got.motion.size(), n);
  EXPECT_EQ(got.regions.size(), n);
  EXPECT_EQ(got.targets.size(), n);
  EXPECT_EQ(got.anchors.size(), n);

  // Live regions: the topic after the add, seek_regions for every earlier frame.
  std::map<std::string, Row> live_regions = liveRows(got.regions, regions_at_add, 7, &TrackedRegionArray::regions);
  const size_t from_topic = live_regions.size();
  size_t seeks = 0;
  for (size_t k = 0; k < n; ++k) {
    if (live_regions.count(key(stampOf(k)))) continue;
    SeekRegions seek;
    seek.request.stamp = stampOf(k);
    ASSERT_TRUE(imt::test::callService("seek_regions", seek));
    ASSERT_TRUE(seek.response.success) << "frame " << k << ": " << seek.response.message;
    ASSERT_EQ(seek.response.regions.regions.size(), 1u);
    live_regions[key(stampOf(k))] = rowOf(seek.response.regions.regions[0]);
    ++seeks;
  }
  EXPECT_GT(from_topic, 40u);
  EXPECT_GT(seeks, 30u);

  // track_bag with the same entries: the requests' values and the stamp
  // exactly (%.17g: a float printed with %.9g reads back as a different
  // double, ~1e-7 px off, which the planar tracker alone turned into 0.15 px).
  char tmpl[] = "/tmp/imt_replay_vs_track_bag_XXXXXX";
  const std::string dir = mkdtemp(tmpl) ? tmpl : "";
  ASSERT_FALSE(dir.empty());
  {
    std::ofstream init(dir + "/init.yaml");
    char text[1024];
    const double t = stampOf(kGiven).toSec();
    std::snprintf(text, sizeof text,
                  "regions:\n  - id: 7\n    stamp: %.9f\n    box: [%.17g, %.17g, %.17g, %.17g]\n"
                  "planar_targets:\n  - id: 8\n    stamp: %.9f\n"
                  "    corners: [[%.17g, %.17g], [%.17g, %.17g], [%.17g, %.17g], [%.17g, %.17g]]\n    size: [%.17g, %.17g]\n"
                  "anchors:\n  - id: 9\n    stamp: %.9f\n    point: [%.17g, %.17g]\n",
                  t, add.request.x, add.request.y, add.request.width, add.request.height, t, corners[0][0],
                  corners[0][1], corners[1][0], corners[1][1], corners[2][0], corners[2][1], corners[3][0],
                  corners[3][1], target.request.width_m, target.request.height_m, t, anchor.request.u, anchor.request.v);
    init << text;
  }
  const std::string cmd = std::string(IMT_BIN_DIR) + "/track_bag --quiet --bag " + bag + " --init " + dir +
                          "/init.yaml --out-dir " + dir + " > " + dir + "/track_bag.log 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  std::map<std::string, Row> live_motion;
  for (const auto& m : got.motion) live_motion[key(m.header.stamp)] = rowOf(m);
  expectAgreement("camera_motion", live_motion, readCsv(dir + "/camera_motion.csv", -1, 2, 10, 1), n);
  expectAgreement("regions", live_regions, readCsv(dir + "/regions.csv", 7, 2, 5, 6), n);
  expectAgreement("planar_targets",
                  liveRows(got.targets, targets_at_add, 8, &instant_motion_tracking::PlanarTargetArray::targets),
                  readCsv(dir + "/planar_targets.csv", 8, 2, 16, 17), 40);
  expectAgreement("anchors", liveRows(got.anchors, anchors_at_add, 9, &instant_motion_tracking::AnchorArray::anchors),
                  readCsv(dir + "/anchors.csv", 9, 2, 10, 11), 40);
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_replay_vs_track_bag");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
