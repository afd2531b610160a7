// The core's door of the item-door table (test/item_doors_table.h): each row
// straight through TrackingSession's add and remove methods, in a live
// session (as the nodelets' services) and an offline one (as track_bag), on
// the rendered `cards` scene (640x480, with its IMU). The same table runs
// through track_bag's INIT.yaml (test/ros/test_item_doors.cpp) and the live
// services (test/rostest/test_item_doors.cpp).
#include "instant_motion_tracking/core/tracking_session.h"

#include "../item_doors_table.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>

#include <memory>
#include <string>
#include <vector>

namespace imt {
namespace {

using test::DoorRow;
using test::ItemKind;
using test::ItemOp;
using test::ItemRequest;

// One session per mode over the first 12 frames of the scene, shared by the
// rows (each row removes what it added, as the service door does).
struct Door {
  std::unique_ptr<SceneGenerator> scene;
  std::unique_ptr<TrackingSession> session;
};

Door& door(TrackingSession::Mode mode) {
  static std::unique_ptr<Door> doors[2];
  std::unique_ptr<Door>& d = doors[mode == TrackingSession::Mode::kLive ? 0 : 1];
  if (d) return *d;
  d = std::make_unique<Door>();
  SceneOptions o = test::preset("cards");
  o.duration = 0.4;
  d->scene = test::make(o);
  PipelineOptions options;
  options.region_tracking.max_regions = test::kDoorMaxRegions;
  d->session = std::make_unique<TrackingSession>(options, mode);
  const std::vector<ImuSample> imu = d->scene->imuSamples();
  size_t next_imu = 0;
  for (int i = 0; i < d->scene->frameCount(); ++i) {
    const double stamp = d->scene->frameStamp(i);
    for (; next_imu < imu.size() && imu[next_imu].stamp <= stamp + 0.02; ++next_imu)
      d->session->addImu(imu[next_imu]);
    d->session->analyze(d->scene->renderFrame(i), stamp);
  }
  d->session->advance(/*all=*/true);
  d->session->takeResults();
  return *d;
}

// Sends one request; true when accepted. `added` gets the id it holds.
bool send(TrackingSession& s, const ItemRequest& r, uint32_t* added, std::string* error) {
  *added = 0;
  if (r.op == ItemOp::kRemove) {
    switch (r.kind) {
      case ItemKind::kRegion: return s.removeRegion(r.id, error);
      case ItemKind::kPlanarTarget: return s.removePlanarTarget(r.id, error);
      case ItemKind::kAnchor: return s.removeAnchor(r.id, error);
    }
  }
  switch (r.kind) {
    case ItemKind::kRegion:
      return s.addRegion(r.id, 0, cv::Rect2d(r.box[0], r.box[1], r.box[2], r.box[3]), added, error);
    case ItemKind::kPlanarTarget: {
      std::array<cv::Point2d, 4> c;
      for (int i = 0; i < 4; ++i) c[i] = cv::Point2d(r.corners[i][0], r.corners[i][1]);
      return s.addPlanarTarget(r.id, 0, c, r.size[0], r.size[1], added, error);
    }
    case ItemKind::kAnchor:
      return s.addAnchor(r.id, 0, cv::Point2d(r.point[0], r.point[1]), r.depth, added, error);
  }
  return false;
}

void remove(TrackingSession& s, ItemKind kind, uint32_t id) {
  std::string err;
  EXPECT_TRUE(send(s, test::removal(kind, id), &id, &err)) << err;
}

class ItemDoorsCore : public ::testing::TestWithParam<TrackingSession::Mode> {};

TEST_P(ItemDoorsCore, EveryRowGetsTheTablesAnswer) {
  Door& d = door(GetParam());
  TrackingSession& s = *d.session;
  ASSERT_EQ(s.camera().width, test::kDoorImageWidth);
  ASSERT_EQ(s.camera().height, test::kDoorImageHeight);
  ASSERT_GT(s.cache().size(), 5u);
  int rows_run = 0;
  for (const DoorRow& row : test::itemDoorRows()) {
    if (row.skip & test::kCoreDoor) continue;
    ++rows_run;
    SCOPED_TRACE(row.name + ": " + test::describe(row.request));
    std::vector<std::pair<ItemKind, uint32_t>> added;
    std::string err;
    uint32_t id = 0;
    for (const ItemRequest& b : row.before) {
      ASSERT_TRUE(send(s, b, &id, &err)) << "before: " << test::describe(b) << ": " << err;
      added.emplace_back(b.kind, id);
    }
    err.clear();
    const bool accepted = send(s, row.request, &id, &err);
    EXPECT_EQ(accepted, row.accept) << err;
    if (accepted && row.request.op == ItemOp::kAdd) {
      if (row.request.id != 0) {
        EXPECT_EQ(id, row.request.id);
      }
      added.emplace_back(row.request.kind, id);
    }
    if (!row.accept) {
      EXPECT_NE(err.find(row.phrase), std::string::npos) << "got: " << err;
    }
    for (const auto& [kind, item] : added) remove(s, kind, item);
    ASSERT_EQ(s.regionCount() + s.planarTargetCount() + s.anchorCount(), 0u) << "a row left items behind";
  }
  EXPECT_GT(rows_run, 40);
}

INSTANTIATE_TEST_SUITE_P(Modes, ItemDoorsCore,
                         ::testing::Values(TrackingSession::Mode::kLive, TrackingSession::Mode::kOffline),
                         [](const auto& info) {
                           return std::string(info.param == TrackingSession::Mode::kLive ? "Live" : "Offline");
                         });

}  // namespace
}  // namespace imt
