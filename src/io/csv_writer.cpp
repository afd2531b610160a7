#include "instant_motion_tracking/io/csv_writer.h"

#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>

namespace imt {

std::string formatShortest(double v) {
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

std::string formatFixed(double v, int decimals) {
  char buf[128];
  const int n = std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  if (n < 0 || n >= static_cast<int>(sizeof(buf))) return formatShortest(v);  // |v| > 1e100
  return std::string(buf, n);
}

CsvRow& CsvRow::stamp(double seconds) {
  fields_.push_back(std::isfinite(seconds) ? formatFixed(seconds, 9) : std::string());
  return *this;
}

CsvRow& CsvRow::number(double v) {
  fields_.push_back(std::isfinite(v) ? formatShortest(v) : std::string());
  return *this;
}

CsvRow& CsvRow::integer(int64_t v) {
  fields_.push_back(std::to_string(v));
  return *this;
}

CsvRow& CsvRow::text(const std::string& s) {
  if (s.find_first_of(",\"\r\n") == std::string::npos) {
    fields_.push_back(s);
    return *this;
  }
  std::string q = "\"";
  for (char c : s) {
    if (c == '"') q += '"';
    q += c;
  }
  q += '"';
  fields_.push_back(q);
  return *this;
}

CsvRow& CsvRow::empty() {
  fields_.emplace_back();
  return *this;
}

bool CsvWriter::open(const std::string& path, const std::vector<std::string>& columns,
                     std::string* error) {
  if (out_.is_open()) out_.close();
  path_ = path;
  columns_ = columns.size();
  rows_ = 0;
  out_.open(path, std::ios::out | std::ios::trunc | std::ios::binary);
  if (!out_) {
    *error = path + ": cannot create the file: " + std::strerror(errno);
    return false;
  }
  writeFields(columns);
  if (!out_) {
    *error = path + ": write failed";
    return false;
  }
  return true;
}

void CsvWriter::writeFields(const std::vector<std::string>& fields) {
  for (size_t i = 0; i < fields.size(); ++i) {
    if (i) out_.put(',');
    out_.write(fields[i].data(), static_cast<std::streamsize>(fields[i].size()));
  }
  out_.put('\n');
}

bool CsvWriter::write(const CsvRow& row, std::string* error) {
  if (!out_.is_open()) {
    *error = (path_.empty() ? std::string("CSV writer") : path_) + ": not open";
    return false;
  }
  if (row.size() != columns_) {
    *error = path_ + ": row has " + std::to_string(row.size()) + " fields, the header " +
             std::to_string(columns_);
    return false;
  }
  writeFields(row.fields());
  if (!out_) {
    *error = path_ + ": write failed";
    return false;
  }
  ++rows_;
  return true;
}

bool CsvWriter::close(std::string* error) {
  if (!out_.is_open()) return true;
  out_.flush();
  const bool ok = static_cast<bool>(out_);
  out_.close();
  if (!ok || out_.fail()) {
    *error = path_ + ": write failed (disk full?)";
    return false;
  }
  return true;
}

const std::vector<std::string>& cameraMotionColumns() {
  static const std::vector<std::string> c = {"stamp", "model", "h00", "h01", "h02",
                                             "h10",   "h11",   "h12", "h20", "h21",
                                             "h22",   "features", "inliers"};
  return c;
}

const std::vector<std::string>& regionColumns() {
  static const std::vector<std::string> c = {"stamp",  "id",         "x",          "y",
                                             "width",  "height",     "status",     "confidence",
                                             "angle",  "rect_width", "rect_height"};
  return c;
}

const std::vector<std::string>& planarTargetColumns() {
  static const std::vector<std::string> c = {"stamp", "id", "x0", "y0", "x1", "y1", "x2",
                                             "y2",    "x3", "y3", "tx", "ty", "tz", "qx",
                                             "qy",    "qz", "qw", "status"};
  return c;
}

const std::vector<std::string>& anchorColumns() {
  static const std::vector<std::string> c = {"stamp", "id", "u",  "v",  "tx", "ty",
                                             "tz",    "qx", "qy", "qz", "qw", "status"};
  return c;
}

CsvRow cameraMotionRow(const MotionData& md) {
  CsvRow row;
  row.stamp(md.stamp).text(motionModelName(md.camera.model));
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) row.number(md.camera.H(r, c));
  row.integer(md.camera.features).integer(md.camera.inliers);
  return row;
}

CsvRow regionRow(const RegionState& s) {
  CsvRow row;
  row.stamp(s.stamp).integer(s.id);
  if (s.status == RegionStatus::kLost) {
    row.empty().empty().empty().empty();
  } else {
    const cv::Rect2d b = s.extent();
    row.number(b.x).number(b.y).number(b.width).number(b.height);
  }
  row.text(regionStatusName(s.status)).number(s.confidence);
  if (s.status == RegionStatus::kLost) return row.empty().empty().empty();
  return row.number(s.angle).number(s.box.width).number(s.box.height);
}

CsvRow planarTargetRow(const PlanarTargetState& s) {
  CsvRow row;
  row.stamp(s.stamp).integer(s.id);
  const bool lost = !s.hasPose();
  for (const cv::Point2d& c : s.corners) {
    row.number(lost ? NAN : c.x).number(lost ? NAN : c.y);
  }
  const Eigen::Vector3d t = s.T_cam_target.translation();
  const Eigen::Quaterniond q(s.T_cam_target.linear());
  for (double v : {t.x(), t.y(), t.z(), q.x(), q.y(), q.z(), q.w()}) row.number(lost ? NAN : v);
  return row.text(targetStatusName(s.status));
}

CsvRow anchorRow(double stamp, uint32_t id, const cv::Point2d& uv, const Eigen::Isometry3d& T_cam_anchor,
                 const std::string& status, bool has_estimate, bool has_rotation) {
  CsvRow row;
  row.stamp(stamp).integer(id);
  const Eigen::Vector3d t = T_cam_anchor.translation();
  const Eigen::Quaterniond q(T_cam_anchor.linear());
  for (double v : {uv.x, uv.y, t.x(), t.y(), t.z()}) row.number(has_estimate ? v : NAN);
  for (double v : {q.x(), q.y(), q.z(), q.w()}) row.number(has_estimate && has_rotation ? v : NAN);
  return row.text(status);
}

}  // namespace imt
