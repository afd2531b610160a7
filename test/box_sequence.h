// Reader of the real box-tracking sequences in ../shared/data (VOT2015 car1,
// UAV123 boat1, OTB Human3, and POT-210's corner boxes) for the real-data
// tests and benchmarks: each sequence's frame files, its per-frame
// axis-aligned ground-truth box in 0-based pixels, and its frame rate. Frames
// are numbered from 1, as in the datasets. Every folder's README gives the
// format this reads:
//   VOT    one line per frame, 8 comma-separated corner coordinates of a
//          rotated box (order varies): scored by their bounding box.
//   OTB    one line per frame, x,y,w,h, 1-based (UAV123 is the same).
//   POT    the official corners and flags (pot210.h): unflagged frames only.
#pragma once

#include "box_metrics.h"
#include "pot210.h"

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>
#include <vector>

namespace imt {
namespace test {

class BoxSequence {
 public:
  // The real sequences with box ground truth under `data_dir`, in a fixed
  // order; those whose files are missing are left out.
  static std::vector<BoxSequence> all(const std::string& data_dir) {
    std::vector<BoxSequence> out;
    BoxSequence s;
    if (s.loadVot(data_dir + "/vot2015_car1", "vot2015_car1", "img/%08d.jpg", 252, 30)) out.push_back(s);
    if (s.loadOtb(data_dir + "/uav123_10fps_boat1", "uav123_10fps_boat1", "img/%06d.jpg", 10)) out.push_back(s);
    if (s.loadOtb(data_dir + "/otb_human3_first199", "otb_human3_first199", "img/%04d.jpg", 30)) out.push_back(s);
    for (const auto& [name, frames] : {std::pair<const char*, int>{"V25_2", 50}, {"V24_7", 110}})
      if (s.loadPot(data_dir + "/pot210_excerpt", name, frames)) out.push_back(s);
    return out;
  }

  // Every `stride`-th frame of this sequence from its first (1, 1 + stride,
  // ...), renumbered from 1, at fps / stride: the same video seen by a slower
  // camera, whose targets move `stride` times as far between frames.
  BoxSequence strided(int stride) const {
    if (stride <= 1) return *this;
    BoxSequence s = *this;
    s.boxes_.clear();
    s.scored_.clear();
    s.files_.clear();
    s.fps_ = fps_ / stride;
    for (int f = 1; f <= frames(); f += stride) {
      s.boxes_.push_back(box(f));
      s.scored_.push_back(scored(f));
      s.files_.push_back(file(f));
    }
    s.name_ = name_ + "/" + std::to_string(stride);
    return s;
  }

  const std::string& name() const { return name_; }
  int frames() const { return static_cast<int>(boxes_.size()); }
  double fps() const { return fps_; }
  double stamp(int f) const { return f / fps_; }
  // Frame f has a ground-truth box that counts in the score.
  bool scored(int f) const { return scored_[f - 1]; }
  // `frames` (frames[f - 1] is frame f) by stamp, for
  // TrackingSession::setImageSource(): empty for a stamp of no frame. Both
  // must outlive the function.
  std::function<cv::Mat(double)> framesByStamp(const std::vector<cv::Mat>& frames) const {
    return [this, &frames](double stamp) {
      const int f = static_cast<int>(std::lround(stamp * fps_));
      return f >= 1 && f <= std::min(this->frames(), static_cast<int>(frames.size())) ? frames[f - 1] : cv::Mat();
    };
  }
  // The frame a box is given at mid-sequence: the first scored one from half way.
  int middleFrame() const {
    for (int f = std::max(1, frames() / 2); f <= frames(); ++f)
      if (scored(f)) return f;
    return std::max(1, frames() / 2);
  }
  // The ground-truth box of frame f (0-based pixels, top-left pixel corner at (0, 0)).
  const cv::Rect2d& box(int f) const { return boxes_[f - 1]; }
  // Frame f in colour / gray (empty when it cannot be read).
  cv::Mat colour(int f) const { return cv::imread(path(f), cv::IMREAD_COLOR); }
  // Gray as a camera driver's colour frame becomes mono (cv_bridge's
  // cvtColor), not libjpeg's own gray decode: the two differ in the last bit.
  cv::Mat gray(int f) const {
    const cv::Mat c = colour(f);
    cv::Mat g;
    if (!c.empty()) cv::cvtColor(c, g, cv::COLOR_BGR2GRAY);
    return g;
  }

 private:
  // The dataset's number of frame f (not f in a strided() copy).
  int file(int f) const { return files_.empty() ? f : files_[f - 1]; }
  std::string path(int f) const {
    char name[64];
    std::snprintf(name, sizeof(name), pattern_.c_str(), file(f));
    return dir_ + "/" + name;
  }

