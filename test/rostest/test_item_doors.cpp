// Rostest node: the services' door of the item-door table
// (test/item_doors_table.h). Motion analysis and the three trackers in one
// manager (test/rostest/item_doors.test, region_tracking/max_regions 3) are
// fed a rendered `cards` bag (640x480, camera_info, IMU); once it has played,
// every row goes through add_region / add_planar_target / add_anchor (and the
// remove_* services) at the latest frame, and each answer must be the
// table's: the same verdict, and the core's reason in the message. The same
// table runs straight through TrackingSession (test/core/test_item_doors.cpp)
// and through track_bag's INIT.yaml (test/ros/test_item_doors.cpp).
#include "instant_motion_tracking/AddAnchor.h"
#include "instant_motion_tracking/AddPlanarTarget.h"
#include "instant_motion_tracking/AddRegion.h"
#include "instant_motion_tracking/MotionData.h"
#include "instant_motion_tracking/RemoveRegion.h"

#include "../item_doors_table.h"
#include "rostest_util.h"

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <cfloat>
#include <cmath>
#include <map>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace {

using imt::test::DoorRow;
using imt::test::ItemKind;
using imt::test::ItemOp;
using imt::test::ItemRequest;
using instant_motion_tracking::AddAnchor;
using instant_motion_tracking::AddPlanarTarget;
using instant_motion_tracking::AddRegion;
using instant_motion_tracking::RemoveRegion;

// A service field is a float32. A value beyond its range becomes the
// infinity of its sign (what a client's own conversion gives on IEEE
// machines, spelt out here: a plain cast of an out-of-range double is
// undefined behaviour); the table marks the rows where that changes the
// request (region_1e300_px) and skips them at this door.
float f32(double v) {
  if (std::isnan(v)) return NAN;
  if (std::abs(v) > FLT_MAX) return std::copysign(INFINITY, v);
  return static_cast<float>(v);
}

struct Answer {
  bool called = false;  // the service answered (it did not die)
  bool success = false;
  uint32_t id = 0;
  std::string message;
};

// One persistent client per service. Persistent connections, because the
// table sends some 150 requests back to back: roscpp's non-persistent calls
// open and close a connection each, and that close path has failed calls
// sporadically (ros/ros_comm#1976). A persistent connection that breaks
// fails every later call, so a dead service still shows.
struct Doors {
  ros::ServiceClient add_region, add_planar_target, add_anchor;
  std::map<ItemKind, ros::ServiceClient> remove;

  explicit Doors(ros::NodeHandle& nh)
      : add_region(nh.serviceClient<AddRegion>("add_region", true)),
        add_planar_target(nh.serviceClient<AddPlanarTarget>("add_planar_target", true)),
        add_anchor(nh.serviceClient<AddAnchor>("add_anchor", true)),
        remove{{ItemKind::kRegion, nh.serviceClient<RemoveRegion>("remove_region", true)},
               {ItemKind::kPlanarTarget, nh.serviceClient<RemoveRegion>("remove_planar_target", true)},
               {ItemKind::kAnchor, nh.serviceClient<RemoveRegion>("remove_anchor", true)}} {}
};

// Calls `client` with `srv` and reads the answer every item service gives.
template <class Srv>
Answer call(ros::ServiceClient& client, Srv& srv) {
  Answer a;
  a.called = client.call(srv);
  a.success = srv.response.success;
  a.message = srv.response.message;
  if constexpr (!std::is_same_v<Srv, RemoveRegion>) a.id = srv.response.id;
  return a;
}

