#include "instant_motion_tracking/io/csv_writer.h"
#include "instant_motion_tracking/io/summary.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

namespace imt {
namespace {

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string tempPath(const std::string& name) { return ::testing::TempDir() + "/" + name; }

TEST(CsvRow, FormatsEachKindOfField) {
  CsvRow r;
  r.stamp(1000.0333333333)
      .number(0.5)
      .number(1e-5)
      .number(-3)
      .number(std::nan(""))
      .number(std::numeric_limits<double>::infinity())
      .integer(-42)
      .text("homography")
      .text("a,b")
      .text("say \"hi\"")
      .empty();
  const std::vector<std::string> expected = {
      "1000.033333333", "0.5", "1e-05", "-3", "", "", "-42", "homography", "\"a,b\"",
      "\"say \"\"hi\"\"\"", ""};
  EXPECT_EQ(r.fields(), expected);
}

TEST(CsvRow, ShortestFormReadsBackExactly) {
  // The CSV is the tool's output of record: H entries must survive a round trip.
  for (double v : {0.1, 1.0 / 3.0, -2.5e-7, 1234567.891011, 1e300, 5e-324}) {
    const std::string s = formatShortest(v);
    EXPECT_EQ(std::strtod(s.c_str(), nullptr), v) << s;
  }
  EXPECT_EQ(formatFixed(1000.5, 6), "1000.500000");
}

TEST(CsvWriter, WritesHeaderAndRowsAndChecksTheWidth) {
  const std::string path = tempPath("imt_csv_writer_test.csv");
  CsvWriter w;
  std::string err;
  ASSERT_TRUE(w.open(path, {"stamp", "id", "status"}, &err)) << err;
  EXPECT_TRUE(w.write(CsvRow().stamp(1.0).integer(3).text("tracked"), &err)) << err;
  EXPECT_TRUE(w.write(CsvRow().stamp(2.0).integer(4).empty(), &err)) << err;
  EXPECT_FALSE(w.write(CsvRow().stamp(3.0).integer(5), &err));  // one field short
  EXPECT_EQ(err, path + ": row has 2 fields, the header 3");
  EXPECT_EQ(w.rows(), 2u);
  ASSERT_TRUE(w.close(&err)) << err;
  EXPECT_EQ(readFile(path), "stamp,id,status\n1.000000000,3,tracked\n2.000000000,4,\n");
  // Reopening truncates (the spec: CSV files are overwritten).
  ASSERT_TRUE(w.open(path, {"a"}, &err)) << err;
  ASSERT_TRUE(w.close(&err)) << err;
  EXPECT_EQ(readFile(path), "a\n");
  std::remove(path.c_str());
}

TEST(CsvWriter, NamesAFileItCannotCreate) {
  CsvWriter w;
  std::string err;
  EXPECT_FALSE(w.open("/nonexistent_dir_imt/x.csv", {"a"}, &err));
  EXPECT_EQ(err, "/nonexistent_dir_imt/x.csv: cannot create the file: No such file or directory");
  EXPECT_FALSE(w.write(CsvRow().integer(1), &err));
}

TEST(CsvWriter, ReportsAFullDisk) {
  // /dev/full accepts the open and fails every write with ENOSPC.
  std::ifstream probe("/dev/full");
  if (!probe) GTEST_SKIP() << "no /dev/full";
  CsvWriter w;
  std::string err;
  bool ok = w.open("/dev/full", cameraMotionColumns(), &err);
  for (int i = 0; ok && i < 100000; ++i) ok = w.write(cameraMotionRow(MotionData()), &err);
  if (ok) ok = w.close(&err);
  EXPECT_FALSE(ok);
  EXPECT_NE(err.find("/dev/full"), std::string::npos) << err;
}

TEST(CsvColumns, MatchTheSpec) {
  // Spelled out from docs (interface.md, "Output CSV files"): these strings
  // are the contract scripts are written against.
  auto join = [](const std::vector<std::string>& c) {
    std::string s;
    for (size_t i = 0; i < c.size(); ++i) s += (i ? "," : "") + c[i];
    return s;
  };
  EXPECT_EQ(join(cameraMotionColumns()),
            "stamp,model,h00,h01,h02,h10,h11,h12,h20,h21,h22,features,inliers");
  EXPECT_EQ(join(regionColumns()), "stamp,id,x,y,width,height,status,confidence,angle,rect_width,rect_height");
  EXPECT_EQ(join(planarTargetColumns()),
            "stamp,id,x0,y0,x1,y1,x2,y2,x3,y3,tx,ty,tz,qx,qy,qz,qw,status");
  EXPECT_EQ(join(anchorColumns()), "stamp,id,u,v,tx,ty,tz,qx,qy,qz,qw,status");
}

TEST(CameraMotionRow, HoldsStampModelRowMajorHAndCounts) {
  MotionData md;
  md.stamp = 1000.1;
  md.camera.model = MotionModel::kSimilarity;
  md.camera.H << 1.01, -0.02, 3.5, 0.02, 1.01, -2.25, 0, 0, 1;
  md.camera.features = 120;
  md.camera.inliers = 100;
  const std::vector<std::string> expected = {"1000.100000000", "similarity", "1.01", "-0.02",
                                             "3.5", "0.02", "1.01", "-2.25", "0", "0", "1",
                                             "120", "100"};
  EXPECT_EQ(cameraMotionRow(md).fields(), expected);
  EXPECT_EQ(cameraMotionRow(md).size(), cameraMotionColumns().size());
}

// A region's row: the extent of the turned region as the box, then its
// status, confidence, turn and own rectangle; a lost one has no estimate.
TEST(RegionRow, HoldsTheTurnedExtentTheTurnAndTheRectangle) {
  RegionState s = RegionState::start(7, cv::Rect2d(10, 20, 40, 20), 1000.5);
  s.confidence = 0.75;
  EXPECT_EQ(regionRow(s).fields(), (std::vector<std::string>{"1000.500000000", "7", "10", "20", "40", "20",
                                                              "tracked", "0.75", "0", "40", "20"}));
  s.angle = M_PI / 2;  // a quarter turn: the extent is 20 wide, 40 high (to the soft threshold's 1%)
  const std::vector<std::string> f = regionRow(s).fields();
  ASSERT_EQ(f.size(), regionColumns().size());
  EXPECT_NEAR(std::stod(f[4]), 20, 0.3);
  EXPECT_NEAR(std::stod(f[5]), 40, 0.3);
  EXPECT_EQ(f[9], "40");
  s.status = RegionStatus::kLost;
  EXPECT_EQ(regionRow(s).fields(),
            (std::vector<std::string>{"1000.500000000", "7", "", "", "", "", "lost", "0.75", "", "", ""}));
}

TEST(RunSummary, HasFramesSecondsRateAndStages) {
  RunSummary s;
  s.frames = 200;
  s.seconds = 2.0;
  s.stage_seconds["motion_analysis"] = 1.5;
  s.stage_seconds["decode"] = 0.2;
  s.details["image_topic"] = "/camera/image_raw";
  const nlohmann::json j = s.toJson();
  EXPECT_EQ(j["frames"], 200);
  EXPECT_DOUBLE_EQ(j["seconds"].get<double>(), 2.0);
  EXPECT_DOUBLE_EQ(j["frames_per_second"].get<double>(), 100.0);
  EXPECT_DOUBLE_EQ(j["stages"]["motion_analysis"]["seconds"].get<double>(), 1.5);
  EXPECT_DOUBLE_EQ(j["stages"]["motion_analysis"]["ms_per_frame"].get<double>(), 7.5);
  EXPECT_DOUBLE_EQ(j["stages"]["decode"]["ms_per_frame"].get<double>(), 1.0);
  EXPECT_EQ(j["image_topic"], "/camera/image_raw");

  RunSummary none;  // no frames, no time: no division by zero, nulls instead
  const nlohmann::json n = none.toJson();
  EXPECT_TRUE(n["frames_per_second"].is_null());

  const std::string path = tempPath("imt_summary_test.json");
  std::string err;
  ASSERT_TRUE(writeJsonFile(path, j, &err)) << err;
  EXPECT_EQ(nlohmann::json::parse(readFile(path)), j);
  std::remove(path.c_str());
  EXPECT_FALSE(writeJsonFile("/nonexistent_dir_imt/summary.json", j, &err));
  EXPECT_EQ(err.rfind("/nonexistent_dir_imt/summary.json: cannot create the file", 0), 0u) << err;
}

}  // namespace
}  // namespace imt
