#include "instant_motion_tracking/io/init_spec.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

namespace imt {
namespace {

const char* kValid = R"(
regions:
  - id: 1
    stamp: 1000.0
    box: [10, 20.5, 30, 40]
  - id: 7
    stamp: 1000.5
    box: [-5, -5, 1e1, 0.5]     # partly outside the image is allowed
planar_targets:
  - id: 1                        # ids are unique per list, not across lists
    stamp: 1000.1
    corners: [[100, 100], [200, 110], [190, 220], [90, 210]]
    size: [0.297, 0.21]
anchors:
  - id: 3
    stamp: 1000.2
    point: [320, 240]
    depth: 1.6
  - id: 4
    stamp: 1000.3
    point: [0.5, 0.5]
)";

TEST(InitSpec, ParsesEveryListWithItsFields) {
  InitSpec spec;
  std::string err;
  ASSERT_TRUE(parseInitSpec(kValid, "INIT.yaml", &spec, &err)) << err;
  ASSERT_EQ(spec.regions.size(), 2u);
  EXPECT_EQ(spec.regions[0].id, 1u);
  EXPECT_EQ(spec.regions[0].stamp, 1000.0);
  EXPECT_EQ(spec.regions[0].box, (std::array<double, 4>{10, 20.5, 30, 40}));
  EXPECT_EQ(spec.regions[1].id, 7u);
  EXPECT_EQ(spec.regions[1].box[2], 10.0);
  EXPECT_EQ(spec.regions[0].frame, -1);  // not resolved yet
  ASSERT_EQ(spec.planar_targets.size(), 1u);
  EXPECT_EQ(spec.planar_targets[0].corners[2][0], 190.0);
  EXPECT_EQ(spec.planar_targets[0].corners[3][1], 210.0);
  EXPECT_EQ(spec.planar_targets[0].size[0], 0.297);
  ASSERT_EQ(spec.anchors.size(), 2u);
  EXPECT_EQ(spec.anchors[0].depth, 1.6);
  EXPECT_EQ(spec.anchors[1].depth, 0.0);  // omitted: anchors.default_depth (the spec's 1.0), as add_anchor's 0
  EXPECT_EQ(spec.anchors[1].point[1], 0.5);
}

TEST(InitSpec, EmptyListsAndMissingListsAreFine) {
  InitSpec spec;
  std::string err;
  ASSERT_TRUE(parseInitSpec("regions: []\nanchors:\n", "f", &spec, &err)) << err;
  EXPECT_TRUE(spec.empty());
  ASSERT_TRUE(parseInitSpec("{}", "f", &spec, &err)) << err;
  EXPECT_TRUE(spec.empty());
}

// depth 0 means anchors.default_depth at every door (add_anchor's "0 =
// default"): an INIT entry saying so is not refused.
TEST(InitSpec, AnchorDepthZeroIsTheDefault) {
  InitSpec spec;
  std::string err;
  ASSERT_TRUE(parseInitSpec("anchors:\n  - {id: 5, stamp: 1, point: [1, 2], depth: 0}\n", "f", &spec, &err)) << err;
  ASSERT_EQ(spec.anchors.size(), 1u);
  EXPECT_EQ(spec.anchors[0].depth, 0.0);
}

TEST(InitSpec, LoadsAFileAndNamesAMissingOne) {
  const std::string path = ::testing::TempDir() + "/imt_init_spec_test.yaml";
  {
    std::ofstream out(path);
    out << kValid;
  }
  InitSpec spec;
  std::string err;
  ASSERT_TRUE(loadInitSpecFile(path, &spec, &err)) << err;
  EXPECT_EQ(spec.regions.size(), 2u);
  std::remove(path.c_str());
  EXPECT_FALSE(loadInitSpecFile(path, &spec, &err));
  EXPECT_EQ(err, path + ": cannot open the init file");
}

// An image target's picture is read relative to the INIT file.
TEST(InitSpec, ReadsAnImageTargetsPictureBesideTheFile) {
  const std::string dir = ::testing::TempDir() + "/imt_init_spec_image";
  std::filesystem::create_directories(dir + "/pictures");
  cv::Mat picture(60, 80, CV_8UC1);
  cv::randu(picture, 0, 255);
  ASSERT_TRUE(cv::imwrite(dir + "/pictures/poster.png", picture));
  {
    std::ofstream out(dir + "/INIT.yaml");
    out << "image_targets:\n  - {id: 4, image: pictures/poster.png, size: [0.6, 0.45]}\n";
  }
  InitSpec spec;
  std::string err;
  ASSERT_TRUE(loadInitSpecFile(dir + "/INIT.yaml", &spec, &err)) << err;
  ASSERT_EQ(spec.image_targets.size(), 1u);
  const ImageTargetInit& t = spec.image_targets[0];
  EXPECT_EQ(t.id, 4u);
  EXPECT_EQ(t.image, "pictures/poster.png");
  EXPECT_EQ(t.path, dir + "/pictures/poster.png");
  EXPECT_EQ(t.size[0], 0.6);
  EXPECT_EQ(t.size[1], 0.45);
  ASSERT_EQ(t.picture.size(), picture.size());
  EXPECT_EQ(cv::norm(t.picture, picture, cv::NORM_INF), 0);  // PNG: lossless
  EXPECT_FALSE(spec.empty());
  std::filesystem::remove_all(dir);
}

// Each bad input with the exact message it must produce: the message is the
// user's only clue, so its wording (entry index, id, field) is asserted fully.
struct BadInit {
  const char* name;
  const char* yaml;
  const char* message;
};

void PrintTo(const BadInit& b, std::ostream* os) { *os << b.name; }

class InitSpecBad : public ::testing::TestWithParam<BadInit> {};

TEST_P(InitSpecBad, IsRejectedWithAMessageNamingTheEntry) {
  InitSpec spec;
  spec.regions.resize(5);  // must be left untouched on error
  std::string err;
  EXPECT_FALSE(parseInitSpec(GetParam().yaml, "INIT.yaml", &spec, &err));
  EXPECT_EQ(err, GetParam().message);
  EXPECT_EQ(spec.regions.size(), 5u);
  EXPECT_EQ(err.find('\n'), std::string::npos) << "one line";
}

const BadInit kBad[] = {
    {"empty_file", "", "INIT.yaml: empty (expected a mapping with regions, planar_targets, image_targets and/or anchors)"},
    {"only_comments", "# nothing\n", "INIT.yaml: empty (expected a mapping with regions, planar_targets, image_targets and/or anchors)"},
    {"invalid_yaml", "regions: [\n  - id: 1\n", "INIT.yaml: invalid YAML at line 2, column 3: illegal block entry"},
    {"top_level_list", "- id: 1\n", "INIT.yaml: expected a mapping with regions, planar_targets, image_targets and/or anchors, got a list of 1"},
    {"top_level_scalar", "hello\n", "INIT.yaml: expected a mapping with regions, planar_targets, image_targets and/or anchors, got 'hello'"},
    {"unknown_list", "region:\n  - {id: 1, stamp: 1, box: [1, 2, 3, 4]}\n", "INIT.yaml: unknown list 'region' (expected regions, planar_targets, image_targets, anchors)"},
    {"list_not_a_list", "regions: {id: 1}\n", "INIT.yaml: regions must be a list of entries, got a mapping"},
    {"entry_not_mapping", "regions: [5]\n", "INIT.yaml: regions[0]: expected a mapping with id, stamp, box, got '5'"},
    {"missing_id", "regions:\n  - {stamp: 1, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0]: missing field 'id'"},
    {"id_zero", "regions:\n  - {id: 0, stamp: 1, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0]: id must be a positive integer, got '0'"},
    {"id_negative", "anchors:\n  - {id: -2, stamp: 1, point: [1, 2]}\n", "INIT.yaml: anchors[0]: id must be a positive integer, got '-2'"},
    {"id_fraction", "regions:\n  - {id: 1.5, stamp: 1, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0]: id must be a positive integer, got '1.5'"},
    {"id_text", "regions:\n  - {id: one, stamp: 1, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0]: id must be a positive integer, got 'one'"},
    {"id_too_big", "regions:\n  - {id: 4294967296, stamp: 1, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0]: id must be a positive integer, got '4294967296'"},
    {"duplicate_id", "regions:\n  - {id: 3, stamp: 1, box: [1, 2, 3, 4]}\n  - {id: 4, stamp: 1, box: [1, 2, 3, 4]}\n  - {id: 3, stamp: 2, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[2] (id 3): region id 3 is already tracked (also regions[0])"},
    {"unknown_key", "regions:\n  - {id: 7, stamp: 1, boxx: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0] (id 7): unknown key 'boxx' (expected id, stamp, box)"},
    {"missing_stamp", "regions:\n  - {id: 7, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0] (id 7): missing field 'stamp'"},
    {"stamp_nan", "regions:\n  - {id: 7, stamp: .nan, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0] (id 7): stamp must be finite, got '.nan'"},
    {"stamp_text", "regions:\n  - {id: 7, stamp: noon, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0] (id 7): stamp must be a number, got 'noon'"},
    {"stamp_negative", "regions:\n  - {id: 7, stamp: -1, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0] (id 7): stamp must not be negative, got -1"},
    {"missing_box", "regions:\n  - {id: 7, stamp: 1}\n", "INIT.yaml: regions[0] (id 7): missing field 'box'"},
    {"box_three_numbers", "regions:\n  - {id: 1, stamp: 1, box: [1, 2, 3, 4]}\n  - {id: 2, stamp: 1, box: [1, 2, 3, 4]}\n  - {id: 7, stamp: 1, box: [1, 2, 3]}\n", "INIT.yaml: regions[2] (id 7): box must have 4 numbers, got 3"},
    {"box_scalar", "regions:\n  - {id: 7, stamp: 1, box: 5}\n", "INIT.yaml: regions[0] (id 7): box must be a list of 4 numbers, got '5'"},
    {"box_null", "regions:\n  - {id: 7, stamp: 1, box: }\n", "INIT.yaml: regions[0] (id 7): box must be a list of 4 numbers, got nothing"},
    {"box_inf", "regions:\n  - {id: 7, stamp: 1, box: [1, .inf, 3, 4]}\n", "INIT.yaml: regions[0] (id 7): box has a NaN or infinite value"},
    {"box_nested", "regions:\n  - {id: 7, stamp: 1, box: [1, [2], 3, 4]}\n", "INIT.yaml: regions[0] (id 7): box[1] must be a number, got a list of 1"},
    {"box_zero_width", "regions:\n  - {id: 7, stamp: 1, box: [1, 2, 0, 4]}\n", "INIT.yaml: regions[0] (id 7): box width and height must be positive (got 0 x 4)"},
    {"box_negative_height", "regions:\n  - {id: 7, stamp: 1, box: [1, 2, 3, -4]}\n", "INIT.yaml: regions[0] (id 7): box width and height must be positive (got 3 x -4)"},
    {"region_id_reserved", "regions:\n  - {id: 1000000000, stamp: 1, box: [1, 2, 3, 4]}\n", "INIT.yaml: regions[0] (id 1000000000): region id 1000000000 is reserved (ids must be below 1000000000)"},
    {"target_missing_size", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [1, 0], [1, 1], [0, 1]]}\n", "INIT.yaml: planar_targets[0] (id 2): missing field 'size'"},
    {"target_three_corners", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [1, 0], [1, 1]], size: [1, 1]}\n", "INIT.yaml: planar_targets[0] (id 2): corners must have 4 points (TL, TR, BR, BL), got 3"},
    {"target_corner_three_numbers", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [1, 0, 5], [1, 1], [0, 1]], size: [1, 1]}\n", "INIT.yaml: planar_targets[0] (id 2): corners[1] must have 2 numbers, got 3"},
    {"target_corner_nan", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [1, 0], [1, .NaN], [0, 1]], size: [1, 1]}\n", "INIT.yaml: planar_targets[0] (id 2): corner with a NaN or infinite coordinate"},
{"target_corners_crossed", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [10, 0], [0, 10], [10, 10]], size: [1, 1]}\n", "INIT.yaml: planar_targets[0] (id 2): quad is not convex (corners must be TL, TR, BR, BL)"},
    {"target_corners_counter_clockwise", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [0, 10], [10, 10], [10, 0]], size: [1, 1]}\n", "INIT.yaml: planar_targets[0] (id 2): corners are counter-clockwise in the image (a mirrored quad): they must be TL, TR, BR, BL, clockwise in the image"},
    {"target_corners_collinear", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [10, 0], [20, 0], [0, 10]], size: [1, 1]}\n", "INIT.yaml: planar_targets[0] (id 2): three corners are collinear"},
    {"target_corners_tiny", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [4, 0], [4, 4], [0, 4]], size: [1, 1]}\n", "INIT.yaml: planar_targets[0] (id 2): degenerate quad (area below 25 px^2)"},
    {"target_size_zero", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [10, 0], [10, 10], [0, 10]], size: [0.3, 0]}\n", "INIT.yaml: planar_targets[0] (id 2): target size must be positive (got 0.300000 x 0.000000 m)"},
    {"target_size_nan", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [10, 0], [10, 10], [0, 10]], size: [.nan, 0.2]}\n", "INIT.yaml: planar_targets[0] (id 2): target size must be positive (got nan x 0.200000 m)"},
    {"target_duplicate_id", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [10, 0], [10, 10], [0, 10]], size: [1, 1]}\n  - {id: 2, stamp: 1, corners: [[0, 0], [10, 0], [10, 10], [0, 10]], size: [1, 1]}\n", "INIT.yaml: planar_targets[1] (id 2): planar target id 2 is already tracked (also planar_targets[0])"},
    {"target_size_one_number", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [1, 0], [1, 1], [0, 1]], size: [0.3]}\n", "INIT.yaml: planar_targets[0] (id 2): size must have 2 numbers, got 1"},
    {"image_target_missing_image", "image_targets:\n  - {id: 3, size: [0.6, 0.45]}\n", "INIT.yaml: image_targets[0] (id 3): missing field 'image'"},
    {"image_target_image_list", "image_targets:\n  - {id: 3, image: [a.png], size: [0.6, 0.45]}\n", "INIT.yaml: image_targets[0] (id 3): image must be a file path, got a list of 1"},
    {"image_target_with_stamp", "image_targets:\n  - {id: 3, stamp: 1, image: a.png, size: [0.6, 0.45]}\n", "INIT.yaml: image_targets[0] (id 3): unknown key 'stamp' (expected id, image, size)"},
    {"image_target_size_zero", "image_targets:\n  - {id: 3, image: a.png, size: [0.6, 0]}\n", "INIT.yaml: image_targets[0] (id 3): target size must be positive (got 0.600000 x 0.000000 m)"},
    {"image_target_unreadable", "image_targets:\n  - {id: 3, image: /nonexistent/poster.png, size: [0.6, 0.45]}\n", "INIT.yaml: image_targets[0] (id 3): cannot read image '/nonexistent/poster.png'"},
    {"image_target_id_of_a_planar_target", "planar_targets:\n  - {id: 2, stamp: 1, corners: [[0, 0], [10, 0], [10, 10], [0, 10]], size: [1, 1]}\nimage_targets:\n  - {id: 2, image: a.png, size: [0.6, 0.45]}\n", "INIT.yaml: image_targets[0] (id 2): planar target id 2 is already tracked (also planar_targets[0])"},
    {"anchor_missing_point", "anchors:\n  - {id: 5, stamp: 1}\n", "INIT.yaml: anchors[0] (id 5): missing field 'point'"},
    {"anchor_point_three_numbers", "anchors:\n  - {id: 5, stamp: 1, point: [1, 2, 3]}\n", "INIT.yaml: anchors[0] (id 5): point must have 2 numbers, got 3"},
    {"anchor_depth_negative", "anchors:\n  - {id: 5, stamp: 1, point: [1, 2], depth: -1}\n", "INIT.yaml: anchors[0] (id 5): depth must be positive and within 0.01 .. 10000 m (0 = anchors.default_depth), got -1"},
    {"anchor_depth_nan", "anchors:\n  - {id: 5, stamp: 1, point: [1, 2], depth: .nan}\n", "INIT.yaml: anchors[0] (id 5): depth must be positive and within 0.01 .. 10000 m (0 = anchors.default_depth), got nan"},
    {"anchor_depth_tiny", "anchors:\n  - {id: 5, stamp: 1, point: [1, 2], depth: 1e-30}\n", "INIT.yaml: anchors[0] (id 5): depth must be positive and within 0.01 .. 10000 m (0 = anchors.default_depth), got 1e-30"},
    {"anchor_point_nan", "anchors:\n  - {id: 5, stamp: 1, point: [.nan, 2]}\n", "INIT.yaml: anchors[0] (id 5): pixel (nan, 2) has a NaN or infinite value"},
    {"anchor_duplicate_id", "anchors:\n  - {id: 5, stamp: 1, point: [1, 2]}\n  - {id: 5, stamp: 2, point: [1, 2]}\n", "INIT.yaml: anchors[1] (id 5): anchor id 5 is already tracked (also anchors[0])"},
    {"anchor_unknown_key", "anchors:\n  - {id: 5, stamp: 1, point: [1, 2], dept: 2}\n", "INIT.yaml: anchors[0] (id 5): unknown key 'dept' (expected id, stamp, point, depth)"},
};