// Sends one request through its service, at the latest frame (stamp 0).
Answer send(Doors& doors, const ItemRequest& r) {
  if (r.op == ItemOp::kRemove) {
    RemoveRegion rm;
    rm.request.id = r.id;
    return call(doors.remove.at(r.kind), rm);
  }
  switch (r.kind) {
    case ItemKind::kRegion: {
      AddRegion add;
      add.request.stamp = ros::Time(0);
      add.request.id = r.id;
      add.request.x = f32(r.box[0]);
      add.request.y = f32(r.box[1]);
      add.request.width = f32(r.box[2]);
      add.request.height = f32(r.box[3]);
      return call(doors.add_region, add);
    }
    case ItemKind::kPlanarTarget: {
      AddPlanarTarget add;
      add.request.stamp = ros::Time(0);
      add.request.id = r.id;
      for (int i = 0; i < 4; ++i) {
        add.request.corners[i].x = f32(r.corners[i][0]);
        add.request.corners[i].y = f32(r.corners[i][1]);
      }
      add.request.width_m = f32(r.size[0]);
      add.request.height_m = f32(r.size[1]);
      return call(doors.add_planar_target, add);
    }
    case ItemKind::kAnchor: {
      AddAnchor add;
      add.request.stamp = ros::Time(0);
      add.request.id = r.id;
      add.request.u = f32(r.point[0]);
      add.request.v = f32(r.point[1]);
      add.request.depth = f32(r.depth);
      return call(doors.add_anchor, add);
    }
  }
  return Answer();
}

TEST(ItemDoors, EveryRowGetsTheTablesAnswerThroughTheServices) {
  // The door's set-up is the table's: max_regions from the launch file.
  int max_regions = 0;
  ASSERT_TRUE(ros::param::get("/region_tracker/region_tracking/max_regions", max_regions));
  ASSERT_EQ(max_regions, imt::test::kDoorMaxRegions);

  imt::test::SceneBag scene;
  std::string err;
  ASSERT_TRUE(imt::test::makeSceneBag("--preset cards --duration 2 --seed 2", &scene, &err)) << err;
  const size_t n = scene.frames();
  ASSERT_GT(n, 10u);

  ros::NodeHandle nh;
  std::vector<instant_motion_tracking::MotionData> motion;
  ros::Subscriber sub = nh.subscribe<instant_motion_tracking::MotionData>(
      "motion_data", 1000, [&](const instant_motion_tracking::MotionDataConstPtr& m) { motion.push_back(*m); });
  for (const char* s : {"add_region", "remove_region", "add_planar_target", "remove_planar_target", "add_anchor",
                        "remove_anchor"})
    ASSERT_TRUE(ros::service::waitForService(s, ros::Duration(60))) << s;
  Doors doors(nh);

  // The whole bag first: the rows then meet a still graph, the same frames
  // in its cache from the first row to the last.
  const pid_t player =
      imt::test::playTopics(scene.bag, {"/camera/image_raw", "/camera/camera_info", "/imu/data", "/tf_static"});
  ASSERT_GT(player, 0);
  const bool all = imt::test::spinUntil(
      [&] { return !motion.empty() && motion.back().header.stamp == scene.stamp(n - 1); }, 60.0);
  imt::test::spinUntil([] { return false; }, 0.5);
  imt::test::stopPlayer(player);
  ASSERT_TRUE(all) << motion.size() << " of " << n << " frames";
  ASSERT_EQ(motion.back().width, static_cast<uint32_t>(imt::test::kDoorImageWidth));
  ASSERT_EQ(motion.back().height, static_cast<uint32_t>(imt::test::kDoorImageHeight));

  int rows_run = 0;
  for (const DoorRow& row : imt::test::itemDoorRows()) {
    if (row.skip & imt::test::kServiceDoor) continue;
    ++rows_run;
    SCOPED_TRACE(row.name + ": " + imt::test::describe(row.request));
    std::vector<std::pair<ItemKind, uint32_t>> added;
    for (const ItemRequest& b : row.before) {
      const Answer a = send(doors, b);
      ASSERT_TRUE(a.called && a.success) << "before: " << imt::test::describe(b) << ": " << a.message;
      added.emplace_back(b.kind, a.id);
    }
    const Answer a = send(doors, row.request);
    ASSERT_TRUE(a.called) << "the service died";
    EXPECT_EQ(a.success, row.accept) << a.message;
    if (a.success && row.request.op == ItemOp::kAdd) {
      if (row.request.id != 0) {
        EXPECT_EQ(a.id, row.request.id);
      }
      added.emplace_back(row.request.kind, a.id);
    }
    if (!row.accept) {
      EXPECT_NE(a.message.find(row.phrase), std::string::npos) << "got: " << a.message;
    }
    for (const auto& [kind, id] : added) {
      const Answer removed = send(doors, imt::test::removal(kind, id));
      EXPECT_TRUE(removed.called && removed.success) << removed.message;
    }
  }
  EXPECT_GT(rows_run, 40);
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_item_doors");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
