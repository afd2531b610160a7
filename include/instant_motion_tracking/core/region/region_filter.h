// A region's discriminative look: a correlation filter learned to tell the
// region from its surround, with a spatial reliability mask (CSR-DCF:
// Lukežič et al., "Discriminative Correlation Filter Tracker with Channel and
// Spatial Reliability", IJCV 2018). The region tracker uses it to place a
// region its features carry weakly (region_tracker.h): a walker whose few
// corners sit on swinging limbs, a target whose box holds much background.
//
// The filter sees a square window about the box, the box grown by three times
// its mean side (scaled to at most kWindowPx px), as 4 x 4 px cells of
// gradient orientations (9 unsigned, normalised over their neighbours, as
// HOG) and the cells' gray level. Its weights are solved for a sharp peak at
// the box's centre and kept to the box, and within it to the cells whose gray
// levels are more the box's than its surround's (a 32-bin histogram of each,
// with a prior toward the box's centre): the background inside the box, and
// what slides past it, do not vote. Each channel's vote is weighted by how
// well it alone told the region at learning. The window follows the box's
// size; the filter's cells keep their number for the region's life.
//
// Usage:
//   imt::RegionFilter f;
//   if (imt::RegionFilter::create(gray, box, &f)) {
//     imt::FilterMatch m = f.locate(next_gray, predicted_box);
//     if (m.found) predicted_box += m.shift;  // cv::Point2d
//     f.learn(next_gray, predicted_box, 0.02);
//   }
// Threading: plain value type (copies share their immutable weights; learn()
// replaces them); const methods may run concurrently (each thread keeps the
// spectra of the few filters it located last).
#pragma once

#include <opencv2/core.hpp>

#include <array>
#include <vector>

namespace imt {

// Where a region's filter finds it around a box.
struct FilterMatch {
  bool found = false;   // false: no window (the box is empty, not finite, or the filter invalid)
  cv::Point2d shift;    // px; from the box's centre to where the filter's response peaks
  double peak = 0;      // the response there (about 1 where the view is as learned)
  double psr = 0;       // the peak's height above the rest of the response, in its standard deviations
};

class RegionFilter {
 public:
  // The filter of `box` in `gray` (CV_8UC1). False when the box is not finite,
  // smaller than a cell at the window's scale, or mostly outside the image.
  static bool create(const cv::Mat& gray, const cv::Rect2d& box, RegionFilter* out);
  bool valid() const { return !weights_.empty(); }
  // Its response over the window about `box` (at `box`'s size): the shift to
  // its peak, within half the window either way.
  FilterMatch locate(const cv::Mat& gray, const cv::Rect2d& box) const;
  // The filter of `box` in `gray` blended in with weight `rate` (0 .. 1),
  // its histograms with kHistogramRate.
  void learn(const cv::Mat& gray, const cv::Rect2d& box, double rate);

  // The window's side at most (px, after scaling) and the cells' side (px).
  static constexpr int kWindowPx = 200;
  static constexpr int kCellPx = 4;
  // How fast the gray histograms of the box and its surround learn, per learn().
  static constexpr double kHistogramRate = 0.04;

 private:
  static constexpr int kBins = 32;
  using Histogram = std::array<float, kBins>;
  // The window's scale (window px per image px) for `box`; 0 when it has none.
  double scaleFor(const cv::Rect2d& box) const;
  cv::Mat window(const cv::Mat& gray, const cv::Rect2d& box, double scale) const;  // CV_8U, side cells_ * kCellPx
  std::vector<cv::Mat> features(const cv::Mat& window) const;                      // cells_ x cells_ each, windowed
  void histograms(const cv::Mat& window, const cv::Size2d& target, Histogram* fg, Histogram* bg) const;
  cv::Mat mask(const cv::Mat& window, const cv::Size2d& target) const;  // CV_32F, cells_ x cells_, 0 / 1
  // The filter (each channel's weights within rect_) and its channels'
  // weights solved on `f` (features()) with `mask`.
  void train(const std::vector<cv::Mat>& f, const cv::Mat& mask, std::vector<cv::Mat>* h,
             std::vector<float>* weights) const;

  int cells_ = 0;          // the window's side in cells
  double side_ratio_ = 0;  // the window's side (image px) per box size (the geometric mean of its sides)
  cv::Rect rect_;          // the box's cells in the window
  cv::Mat label_;          // the wanted response's spectrum (CV_32FC2), a peak at zero shift
  cv::Mat hann_;           // CV_32F, cells_ x cells_
  std::vector<cv::Mat> h_;  // per channel, CV_32F, rect_.size()
  std::vector<float> weights_;  // per channel, summing to 1
  Histogram fg_{}, bg_{};  // the box's and its surround's gray levels, each summing to 1
};

}  // namespace imt