INSTANTIATE_TEST_SUITE_P(Each, InitSpecBad, ::testing::ValuesIn(kBad),
                         [](const auto& info) { return std::string(info.param.name); });

// --- stamp resolution ---------------------------------------------------------

std::vector<double> frames(double first, double interval, int n) {
  std::vector<double> s;
  for (int i = 0; i < n; ++i) s.push_back(first + i * interval);
  return s;
}

TEST(ResolveStamp, PicksTheNearestFrameWithinHalfAnInterval) {
  const std::vector<double> f = frames(1000.0, 0.1, 11);  // 1000.0 .. 1001.0
  std::string err;
  EXPECT_EQ(resolveStamp(1000.0, f, "the bag", &err), 0);
  EXPECT_EQ(resolveStamp(1000.3, f, "the bag", &err), 3);
  EXPECT_EQ(resolveStamp(1000.34, f, "the bag", &err), 3);
  EXPECT_EQ(resolveStamp(1000.36, f, "the bag", &err), 4);
  EXPECT_EQ(resolveStamp(1001.0, f, "the bag", &err), 10);
  // Up to half an interval beyond the ends still selects the end frames.
  EXPECT_EQ(resolveStamp(999.951, f, "the bag", &err), 0);
  EXPECT_EQ(resolveStamp(1001.049, f, "the bag", &err), 10);
  // A stamp printed with 6 decimals (CSV) resolves to its frame even when it
  // is off by the 1 us slack.
  EXPECT_EQ(resolveStamp(1000.2000004, f, "the bag", &err), 2);
}

