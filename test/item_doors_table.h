// One table of item requests with the answer every door must give (issue 16
// item 3: "the same request gets the same answer at every door, and a
// table-driven test proves it"). Three tests run it, one per door:
//   test/core/test_item_doors.cpp     TrackingSession's add and remove, live and offline
//   test/ros/test_item_doors.cpp      track_bag with an INIT.yaml holding the row's items
//   test/rostest/test_item_doors.cpp  the services of the live nodelets (rostest item_doors)
// A row: the items added first (each accepted at every door), then the
// request under test with its verdict and, for a refusal, a key phrase of
// the core's reason. A door may wrap that reason (INIT: the file and the
// entry; a service: a retry hint) but not reword it. After a row every door
// removes what it added, so rows do not see each other.
// A row a door cannot express says so (`skip`, `why_skipped`); the door
// skips it there, and only there.
// Every door runs on a 640x480 image with region_tracking.max_regions 3
// (kDoorImageWidth / kDoorImageHeight / kDoorMaxRegions; each door checks
// its own set-up against them).
#pragma once

#include "instant_motion_tracking/core/anchor/anchor_manager.h"

#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace imt {
namespace test {

constexpr int kDoorImageWidth = 640;
constexpr int kDoorImageHeight = 480;
constexpr int kDoorMaxRegions = 3;  // region_tracking.max_regions at every door

enum class ItemKind { kRegion, kPlanarTarget, kAnchor };
enum class ItemOp { kAdd, kRemove };

// The doors, as bits of DoorRow::skip.
enum Door : unsigned { kCoreDoor = 1, kInitDoor = 2, kServiceDoor = 4 };

struct ItemRequest {
  ItemKind kind = ItemKind::kRegion;
  ItemOp op = ItemOp::kAdd;
  uint32_t id = 0;                                   // 0: the tracker chooses (services and core only)
  std::array<double, 4> box{};                       // region: x, y, width, height (px)
  std::array<std::array<double, 2>, 4> corners{};    // planar target: TL, TR, BR, BL (px)
  std::array<double, 2> size{};                      // planar target: width, height (m)
  std::array<double, 2> point{};                     // anchor: u, v (px)
  double depth = 0;                                  // anchor: m (0 = anchors.default_depth)
};

struct DoorRow {
  std::string name;
  std::vector<ItemRequest> before;  // added first; accepted at every door
  ItemRequest request;
  bool accept = false;
  std::string phrase;               // in the refusal (its core reason); "" when accepted
  unsigned skip = 0;                // doors that cannot express this row (Door bits)
  std::string why_skipped = "";  // why those doors cannot
};

inline const char* kindName(ItemKind k) {
  return k == ItemKind::kRegion ? "region" : k == ItemKind::kPlanarTarget ? "planar target" : "anchor";
}

inline std::string describe(const ItemRequest& r) {
  std::ostringstream os;
  os.precision(17);
  os << (r.op == ItemOp::kAdd ? "add " : "remove ") << kindName(r.kind) << " id " << r.id;
  if (r.op == ItemOp::kRemove) return os.str();
  switch (r.kind) {
    case ItemKind::kRegion:
      os << " box " << r.box[0] << ", " << r.box[1] << ", " << r.box[2] << ", " << r.box[3];
      break;
    case ItemKind::kPlanarTarget:
      os << " corners";
      for (const auto& c : r.corners) os << " (" << c[0] << ", " << c[1] << ")";
      os << " size " << r.size[0] << " x " << r.size[1];
      break;
    case ItemKind::kAnchor:
      os << " point " << r.point[0] << ", " << r.point[1] << " depth " << r.depth;
      break;
  }
  return os.str();
}

inline ItemRequest region(uint32_t id, double x, double y, double w, double h) {
  ItemRequest r;
  r.kind = ItemKind::kRegion;
  r.id = id;
  r.box = {x, y, w, h};
  return r;
}

inline ItemRequest target(uint32_t id, const std::array<std::array<double, 2>, 4>& corners, double w, double h) {
  ItemRequest r;
  r.kind = ItemKind::kPlanarTarget;
  r.id = id;
  r.corners = corners;
  r.size = {w, h};
  return r;
}

inline ItemRequest anchor(uint32_t id, double u, double v, double depth) {
  ItemRequest r;
  r.kind = ItemKind::kAnchor;
  r.id = id;
  r.point = {u, v};
  r.depth = depth;
  return r;
}

inline ItemRequest removal(ItemKind kind, uint32_t id) {
  ItemRequest r;
  r.kind = kind;
  r.op = ItemOp::kRemove;
  r.id = id;
  return r;
}

// The rows. Values are chosen so that a float32 (the services' fields) holds
// each exactly or keeps its verdict (1e-30, 3e38); the one that it cannot
// hold (1e300) says so.
inline std::vector<DoorRow> itemDoorRows() {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  using Quad = std::array<std::array<double, 2>, 4>;
  const Quad good = {{{200, 150}, {440, 160}, {430, 330}, {210, 320}}};  // TL, TR, BR, BL
  const char* kNoRemoval = "INIT.yaml only adds items";
  const char* kNoChoice = "INIT.yaml ids are positive (0 has no 'choose one' there)";
  std::vector<DoorRow> rows = {
      // --- regions ---------------------------------------------------------------
      {"region_good", {}, region(10, 100, 100, 80, 60), true, ""},
      {"region_partly_outside", {}, region(11, 600, 440, 100, 100), true, ""},
      {"region_id_0_chooses", {}, region(0, 100, 100, 80, 60), true, "", kInitDoor, kNoChoice},
      {"region_nan_x", {}, region(12, nan, 100, 80, 60), false, "box has a NaN or infinite value"},
      {"region_nan_width", {}, region(12, 100, 100, nan, 60), false, "box has a NaN or infinite value"},
      {"region_inf_size", {}, region(12, 100, 100, inf, inf), false, "box has a NaN or infinite value"},
      {"region_zero_width", {}, region(12, 100, 100, 0, 60), false, "box width and height must be positive"},
      {"region_negative_height", {}, region(12, 100, 100, 80, -60), false, "box width and height must be positive"},
      {"region_1e-6_px", {}, region(12, 100, 100, 1e-6, 1e-6), false, "box size"},
      {"region_1.5_px_wide", {}, region(12, 100, 100, 1.5, 40), false, "box size"},
      // A float32 turns 1e300 into inf, refused as region_inf_size is: for
      // another reason ("NaN or infinite"), so not the same request there.
      {"region_1e300_px", {}, region(12, 0, 0, 1e300, 1e300), false, "box size",
       kServiceDoor, "a float32 holds no 1e300 (it becomes inf: region_inf_size)"},
      {"region_3e38_px", {}, region(12, 0, 0, 3e38, 3e38), false, "box size"},
      {"region_5_images_wide", {}, region(12, 0, 10, 3200, 50), false, "box size"},
      {"region_wholly_outside", {}, region(12, 5000, 100, 50, 50), false, "box lies entirely outside the 640x480 image"},
      {"region_touching_the_left_edge", {}, region(12, -100, 100, 100, 50), false,
       "box lies entirely outside the 640x480 image"},
      {"region_beyond_max_regions",
       {region(21, 10, 10, 40, 40), region(22, 60, 10, 40, 40), region(23, 110, 10, 40, 40)},
       region(24, 160, 10, 40, 40), false, "regions (region_tracking.max_regions): remove some first"},
      // max_regions counts the user's regions, not the anchors' own (each
      // anchor tracks a region): per kind.
      {"region_beside_anchors",
       {anchor(26, 100, 100, 1.5), anchor(27, 300, 100, 1.5), anchor(28, 500, 100, 1.5)},
       region(29, 160, 300, 40, 40), true, ""},
      {"region_duplicate_id", {region(25, 10, 10, 40, 40)}, region(25, 300, 200, 40, 40), false,
       "region id 25 is already tracked"},
      {"region_reserved_id", {}, region(AnchorManager::kAnchorRegionBase, 100, 100, 80, 60), false,
       "is reserved (ids must be below 1000000000)"},
      {"region_remove_unknown", {}, removal(ItemKind::kRegion, 999), false, "unknown region id 999", kInitDoor,
       kNoRemoval},

      // --- planar targets --------------------------------------------------------
      {"target_good", {}, target(40, good, 0.5, 0.375), true, ""},
      {"target_partly_outside", {}, target(41, {{{560, 400}, {720, 400}, {720, 520}, {560, 520}}}, 0.5, 0.375), true,
       ""},
      {"target_mirrored", {},
       target(42, {{good[0], good[3], good[2], good[1]}}, 0.5, 0.375),  // TL, BL, BR, TR: counter-clockwise
       false, "corners are counter-clockwise in the image (a mirrored quad)"},
      {"target_bow_tie", {}, target(42, {{good[0], good[2], good[1], good[3]}}, 0.5, 0.375), false,
       "quad is not convex"},
      {"target_collinear", {}, target(42, {{{200, 150}, {320, 150}, {440, 150}, {210, 320}}}, 0.5, 0.375), false,
       "three corners are collinear"},
      {"target_tiny_area", {}, target(42, {{{300, 200}, {304, 200}, {304, 204}, {300, 204}}}, 0.5, 0.375), false,
       "degenerate quad (area below 25 px^2)"},
      {"target_coincident_corners", {}, target(42, {{{300, 200}, {301, 200}, {304, 240}, {280, 240}}}, 0.5, 0.375),
       false, "corners 0 and 1 coincide"},
      {"target_nan_corner", {}, target(42, {{good[0], {nan, 160}, good[2], good[3]}}, 0.5, 0.375), false,
       "corner with a NaN or infinite coordinate"},
      {"target_at_1e6_px", {},
       target(42, {{{1e6, 1e6}, {1e6 + 100, 1e6}, {1e6 + 100, 1e6 + 100}, {1e6, 1e6 + 100}}}, 0.5, 0.375), false,
       "corners lie entirely outside the 640x480 image"},
      {"target_size_nan", {}, target(42, good, nan, 0.375), false, "target size must be positive"},
      {"target_size_zero", {}, target(42, good, 0.5, 0), false, "target size must be positive"},
      {"target_size_negative", {}, target(42, good, -0.5, 0.375), false, "target size must be positive"},
      {"target_duplicate_id", {target(43, good, 0.5, 0.375)}, target(43, good, 0.5, 0.375), false,
       "planar target id 43 is already tracked"},
      {"target_remove_unknown", {}, removal(ItemKind::kPlanarTarget, 999), false, "unknown planar target id 999",
       kInitDoor, kNoRemoval},

      // --- anchors ---------------------------------------------------------------
      {"anchor_good", {}, anchor(60, 320, 300, 1.5), true, ""},
      {"anchor_depth_0_is_the_default", {}, anchor(61, 320, 300, 0), true, ""},
      {"anchor_depth_at_most", {}, anchor(62, 320, 300, AnchorManager::kMaxDepth), true, ""},
      {"anchor_at_the_image_corner", {}, anchor(63, 640, 480, 1.5), true, ""},
      {"anchor_depth_1e-30", {}, anchor(64, 320, 300, 1e-30), false, "depth must be positive and within 0.01 .. 10000 m"},
      {"anchor_depth_3e38", {}, anchor(64, 320, 300, 3e38), false, "depth must be positive and within 0.01 .. 10000 m"},
      {"anchor_depth_inf", {}, anchor(64, 320, 300, inf), false, "depth must be positive and within 0.01 .. 10000 m"},
      {"anchor_depth_nan", {}, anchor(64, 320, 300, nan), false, "depth must be positive and within 0.01 .. 10000 m"},
      {"anchor_depth_negative", {}, anchor(64, 320, 300, -1.5), false,
       "depth must be positive and within 0.01 .. 10000 m"},
      {"anchor_pixel_outside", {}, anchor(64, 700, 100, 1.5), false, "is outside the 640x480 image"},
      {"anchor_pixel_above", {}, anchor(64, 320, -1, 1.5), false, "is outside the 640x480 image"},
      {"anchor_pixel_nan", {}, anchor(64, nan, 100, 1.5), false, "has a NaN or infinite value"},
      {"anchor_beside_max_regions",
       {region(66, 10, 10, 40, 40), region(67, 60, 10, 40, 40), region(68, 110, 10, 40, 40)},
       anchor(69, 320, 300, 1.5), true, ""},
      {"anchor_duplicate_id", {anchor(65, 100, 100, 1.5)}, anchor(65, 320, 300, 1.5), false,
       "anchor id 65 is already tracked"},
      {"anchor_remove_unknown", {}, removal(ItemKind::kAnchor, 999), false, "unknown anchor id 999", kInitDoor,
       kNoRemoval},
  };
  return rows;
}

}  // namespace test
}  // namespace imt
