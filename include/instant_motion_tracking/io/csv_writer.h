// CSV output of track_bag (no ROS): a small writer every tracker reuses, the
// spec's column lists (docs: interface.md, "Output CSV files") and the
// camera-motion row.
//
// Usage:
//   imt::CsvWriter csv;
//   std::string err;
//   if (!csv.open(dir + "/camera_motion.csv", imt::cameraMotionColumns(), &err)) die(err);
//   if (!csv.write(imt::cameraMotionRow(md), &err)) die(err);
//   if (!csv.close(&err)) die(err);            // flushes; reports a full disk
//
// Formatting: stamps fixed with 9 decimals; other numbers in the shortest
// form that reads back to the same double ("0.5", "1e-05"); a non-finite
// number is written as an empty field (no estimate); text is quoted only when
// it holds a comma, a quote or a line break (RFC 4180).
// Threading: one writer per thread.
#pragma once

#include "instant_motion_tracking/core/planar/planar_target.h"
#include "instant_motion_tracking/core/region/region_tracker.h"
#include "instant_motion_tracking/core/types.h"

#include <cstdint>
#include <fstream>
#include <string>
#include <vector>

namespace imt {

// One row under construction.
class CsvRow {
 public:
  CsvRow& stamp(double seconds);      // "1000.033333333"
  CsvRow& number(double v);           // shortest round-trip form; empty when not finite
  CsvRow& integer(int64_t v);
  CsvRow& text(const std::string& s);
  CsvRow& empty();                    // an empty field (no estimate)
  size_t size() const { return fields_.size(); }
  const std::vector<std::string>& fields() const { return fields_; }

 private:
  std::vector<std::string> fields_;
};

class CsvWriter {
 public:
  CsvWriter() = default;
  ~CsvWriter() = default;
  CsvWriter(const CsvWriter&) = delete;
  CsvWriter& operator=(const CsvWriter&) = delete;

  // Creates or truncates `path` and writes the header row. False with a
  // message naming the file when it cannot be opened.
  bool open(const std::string& path, const std::vector<std::string>& columns, std::string* error);
  // Appends a row. False when the row's width differs from the header's
  // (a programming error, named) or the write failed.
  bool write(const CsvRow& row, std::string* error);
  // Flushes and closes. False on an I/O error (e.g. disk full).
  bool close(std::string* error);

  bool isOpen() const { return out_.is_open(); }
  const std::string& path() const { return path_; }
  size_t columns() const { return columns_; }
  size_t rows() const { return rows_; }  // data rows written, header excluded

 private:
  void writeFields(const std::vector<std::string>& fields);
  std::ofstream out_;
  std::string path_;
  size_t columns_ = 0;
  size_t rows_ = 0;
};

// Shortest decimal text that reads back as `v` (std::to_chars).
std::string formatShortest(double v);
// `v` with exactly `decimals` digits after the point.
std::string formatFixed(double v, int decimals);

// The spec's columns, in order.
const std::vector<std::string>& cameraMotionColumns();  // stamp,model,h00..h22,features,inliers
const std::vector<std::string>& regionColumns();        // stamp,id,x,y,width,height,status,confidence,angle,rect_width,rect_height
const std::vector<std::string>& planarTargetColumns();  // stamp,id,x0..y3,tx,ty,tz,qx,qy,qz,qw,status
const std::vector<std::string>& anchorColumns();        // stamp,id,u,v,tx,ty,tz,qx,qy,qz,qw,status

// One camera_motion.csv row of a frame's motion data.
CsvRow cameraMotionRow(const MotionData& md);
// One regions.csv row (box, angle and rect columns empty when the region is lost).
CsvRow regionRow(const RegionState& s);
// One planar_targets.csv row (every estimate column empty when lost).
CsvRow planarTargetRow(const PlanarTargetState& s);
// One anchors.csv row; the estimate columns are empty when `has_estimate` is
// false, the rotation's (qx..qw) also when `has_rotation` is (calibrating).
CsvRow anchorRow(double stamp, uint32_t id, const cv::Point2d& uv, const Eigen::Isometry3d& T_cam_anchor,
                 const std::string& status, bool has_estimate, bool has_rotation = true);

}  // namespace imt