TEST(ResolveStamp, NamesStampsOutsideTheBag) {
  const std::vector<double> f = frames(1000.0, 1.0, 11);  // 1000 .. 1010
  std::string err;
  EXPECT_EQ(resolveStamp(1234.5, f, "the bag", &err), -1);
  EXPECT_EQ(err, "stamp 1234.5 is outside the bag (frames 1000.000000 .. 1010.000000)");
  EXPECT_EQ(resolveStamp(999.4, f, "the bag", &err), -1);  // 0.6 s before: more than half a frame
  EXPECT_EQ(err, "stamp 999.4 is outside the bag (frames 1000.000000 .. 1010.000000)");
  EXPECT_EQ(resolveStamp(1010.6, f, "the processed part", &err), -1);
  EXPECT_EQ(err, "stamp 1010.6 is outside the processed part (frames 1000.000000 .. 1010.000000)");
}

TEST(ResolveStamp, NamesAStampInAGapOfDroppedFrames) {
  // 10 Hz with frames 1000.2 .. 1000.8 dropped: the interval stays 0.1 s
  // (median spacing), so 1000.45 is 0.35 s from the nearest frame.
  const std::vector<double> f = {1000.0, 1000.1, 1000.9, 1001.0, 1001.1};
  std::string err;
  EXPECT_EQ(resolveStamp(1000.45, f, "the bag", &err), -1);
  EXPECT_EQ(err, "stamp 1000.45 is not within half a frame of any frame (nearest 1000.100000)");
  EXPECT_EQ(resolveStamp(1000.14, f, "the bag", &err), 1);  // 0.04 from 1000.1: within 0.05
  EXPECT_EQ(resolveStamp(1000.86, f, "the bag", &err), 2);
}