  static std::vector<std::vector<double>> readCsvRows(const std::string& path) {
    std::vector<std::vector<double>> rows;
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line)) {
      std::replace(line.begin(), line.end(), ',', ' ');
      std::istringstream ss(line);
      std::vector<double> v;
      double x;
      while (ss >> x) v.push_back(x);
      if (!v.empty()) rows.push_back(v);
    }
    return rows;
  }

  void begin(const std::string& dir, const std::string& name, const std::string& pattern, double fps) {
    dir_ = dir;
    name_ = name;
    pattern_ = pattern;
    fps_ = fps;
    boxes_.clear();
    scored_.clear();
    files_.clear();
  }

  bool loadVot(const std::string& dir, const std::string& name, const std::string& pattern, int frames,
               double fps) {
    begin(dir, name, pattern, fps);
    const auto rows = readCsvRows(dir + "/groundtruth.txt");
    if (static_cast<int>(rows.size()) < frames) return false;
    for (int f = 0; f < frames; ++f) {
      const std::vector<double>& r = rows[f];
      bool ok = r.size() == 8 && std::all_of(r.begin(), r.end(), [](double x) { return std::isfinite(x); });
      double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
      for (size_t i = 0; ok && i < 4; ++i) {
        x0 = std::min(x0, r[2 * i]);
        x1 = std::max(x1, r[2 * i]);
        y0 = std::min(y0, r[2 * i + 1]);
        y1 = std::max(y1, r[2 * i + 1]);
      }
      ok = ok && x1 > x0 && y1 > y0;
      boxes_.push_back(ok ? cv::Rect2d(x0, y0, x1 - x0, y1 - y0) : cv::Rect2d());
      scored_.push_back(ok);
    }
    return true;
  }

  bool loadOtb(const std::string& dir, const std::string& name, const std::string& pattern, double fps) {
    begin(dir, name, pattern, fps);
    const auto rows = readCsvRows(dir + "/groundtruth_rect.txt");
    for (const std::vector<double>& r : rows) {
      const bool ok = r.size() == 4 && std::isfinite(r[0]) && std::isfinite(r[1]) && r[2] > 0 && r[3] > 0;
      boxes_.push_back(ok ? cv::Rect2d(r[0] - 1, r[1] - 1, r[2], r[3]) : cv::Rect2d());  // 1-based
      scored_.push_back(ok);
    }
    return !boxes_.empty();
  }

  bool loadPot(const std::string& dir, const std::string& name, int frames) {
    PotSequence pot;
    if (!pot.load(dir, name, frames)) return false;
    begin(dir, "pot210_" + name, name + "/img/%08d.jpg", 30);
    for (int f = 1; f <= frames; ++f) {
      boxes_.push_back(pot.box(f));
      scored_.push_back(pot.scored(f));
    }
    return true;
  }

  std::string dir_, name_, pattern_;
  double fps_ = 30;
  std::vector<cv::Rect2d> boxes_;
  std::vector<bool> scored_;
  std::vector<int> files_;  // strided(): the dataset's number of each frame; empty: f itself
};

// Success and precision of one tracker over one sequence (OTB definitions).
// Frames count from the second; a frame without a box (lost) counts as IoU 0
// and as a precision miss.
class BoxScore {
 public:
  void add(bool has_box, const cv::Rect2d& box, const cv::Rect2d& truth, cv::Size image) {
    const double iou = has_box ? iouClipped(box, truth, image) : 0.0;
    ious_.push_back(iou);
    const cv::Point2d d = (box.tl() + box.br()) / 2 - (truth.tl() + truth.br()) / 2;
    hits20_ += has_box && std::hypot(d.x, d.y) <= 20.0;
  }
  int frames() const { return static_cast<int>(ious_.size()); }
  double meanIou() const {
    double s = 0;
    for (double v : ious_) s += v;
    return ious_.empty() ? 0 : s / ious_.size();
  }
  // Mean over thresholds 0, 0.05, ..., 1 of the fraction of frames whose IoU
  // exceeds the threshold.
  double successAuc() const {
    if (ious_.empty()) return 0;
    double s = 0;
    for (int k = 0; k <= 20; ++k) {
      const double t = 0.05 * k;
      s += static_cast<double>(std::count_if(ious_.begin(), ious_.end(), [&](double v) { return v > t; })) /
           ious_.size();
    }
    return s / 21;
  }
  double precision20() const { return ious_.empty() ? 0 : static_cast<double>(hits20_) / ious_.size(); }

 private:
  std::vector<double> ious_;
  int hits20_ = 0;
};

}  // namespace test
}  // namespace imt
