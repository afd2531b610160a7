#include "area_resize.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace imt {

void AreaResize::make(int from, int to, Taps* taps) {
  if (taps->from == from && taps->to == to) return;
  taps->from = from;
  taps->to = to;
  taps->start.assign(1, 0);
  taps->index.clear();
  taps->weight.clear();
  // OpenCV's table (computeResizeAreaTab in imgproc/resize.cpp), in double:
  // output pixel i covers [i s, (i + 1) s) of the source, s = from / to.
  const double scale = 1.0 / (static_cast<double>(to) / from);
  const auto add = [taps](int index, double weight) {
    taps->index.push_back(index);
    taps->weight.push_back(static_cast<float>(weight));
  };
  for (int i = 0; i < to; ++i) {
    const double f1 = i * scale, f2 = f1 + scale;
    const double cell = std::min(scale, from - f1);
    int s2 = static_cast<int>(std::floor(f2));
    s2 = std::min(s2, from - 1);
    const int s1 = std::min(static_cast<int>(std::ceil(f1)), s2);
    if (s1 - f1 > 1e-3) add(s1 - 1, (s1 - f1) / cell);
    for (int s = s1; s < s2; ++s) add(s, 1.0 / cell);
    if (f2 - s2 > 1e-3) add(s2, std::min(std::min(f2 - s2, 1.0), cell) / cell);
    taps->start.push_back(static_cast<int>(taps->index.size()));
  }
}

bool AreaResize::apply(const cv::Mat& src, cv::Size size, cv::Mat* dst) {
  if (src.empty() || size.width < 1 || size.height < 1) {
    dst->release();
    return false;
  }
  // OpenCV's own where it does not take its general path: whole factors on
  // both sides (its fast path), a side enlarged (no area average then), and
  // other pixel types. Its test, in double.
  const double fx = 1.0 / (static_cast<double>(size.width) / src.cols);
  const double fy = 1.0 / (static_cast<double>(size.height) / src.rows);
  const bool whole = std::abs(fx - cv::saturate_cast<int>(fx)) < DBL_EPSILON &&
                     std::abs(fy - cv::saturate_cast<int>(fy)) < DBL_EPSILON;
  if (src.type() != CV_8UC1 || fx < 1 || fy < 1 || whole) {
    cv::resize(src, *dst, size, 0, 0, cv::INTER_AREA);
    return true;
  }
  make(src.cols, size.width, &x_);
  make(src.rows, size.height, &y_);
  // Across, on the transposed frame: output column i's sums over all the
  // source rows at once are a weighted sum of the source's columns (rows
  // here), the compiler's vector loops, where row by row each sum gathers
  // 2-3 pixels (scalar, 4x slower). The same products, added in the same
  // order, as OpenCV's row by row.
  cv::transpose(src, src_t_);
  across_t_.create(size.width, src.rows, CV_32F);
  const int n = src.rows;
  for (int i = 0; i < size.width; ++i) {
    float* a = across_t_.ptr<float>(i);
    {
      const uint8_t* s = src_t_.ptr<uint8_t>(x_.index[x_.start[i]]);
      const float w = x_.weight[x_.start[i]];
      for (int k = 0; k < n; ++k) a[k] = s[k] * w;
    }
    for (int t = x_.start[i] + 1; t < x_.start[i + 1]; ++t) {
      const uint8_t* s = src_t_.ptr<uint8_t>(x_.index[t]);
      const float w = x_.weight[t];
      for (int k = 0; k < n; ++k) a[k] += s[k] * w;
    }
  }
  cv::transpose(across_t_, across_);
  // Down: each output row the weighted sum of its source rows' sums, in
  // the table's order (as OpenCV adds them), then rounded as OpenCV rounds
  // (saturate_cast, by convertTo's vector loop: the scalar rounding of each
  // pixel took 40% of the time) a block of rows at a time.
  dst->create(size, CV_8UC1);
  constexpr int kBlockRows = 16;
  block_.create(std::min(kBlockRows, size.height), size.width, CV_32F);
  for (int j0 = 0; j0 < size.height; j0 += kBlockRows) {
    const int rows = std::min(kBlockRows, size.height - j0);
    for (int j = j0; j < j0 + rows; ++j) {
      float* sum = block_.ptr<float>(j - j0);
      const int t0 = y_.start[j], t1 = y_.start[j + 1];
      {
        const float* a = across_.ptr<float>(y_.index[t0]);
        const float w = y_.weight[t0];
        for (int i = 0; i < size.width; ++i) sum[i] = w * a[i];
      }
      for (int t = t0 + 1; t < t1; ++t) {
        const float* a = across_.ptr<float>(y_.index[t]);
        const float w = y_.weight[t];
        for (int i = 0; i < size.width; ++i) sum[i] += w * a[i];
      }
    }
    cv::Mat out = dst->rowRange(j0, j0 + rows);
    block_.rowRange(0, rows).convertTo(out, CV_8U);
  }
  return true;
}

}  // namespace imt
