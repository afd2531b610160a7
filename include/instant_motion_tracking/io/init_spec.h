// INIT.yaml: what track_bag tracks (regions, planar targets, anchors), as
// plain structs, and the resolution of each entry's stamp to a frame of the
// bag. No ROS in here. The file format is the spec's (docs: interface.md,
// "INIT.yaml"):
//
//   regions:        [{id: 1, stamp: 1000.0, box: [x, y, width, height]}]
//   planar_targets: [{id: 1, stamp: 1000.0, corners: [[x0, y0], ..., [x3, y3]], size: [w_m, h_m]}]
//   image_targets:  [{id: 2, image: poster.png, size: [w_m, h_m]}]   # found from the first frame on
//   anchors:        [{id: 1, stamp: 1000.0, point: [u, v], depth: 1.6}]   # depth optional (0 = the default)
//
// Usage:
//   imt::InitSpec spec;
//   std::string err;
//   if (!imt::loadInitSpecFile("INIT.yaml", &spec, &err)) die(err);
//   if (!imt::resolveInitStamps(frame_stamps, "INIT.yaml", "the bag", &spec, &err)) die(err);
//   // every entry's `frame` now indexes frame_stamps
//
// Every error message names the file and the entry, e.g.
//   "INIT.yaml: regions[2] (id 7): box must have 4 numbers, got 3".
// Entries are indexed from 0, in file order.
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace imt {

// A 2D region to track. Pixels in the package convention (docs/conventions.md).
struct RegionInit {
  uint32_t id = 0;                   // positive, unique among regions
  double stamp = 0;                  // s, bag time of the frame where the box is given
  std::array<double, 4> box{};       // x, y (top-left corner), width, height; px
  int frame = -1;                    // index into the frame stamps after resolveInitStamps()
};

// A planar target of known physical size.
struct PlanarTargetInit {
  uint32_t id = 0;
  double stamp = 0;
  std::array<std::array<double, 2>, 4> corners{};  // px; TL, TR, BR, BL of the target (convex)
  std::array<double, 2> size{};                    // m; width (TL->TR), height (TL->BL)
  int frame = -1;
};

// A planar target known by its picture (found whenever in view, from the
// bag's first frame on). Shares the id space of planar_targets.
struct ImageTargetInit {
  uint32_t id = 0;
  std::string image;              // as written: a relative path is relative to the INIT file
  std::string path;               // the file read
  cv::Mat picture;                // its pixels (gray)
  std::array<double, 2> size{};   // m; width (picture's left -> right), height (top -> bottom)
};

// A calibration-free 6DoF anchor.
struct AnchorInit {
  uint32_t id = 0;
  double stamp = 0;
  std::array<double, 2> point{};     // px; the pixel the user tapped (u, v)
  // m along that pixel's ray; sets the scale. 0 (also when the entry has no
  // depth): anchors.default_depth, as add_anchor's depth 0.
  double depth = 0;
  int frame = -1;
};

struct InitSpec {
  std::vector<RegionInit> regions;
  std::vector<PlanarTargetInit> planar_targets;
  std::vector<ImageTargetInit> image_targets;
  std::vector<AnchorInit> anchors;

  bool empty() const { return regions.empty() && planar_targets.empty() && image_targets.empty() && anchors.empty(); }
};

// Parses INIT.yaml text. False with a one-line message naming `source` and
// the entry on any error: invalid or empty YAML, top level not a mapping,
// unknown top-level list, an entry that is not a mapping, a missing field,
// an unknown key, a list of the wrong length, a non-number, a stamp that is
// NaN/Inf or negative, an id that is not a positive integer, a duplicate id
// within a list ("region id 3 is already tracked (also regions[0])"), and
// an item its kind's validator refuses (core/item_requests.h: the reason in
// the words every door uses, e.g. "box has a NaN or infinite value", "corners
// are counter-clockwise in the image ...", "depth must be positive and
// within ..."). What needs the frame (the image bounds, max_regions) is
// checked when the item is added. An image target's picture is read here
// (a relative path from the directory of `source`): a file that cannot be
// read as an image is an error naming the entry and the path. `spec` is
// unchanged on error.
bool parseInitSpec(const std::string& text, const std::string& source, InitSpec* spec,
                   std::string* error);
bool loadInitSpecFile(const std::string& path, InitSpec* spec, std::string* error);

// The index of the frame whose stamp is nearest to `stamp` when it lies within
// half a frame interval of it (the median spacing of the frame stamps, so a
// gap of dropped frames does not widen it), with 1 us of slack for stamps
// copied from 6-decimal CSV files. Else -1 and a message: "stamp 1234.5 is
// outside <range_name> (frames 1000.000000 .. 1010.000000)" or "stamp 1005.3
// is not within half a frame of any frame (nearest 1005.000000)" (a gap).
// `frame_stamps` are header stamps in bag order; they need not be sorted
// (a repeated stamp resolves to its first frame; ties to the earlier stamp).
int resolveStamp(double stamp, const std::vector<double>& frame_stamps,
                 const std::string& range_name, std::string* error);

// Sets `frame` of every entry of `spec`. False with "<source>: <list>[i] (id
// n): <resolveStamp's message>" for the first entry that does not resolve.
bool resolveInitStamps(const std::vector<double>& frame_stamps, const std::string& source,
                       const std::string& range_name, InitSpec* spec, std::string* error);

}  // namespace imt
