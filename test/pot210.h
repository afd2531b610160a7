// Reader of the POT-210 excerpt (../shared/data/pot210_excerpt): a sequence's
// frames and its official ground truth (four corners per frame, flags), for
// the real-data tests and benchmarks. Frames are numbered from 1, as in POT.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <array>
#include <cstdio>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace imt {
namespace test {

class PotSequence {
 public:
  // False when the annotation files are missing or shorter than `frames`.
  bool load(const std::string& pot_dir, const std::string& name, int frames) {
    dir_ = pot_dir;
    name_ = name;
    gt_ = readRows(pot_dir + "/annotation/" + name + "_gt_points.txt");
    flags_ = readRows(pot_dir + "/annotation/" + name + "_flag.txt");
    const bool ok = static_cast<int>(gt_.size()) >= frames && static_cast<int>(flags_.size()) >= frames;
    frames_ = ok ? frames : 0;
    return ok;
  }
  const std::string& name() const { return name_; }
  int frames() const { return frames_; }  // 0 until a load succeeded

  // Frame f is annotated and not flagged (POT scores only those).
  bool scored(int f) const {
    const std::vector<double>& g = gt_[f - 1];
    const bool annotated = g.size() == 8 && (g[0] != 0 || g[1] != 0);
    return annotated && !flags_[f - 1].empty() && flags_[f - 1][0] == 0;
  }
  // The target's corners (TL, TR, BR, BL) in frame f; the first frame's are
  // the initialisation.
  std::array<cv::Point2d, 4> corners(int f) const {
    std::array<cv::Point2d, 4> c;
    for (int i = 0; i < 4; ++i) c[i] = cv::Point2d(gt_[f - 1][2 * i], gt_[f - 1][2 * i + 1]);
    return c;
  }
  // Their axis-aligned bounding box: what a box tracker is scored against.
  cv::Rect2d box(int f) const {
    const auto c = corners(f);
    double x0 = c[0].x, y0 = c[0].y, x1 = c[0].x, y1 = c[0].y;
    for (const cv::Point2d& p : c) {
      x0 = std::min(x0, p.x);
      y0 = std::min(y0, p.y);
      x1 = std::max(x1, p.x);
      y1 = std::max(y1, p.y);
    }
    return cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
  }
  // Frame f in gray (empty when it cannot be read).
  cv::Mat gray(int f) const {
    char file[64];
    std::snprintf(file, sizeof(file), "/%s/img/%08d.jpg", name_.c_str(), f);
    return cv::imread(dir_ + file, cv::IMREAD_GRAYSCALE);
  }

 private:
  static std::vector<std::vector<double>> readRows(const std::string& path) {
    std::vector<std::vector<double>> rows;
    std::ifstream in(path);
    std::string line;
    while (std::getline(in, line)) {
      std::istringstream ss(line);
      std::vector<double> v;
      double x;
      while (ss >> x) v.push_back(x);
      rows.push_back(v);
    }
    return rows;
  }

  std::string dir_, name_;
  int frames_ = 0;
  std::vector<std::vector<double>> gt_, flags_;
};

}  // namespace test
}  // namespace imt
