// INIT.yaml's door of the item-door table (test/item_doors_table.h): each
// row is one track_bag run on a 640x480 bag (track_bag_fixture.h) with an
// INIT.yaml holding the row's items (those added first, then the request),
// and a config with region_tracking.max_regions 3. A refused row must exit 1
// with one line naming the file, the request's entry and the core's reason;
// an accepted one exits 0 with the item's rows in its CSV. The same table runs
// straight through TrackingSession (test/core/test_item_doors.cpp) and
// through the live services (test/rostest/test_item_doors.cpp).
#include "track_bag_fixture.h"

#include "../item_doors_table.h"

#include <cstdio>
#include <map>

namespace imt {
namespace {

using test::DoorRow;
using test::ItemKind;
using test::ItemRequest;

constexpr int kFrames = 8;
constexpr int kFrame = 4;  // the frame every item is given at

// A number as YAML writes it (.nan, .inf: what INIT.yaml can say of them).
std::string yamlNumber(double v) {
  if (std::isnan(v)) return ".nan";
  if (std::isinf(v)) return v > 0 ? ".inf" : "-.inf";
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

const char* listOf(ItemKind k) {
  return k == ItemKind::kRegion ? "regions" : k == ItemKind::kPlanarTarget ? "planar_targets" : "anchors";
}

std::string entry(const ItemRequest& r, double stamp) {
  std::string e = "  - {id: " + std::to_string(r.id) + ", stamp: " + yamlNumber(stamp);
  switch (r.kind) {
    case ItemKind::kRegion:
      e += ", box: [" + yamlNumber(r.box[0]) + ", " + yamlNumber(r.box[1]) + ", " + yamlNumber(r.box[2]) + ", " +
           yamlNumber(r.box[3]) + "]";
      break;
    case ItemKind::kPlanarTarget:
      e += ", corners: [";
      for (int i = 0; i < 4; ++i)
        e += std::string(i ? ", " : "") + "[" + yamlNumber(r.corners[i][0]) + ", " + yamlNumber(r.corners[i][1]) + "]";
      e += "], size: [" + yamlNumber(r.size[0]) + ", " + yamlNumber(r.size[1]) + "]";
      break;
    case ItemKind::kAnchor:
      e += ", point: [" + yamlNumber(r.point[0]) + ", " + yamlNumber(r.point[1]) + "], depth: " + yamlNumber(r.depth);
      break;
  }
  return e + "}\n";
}

class ItemDoorsInit : public TrackBag {
 protected:
  static void SetUpTestSuite() {
    TrackBag::SetUpTestSuite();
    BagSpec spec;
    spec.frames = kFrames;
    spec.width = test::kDoorImageWidth;
    spec.height = test::kDoorImageHeight;
    bag_ = makeBag("doors.bag", spec);
    stamp_ = frameStamp(spec, kFrame);
    config_ = writeText("doors_config.yaml",
                        "region_tracking:\n  max_regions: " + std::to_string(test::kDoorMaxRegions) + "\n");
  }
  static std::string bag_, config_;
  static double stamp_;
};
std::string ItemDoorsInit::bag_, ItemDoorsInit::config_;
double ItemDoorsInit::stamp_ = 0;

TEST_F(ItemDoorsInit, EveryRowGetsTheTablesAnswerThroughTrackBag) {
  int rows_run = 0;
  for (const DoorRow& row : test::itemDoorRows()) {
    if (row.skip & test::kInitDoor) continue;
    ++rows_run;
    SCOPED_TRACE(row.name + ": " + test::describe(row.request));
    // The row's items in their lists, in order: the request last in its own.
    std::map<std::string, std::string> lists;
    for (const ItemRequest& b : row.before) lists[listOf(b.kind)] += entry(b, stamp_);
    const std::string list = listOf(row.request.kind);
    size_t index = 0;
    for (const ItemRequest& b : row.before) index += b.kind == row.request.kind;
    lists[list] += entry(row.request, stamp_);
    std::string yaml;
    for (const auto& [name, entries] : lists) yaml += name + ":\n" + entries;
    const std::string init = writeText("doors_init.yaml", yaml);
    const std::string out = path("doors_out");
    const ToolRun r = run("--bag " + quote(bag_) + " --init " + quote(init) + " --config " + quote(config_) +
                          " --out-dir " + quote(out) + " --quiet");
    ASSERT_NE(r.status, 124) << "timed out";
    if (row.accept) {
      EXPECT_EQ(r.status, 0) << r.err << "\n" << yaml;
      // Tracked: the item has a row in every frame of its CSV.
      const char* csv = row.request.kind == ItemKind::kRegion         ? "/regions.csv"
                        : row.request.kind == ItemKind::kPlanarTarget ? "/planar_targets.csv"
                                                                      : "/anchors.csv";
      int rows = 0;
      for (const auto& cells : readCsv(out + csv))
        rows += cells.size() > 1 && cells[1] == std::to_string(row.request.id);
      EXPECT_EQ(rows, kFrames) << csv;
      continue;
    }
    EXPECT_EQ(r.status, 1) << r.err << "\n" << yaml;
    ASSERT_EQ(r.errLines().size(), 1u) << r.err;
    const std::string line = r.errLines()[0];
    // The file, the request's entry (parse time: "regions[1] (id 25)"; when
    // track_bag adds it at its frame: "regions (id 25)"), the core's reason.
    EXPECT_EQ(line.rfind("track_bag: error: " + init + ": ", 0), 0u) << line;
    const std::string id = " (id " + std::to_string(row.request.id) + "): ";
    EXPECT_TRUE(line.find(list + "[" + std::to_string(index) + "]" + id) != std::string::npos ||
                line.find(list + id) != std::string::npos)
        << line;
    EXPECT_NE(line.find(row.phrase), std::string::npos) << "got: " << line;
  }
  EXPECT_GT(rows_run, 35);
}

}  // namespace
}  // namespace imt
