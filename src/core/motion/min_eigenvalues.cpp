#include "motion/min_eigenvalues.h"

#include <algorithm>
#include <cmath>

namespace imt {
namespace {

// OpenCV's BORDER_REFLECT_101 index (…, 2, 1 | 0, 1, 2, … n-1 | n-2, …), the
// border its Sobel and box filter read.
int reflect101(int i, int n) { return cv::borderInterpolate(i, n, cv::BORDER_REFLECT_101); }

// The slot of image row r among the three rolling rows.
int slotOf(int r) { return ((r % 3) + 3) % 3; }

// A row's horizontal passes over q[0 .. n + 1]: the difference [-1 0 1]
// (of the x gradient) and the smoothing [1 2 1] (of the y gradient).
void horizontal(const uint8_t* __restrict q, int n, int16_t* __restrict d, int16_t* __restrict s) {
  for (int x = 0; x < n; ++x) {
    d[x] = static_cast<int16_t>(q[x + 2] - q[x]);
    s[x] = static_cast<int16_t>(q[x] + 2 * q[x + 1] + q[x + 2]);
  }
}

// A row's Sobel gradients, from its own and its neighbours' horizontal
// passes, and their products.
void products(const int16_t* __restrict d0, const int16_t* __restrict d1,
              const int16_t* __restrict d2, const int16_t* __restrict s0,
              const int16_t* __restrict s2, int n, int32_t* __restrict xx, int32_t* __restrict xy,
              int32_t* __restrict yy) {
  for (int x = 0; x < n; ++x) {
    const int32_t gx = d0[x] + 2 * d1[x] + d2[x];
    const int32_t gy = s2[x] - s0[x];
    xx[x] = gx * gx;
    xy[x] = gx * gy;
    yy[x] = gy * gy;
  }
}

// Sums of three across, reflected at the area's ends (the box filter runs
// on the area's covariance image alone).
void across(const int32_t* __restrict v, int n, int32_t* __restrict out) {
  if (n == 1) {
    out[0] = 3 * v[0];
    return;
  }
  out[0] = 2 * v[1] + v[0];
  for (int x = 1; x < n - 1; ++x) out[x] = v[x - 1] + v[x] + v[x + 1];
  out[n - 1] = 2 * v[n - 2] + v[n - 1];
}

// The smaller eigenvalue from the sums of three rows of each product, as
// OpenCV's calcMinEigenVal: a = xx / 2, b = xy, c = yy / 2, all scaled.
void eigen(const int32_t* __restrict a0, const int32_t* __restrict a1, const int32_t* __restrict a2,
           const int32_t* __restrict b0, const int32_t* __restrict b1, const int32_t* __restrict b2,
           const int32_t* __restrict c0, const int32_t* __restrict c1, const int32_t* __restrict c2,
           int n, float k, float half_k, float* __restrict o) {
  for (int x = 0; x < n; ++x) {
    const float a = static_cast<float>(a0[x] + a1[x] + a2[x]) * half_k;
    const float b = static_cast<float>(b0[x] + b1[x] + b2[x]) * k;
    const float c = static_cast<float>(c0[x] + c1[x] + c2[x]) * half_k;
    o[x] = (a + c) - std::sqrt((a - c) * (a - c) + b * b);
  }
}

}  // namespace

bool MinEigenvalues::apply(const cv::Mat& gray, const cv::Rect& area, cv::Mat* out) {
  if (gray.empty() || gray.type() != CV_8UC1 || area.width < 1 || area.height < 1 ||
      (area & cv::Rect(0, 0, gray.cols, gray.rows)) != area)
    return false;
  const int w = area.width, h = area.height;
  out->create(h, w, CV_32F);
  // Columns area.x - 1 and area.x + w read straight from the frame when
  // both are in it; else each row is copied with its ends reflected.
  const bool inside = area.x >= 1 && area.x + w + 1 <= gray.cols;
  row_.resize(w + 2);
  diff_.resize(3 * w);
  smooth_.resize(3 * w);
  xx_.resize(w);
  xy_.resize(w);
  yy_.resize(w);
  hxx_.resize(3 * w);
  hxy_.resize(3 * w);
  hyy_.resize(3 * w);
  // The horizontal passes of image row r (reflected at the frame's edges).
  const auto pass = [&](int r) {
    const uint8_t* p = gray.ptr<uint8_t>(reflect101(r, gray.rows));
    const uint8_t* q = p + area.x - 1;
    if (!inside) {
      // Only the two ends can fall outside the frame.
      row_[0] = p[reflect101(area.x - 1, gray.cols)];
      std::copy(p + area.x, p + area.x + w, row_.begin() + 1);
      row_[w + 1] = p[reflect101(area.x + w, gray.cols)];
      q = row_.data();
    }
    horizontal(q, w, diff_.data() + slotOf(r) * w, smooth_.data() + slotOf(r) * w);
  };
  // The products of the area's row y, summed across, into its rolling slot.
  const auto sums = [&](int y) {
    const int r = area.y + y;
    const int16_t* d = diff_.data();
    const int16_t* s = smooth_.data();
    products(d + slotOf(r - 1) * w, d + slotOf(r) * w, d + slotOf(r + 1) * w, s + slotOf(r - 1) * w,
             s + slotOf(r + 1) * w, w, xx_.data(), xy_.data(), yy_.data());
    across(xx_.data(), w, hxx_.data() + (y % 3) * w);
    across(xy_.data(), w, hxy_.data() + (y % 3) * w);
    across(yy_.data(), w, hyy_.data() + (y % 3) * w);
  };
  // OpenCV's scale for a 3 x 3 Sobel and a 3 x 3 block on 8-bit input.
  const double s = 1.0 / (4 * 3 * 255.0);
  const float k = static_cast<float>(s * s), half_k = static_cast<float>(0.5 * s * s);
  pass(area.y - 1);
  pass(area.y);
  pass(area.y + 1);
  sums(0);
  for (int y = 0; y < h; ++y) {
    if (y + 1 < h) {
      pass(area.y + y + 2);
      sums(y + 1);
    }
    // The rows above and below, reflected at the area's top and bottom.
    const int up = (reflect101(y - 1, h) % 3) * w, mid = (y % 3) * w,
              down = (reflect101(y + 1, h) % 3) * w;
    const int32_t* a = hxx_.data();
    const int32_t* b = hxy_.data();
    const int32_t* c = hyy_.data();
    eigen(a + up, a + mid, a + down, b + up, b + mid, b + down, c + up, c + mid, c + down, w, k,
          half_k, out->ptr<float>(y));
  }
  return true;
}

}  // namespace imt