TEST(ResolveStamp, SingleFrameAndUnsortedInput) {
  std::string err;
  // Single-frame bag: no interval, only that stamp (with 1 us slack).
  EXPECT_EQ(resolveStamp(1000.0000005, {1000.0}, "the bag", &err), 0);
  EXPECT_EQ(resolveStamp(1000.01, {1000.0}, "the bag", &err), -1);
  EXPECT_EQ(err, "stamp 1000.01 is outside the bag (frames 1000.000000 .. 1000.000000)");
  // Unsorted input with a repeated stamp (a bag whose stamps go backwards):
  // the nearest distinct stamp is used and its first index reported.
  const std::vector<double> u = {1000.2, 1000.0, 1000.1, 1000.1, 1000.3};
  EXPECT_EQ(resolveStamp(1000.11, u, "the bag", &err), 2);
  EXPECT_EQ(resolveStamp(1000.0, u, "the bag", &err), 1);
  // An exact midpoint goes to the earlier frame (1000.25 is exactly
  // representable, as are its distances to 1000.0 and 1000.5).
  EXPECT_EQ(resolveStamp(1000.25, {1000.0, 1000.5, 1001.0}, "the bag", &err), 0);
  // No frames at all.
  EXPECT_EQ(resolveStamp(1000.0, {}, "the bag", &err), -1);
  EXPECT_EQ(err, "stamp 1000 cannot be resolved: no frames in the bag");
}

