// cv::cornerMinEigenVal(gray(area), out, 3, 3) to float rounding, in a third
// of OpenCV's time on the small cells the feature tracker detects corners
// in (one core, a 42 x 42 cell of a 320 x 240 frame: 5.8 us against 17.3;
// benchmark_motion_analysis, BM_CornerMapVsOpenCv). OpenCV's pays for its
// general path on each call: two Sobel images, the covariance image and a
// box filter, each allocated and bordered. Here the 3 x 3 Sobel, the
// gradients' products and their 3 x 3 sums are exact integers over three
// rolling rows, and only the eigenvalue is float. The same pixels outside
// `area` (the frame's own, as OpenCV reads outside a submatrix, reflected
// at the frame's edges) and the same reflection of the sums at the area's
// edges. `gray` is taken as a whole image: where it is a window into a
// larger one, its edges are reflected too (OpenCV would read past them).
// Its map is OpenCV's to 1e-6 of the area's largest eigenvalue
// (test_min_eigenvalues.cpp). Its file is built with the full vectoriser
// cost model and without math errno (CMakeLists.txt).
//
// Usage (one object a thread; it keeps its row buffers between calls):
//   imt::MinEigenvalues eig;
//   cv::Mat map;  // CV_32F, area.size()
//   eig.apply(gray, cell, &map);
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace imt {

class MinEigenvalues {
 public:
  // The smaller eigenvalue of each pixel's 3 x 3 gradient covariance
  // (3 x 3 Sobel, scaled as OpenCV scales it for 8-bit input) over `area`
  // of `gray` into `out`. False, `out` untouched, when `gray` is not a
  // non-empty CV_8UC1 image or `area` is empty or not inside it.
  bool apply(const cv::Mat& gray, const cv::Rect& area, cv::Mat* out);

 private:
  std::vector<int16_t> diff_, smooth_;    // 3 rolling image rows: horizontal [-1 0 1] and [1 2 1]
  std::vector<int32_t> xx_, xy_, yy_;     // the gradients' products along one row
  std::vector<int32_t> hxx_, hxy_, hyy_;  // their sums of three across, 3 rows rolling
  std::vector<uint8_t> row_;              // a row with its reflected ends, at the frame's edges
};

}  // namespace imt
