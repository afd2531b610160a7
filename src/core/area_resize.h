// cv::resize(src, dst, size, 0, 0, cv::INTER_AREA), bit for bit, faster
// where OpenCV takes its general path (a CV_8UC1 image shrunk by factors
// not both whole, as what is left after exact halvings): there OpenCV's is
// scalar (480 x 640 -> 320 x 427, one core: 0.55 ms). This one is
// separable, its loops over whole rows (the frame transposed for the sums
// across), which the compiler vectorises: 0.21 ms there. OpenCV's weights
// (each source pixel's overlap with the output pixel, slivers under 1e-3 px
// left out), its order of float sums and its rounding: the output is
// OpenCV's on every size tested (test_area_resize.cpp). Anything else goes
// to OpenCV's own.
//
// Usage:
//   imt::AreaResize r;
//   r.apply(gray, cv::Size(320, 427), &small);  // scratch kept in `r` between frames
#pragma once

#include <opencv2/core.hpp>

#include <vector>

namespace imt {

class AreaResize {
 public:
  // `src` resized to `size` into `dst`, as by cv::INTER_AREA. An empty
  // `src` or a side under 1: dst released, false.
  bool apply(const cv::Mat& src, cv::Size size, cv::Mat* dst);

 private:
  // One axis: output pixel i takes the sum over taps [start[i], start[i+1])
  // of weight[t] times source pixel index[t].
  struct Taps {
    int from = 0, to = 0;  // the sizes the table was made for
    std::vector<int> start, index;
    std::vector<float> weight;
  };
  static void make(int from, int to, Taps* taps);
  Taps x_, y_;
  cv::Mat src_t_;     // the source transposed
  cv::Mat across_t_;  // CV_32F, size.width x src.rows: each source row's sums, transposed
  cv::Mat across_;    // and back: src.rows x size.width
  cv::Mat block_;     // CV_32F: a block of output rows before rounding
};

}  // namespace imt