TEST(ResolveInitStamps, SetsFramesOrNamesTheEntry) {
  InitSpec spec;
  std::string err;
  ASSERT_TRUE(parseInitSpec(kValid, "INIT.yaml", &spec, &err)) << err;
  const std::vector<double> f = frames(1000.0, 0.1, 11);
  ASSERT_TRUE(resolveInitStamps(f, "INIT.yaml", "the bag", &spec, &err)) << err;
  EXPECT_EQ(spec.regions[0].frame, 0);
  EXPECT_EQ(spec.regions[1].frame, 5);
  EXPECT_EQ(spec.planar_targets[0].frame, 1);
  EXPECT_EQ(spec.anchors[0].frame, 2);
  EXPECT_EQ(spec.anchors[1].frame, 3);

  spec.anchors[1].stamp = 1234.5;
  spec.anchors[1].frame = -1;
  const InitSpec before = spec;
  EXPECT_FALSE(resolveInitStamps(f, "INIT.yaml", "the bag", &spec, &err));
  EXPECT_EQ(err,
            "INIT.yaml: anchors[1] (id 4): stamp 1234.5 is outside the bag (frames 1000.000000 .. "
            "1001.000000)");
  EXPECT_EQ(spec.anchors[1].frame, -1);  // unchanged on error
  EXPECT_EQ(spec.regions[0].frame, before.regions[0].frame);
}

}  // namespace
}  // namespace imt
