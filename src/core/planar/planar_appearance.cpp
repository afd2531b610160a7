// Image side of the planar targets' appearance alignment: sampling the frame
// on a target-plane grid, finding what covers the target, and searching for
// it (see planar_appearance.h).
#include "planar_appearance.h"

#include <Eigen/Core>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <cmath>
#include <functional>
#include <limits>

namespace imt {
namespace planar_detail {

cv::Matx33d toMatx(const Eigen::Matrix3d& M) {
  cv::Matx33d m;
  cv::eigen2cv(M, m);
  return m;
}

namespace {

// The value below which a fraction `q` of `m`'s pixels under `mask` lie,
// for `m` >= 0 (`whole`: the mask is 255 everywhere; `buffer`: scratch
// space). Exactly std::nth_element's answer, found faster: non-negative
// floats order as their bit patterns, so a histogram of the leading bits
// (sign, exponent, 3 bits of mantissa) says which values share the wanted
// one's, and nth_element runs among those few only.
float quantile(const cv::Mat& m, const cv::Mat& mask, bool whole, double q,
               std::vector<float>* buffer) {
  std::vector<float>& v = *buffer;
  v.resize(m.total());
  size_t n = 0;
  for (int r = 0; r < m.rows; ++r) {
    const float* pm = m.ptr<float>(r);
    if (whole) {
      std::copy(pm, pm + m.cols, v.begin() + n);
      n += m.cols;
      continue;
    }
    const uchar* pk = mask.ptr<uchar>(r);
    for (int c = 0; c < m.cols; ++c)
      if (pk[c]) v[n++] = pm[c];
  }
  if (n == 0) return 0;
  const size_t k = std::min(n - 1, static_cast<size_t>(q * n));
  constexpr int kShift = 20;  // 32 - 12 leading bits
  const auto leading = [](float f) {
    uint32_t b;
    std::memcpy(&b, &f, sizeof b);
    return (b & 0x7fffffffu) >> kShift;  // -0 as 0
  };
  std::array<uint32_t, 1 << (32 - kShift)> histogram{};
  for (size_t i = 0; i < n; ++i) ++histogram[leading(v[i])];
  uint32_t bin = 0;
  size_t below = 0;  // values in lower bins
  while (below + histogram[bin] <= k) below += histogram[bin++];
  size_t in_bin = 0;
  for (size_t i = 0; i < n; ++i)
    if (leading(v[i]) == bin) v[in_bin++] = v[i];
  std::nth_element(v.begin(), v.begin() + (k - below), v.begin() + in_bin);
  return v[k - below];
}

// Sums over the pixels of `mask` (CV_8U, 255 / 0) of a, b (CV_32F), their
// squares and their product: a masked meanStdDev of both and their
// covariance in one pass (a row's sums in float, vectorised; the rows' in
// double).
struct PairSums {
  double n = 0, a = 0, b = 0, aa = 0, bb = 0, ab = 0;
};
PairSums pairSums(const cv::Mat& a, const cv::Mat& b, const cv::Mat& mask) {
  cv::Mat weight;
  mask.convertTo(weight, CV_32F, 1.0 / 255);
  PairSums s;
  using Row = Eigen::Map<const Eigen::ArrayXf>;
  for (int r = 0; r < a.rows; ++r) {
    const Row w(weight.ptr<float>(r), a.cols), x(a.ptr<float>(r), a.cols), y(b.ptr<float>(r), a.cols);
    s.n += w.sum();
    s.a += (w * x).sum();
    s.b += (w * y).sum();
    s.aa += (w * x * x).sum();
    s.bb += (w * y * y).sum();
    s.ab += (w * x * y).sum();
  }
  return s;
}

// The side (px, odd) of the windows unoccludedPixels looks at on `tpl`.
int occlusionWindow(const cv::Mat& tpl) {
  return std::max(3, std::min(tpl.cols, tpl.rows) / 8) | 1;
}

// Window means of `m` times `vf` (the valid pixels, 1 / 0; empty: all).
cv::Mat localSum(const cv::Mat& m, const cv::Mat& vf, int win) {
  cv::Mat out;
  cv::boxFilter(vf.empty() ? m : m.mul(vf), out, CV_32F, cv::Size(win, win), cv::Point(-1, -1),
                true, cv::BORDER_CONSTANT);
  return out;
}

// TemplateWindows of `tpl` where `vf` (1 / 0; empty: all) says it is valid.
TemplateWindows templateWindows(const cv::Mat& tpl, const cv::Mat& vf) {
  const int win = occlusionWindow(tpl);
  TemplateWindows w;
  w.n = localSum(vf.empty() ? cv::Mat(tpl.size(), CV_32F, cv::Scalar(1)) : vf, cv::Mat(), win);
  w.seen = w.n > 0.5;  // windows mostly on valid pixels
  w.n = cv::max(w.n, 1e-3);
  w.mean = localSum(tpl, vf, win) / w.n;
  w.var = localSum(tpl.mul(tpl), vf, win) / w.n - w.mean.mul(w.mean);
  return w;
}

// Whether every pixel of a grid of `size` mapped by `W` lands (nearest
// pixel) on an image of size `image`: the grid's corners do, in front of the
// camera (the grid's image is then the convex quad they span).
bool allSamplesInside(const cv::Matx33d& W, cv::Size size, cv::Size image) {
  for (const cv::Point2d& g :
       {cv::Point2d(0, 0), cv::Point2d(size.width - 1, 0),
        cv::Point2d(size.width - 1, size.height - 1), cv::Point2d(0, size.height - 1)}) {
    const cv::Vec3d p = W * cv::Vec3d(g.x, g.y, 1);
    if (!(p[2] > 1e-9)) return false;
    const double x = p[0] / p[2], y = p[1] / p[2];
    if (!(x >= 0 && y >= 0 && x <= image.width - 1 && y <= image.height - 1)) return false;
  }
  return true;
}

}  // namespace

double displacementBound(const cv::Matx33d& M, cv::Size size) {
  if (!(M(2, 2) != 0)) return std::numeric_limits<double>::infinity();
  const cv::Matx33d W = M * (1.0 / M(2, 2));
  const double xs[2] = {0.0, size.width - 1.0}, ys[2] = {0.0, size.height - 1.0};
  // Displacement along x: ((h00 - 1) x + h01 y + h02 - x (h20 x + h21 y)) / (h20 x + h21 y + 1);
  // the affine parts are largest at the corners.
  double px = 0, py = 0, q = 0, den = std::numeric_limits<double>::infinity();
  for (double x : xs) {
    for (double y : ys) {
      px = std::max(px, std::abs((W(0, 0) - 1) * x + W(0, 1) * y + W(0, 2)));
      py = std::max(py, std::abs(W(1, 0) * x + (W(1, 1) - 1) * y + W(1, 2)));
      q = std::max(q, std::abs(W(2, 0) * x + W(2, 1) * y));
      den = std::min(den, W(2, 0) * x + W(2, 1) * y + 1);
    }
  }
  if (!(den > 0)) return std::numeric_limits<double>::infinity();
  return std::max(px + xs[1] * q, py + ys[1] * q) / den;
}

bool movesNoPixel(const cv::Matx33d& warp, cv::Size size) {
  return displacementBound(warp, size) < 0.49;  // rounds to the same pixel, with a margin for rounding
}

Eigen::Matrix3d templateToPlane(double px_per_m, int level, double w, double h) {
  const double f = (1 << level) / px_per_m;
  Eigen::Matrix3d A;
  A << f, 0, 0.5 / px_per_m - w / 2, 0, f, 0.5 / px_per_m - h / 2, 0, 0, 1;
  return A;
}

Eigen::Matrix3d toPyramidPixel(int level) {
  const double s = 1.0 / (1 << level);
  Eigen::Matrix3d S;
  S << s, 0, -0.5 * s, 0, s, -0.5 * s, 0, 0, 1;
  return S;
}

int imageLevelFor(double ratio) {
  if (!(ratio > 1.5)) return 0;
  return std::min(4, static_cast<int>(std::lround(std::log2(ratio))));
}

namespace {

// sampleImage through a distorting lens: every grid pixel's image pixel,
// looked up by remap on the reduced part of the image under the grid.
void sampleThroughLens(const cv::Mat& gray, int level, const Eigen::Matrix3d& M, cv::Size size,
                       const CameraModel& lens, cv::Mat* out, cv::Mat* valid) {
  const int s = 1 << level;
  std::vector<cv::Point2d> px;
  px.reserve(size.area());
  std::vector<uchar> front(size.area(), 0);
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      const Eigen::Vector3d p = M * Eigen::Vector3d(c, r, 1);
      const bool ok = p.z() > 1e-9;
      front[r * size.width + c] = ok;
      px.emplace_back(ok ? p.x() / p.z() : std::nan(""), ok ? p.y() / p.z() : std::nan(""));
    }
  }
  lens.distort(&px);  // ideal -> image pixels (ours, full resolution)
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (const cv::Point2d& p : px) {
    if (!(std::isfinite(p.x) && std::isfinite(p.y))) continue;
    x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
    y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  }
  *out = cv::Mat::zeros(size, CV_32F);
  *valid = cv::Mat::zeros(size, CV_8U);
  const double margin = 4.0 * s + 2;  // pyrDown's 5 taps per level, bilinear sampling
  const auto lo = [&](double v, int hi) {
    return std::clamp(static_cast<int>(std::floor(std::max(v - margin, -1.0) / s)) * s, 0, hi);
  };
  const auto up = [&](double v, int hi) {
    return std::clamp(static_cast<int>(std::ceil(std::min(v + margin, hi + 1.0) / s)) * s, 0, hi);
  };
  if (!(x1 >= x0) || !(y1 >= y0)) return;  // nothing in front of the camera
  const int l = lo(x0, gray.cols), t = lo(y0, gray.rows);
  const cv::Rect roi(l, t, up(x1, gray.cols) - l, up(y1, gray.rows) - t);
  if (roi.width < s || roi.height < s) return;  // entirely outside the frame
  cv::Mat im = gray(roi);
  for (int i = 0; i < level; ++i) {
    cv::Mat down;
    cv::pyrDown(im, down);
    im = down;
  }
  // Our full-resolution pixel -> OpenCV pixel of the cropped pyramid level.
  const Eigen::Matrix3d S = toPyramidPixel(level);
  cv::Mat map_x(size, CV_32F), map_y(size, CV_32F);
  for (int r = 0; r < size.height; ++r) {
    for (int c = 0; c < size.width; ++c) {
      const cv::Point2d& p = px[r * size.width + c];
      const bool ok = front[r * size.width + c] && std::isfinite(p.x) && std::isfinite(p.y);
      map_x.at<float>(r, c) = ok ? static_cast<float>(S(0, 0) * p.x + S(0, 2) - roi.x / s) : -1e6f;
      map_y.at<float>(r, c) = ok ? static_cast<float>(S(1, 1) * p.y + S(1, 2) - roi.y / s) : -1e6f;
    }
  }
  cv::Mat warped;
  cv::remap(im, warped, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  warped.convertTo(*out, CV_32F);
  const cv::Mat ones(im.size(), CV_8U, cv::Scalar(255));
  cv::remap(ones, *valid, map_x, map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT, 0);
  cv::erode(*valid, *valid, cv::Mat());  // no bilinear samples mixing in the border
}

}  // namespace

void sampleImage(const cv::Mat& gray, int level, const Eigen::Matrix3d& M, cv::Size size,
                 cv::Mat* out, cv::Mat* valid, const CameraModel* lens) {
  if (lens && lens->hasDistortion()) {
    sampleThroughLens(gray, level, M, size, *lens, out, valid);
    return;
  }
  const int s = 1 << level;
  cv::Rect roi(0, 0, gray.cols, gray.rows);
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  bool bounded = true;
  for (const Eigen::Vector2d& g :
       {Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(size.width - 0.5, -0.5),
        Eigen::Vector2d(size.width - 0.5, size.height - 0.5),
        Eigen::Vector2d(-0.5, size.height - 0.5)}) {
    const Eigen::Vector3d p = M * g.homogeneous();
    if (!(p.z() > 1e-9)) {
      bounded = false;  // the grid reaches the horizon: take the whole frame
      break;
    }
    x0 = std::min(x0, p.x() / p.z());
    x1 = std::max(x1, p.x() / p.z());
    y0 = std::min(y0, p.y() / p.z());
    y1 = std::max(y1, p.y() / p.z());
  }
  if (bounded) {
    const double margin = 4.0 * s + 2;  // pyrDown's 5 taps per level, bilinear sampling
    const auto lo = [&](double v, int hi) {
      return std::clamp(static_cast<int>(std::floor((v - margin) / s)) * s, 0, hi);
    };
    const auto up = [&](double v, int hi) {
      return std::clamp(static_cast<int>(std::ceil((v + margin) / s)) * s, 0, hi);
    };
    const int l = lo(x0, gray.cols), t = lo(y0, gray.rows);
    roi = cv::Rect(l, t, up(x1, gray.cols) - l, up(y1, gray.rows) - t);
  }
  if (roi.width < s || roi.height < s) {  // entirely outside the frame
    *out = cv::Mat::zeros(size, CV_32F);
    *valid = cv::Mat::zeros(size, CV_8U);
    return;
  }
  cv::Mat im = gray(roi);
  for (int i = 0; i < level; ++i) {
    cv::Mat down;
    cv::pyrDown(im, down);
    im = down;
  }
  Eigen::Matrix3d crop = Eigen::Matrix3d::Identity();
  crop(0, 2) = -static_cast<double>(roi.x / s);
  crop(1, 2) = -static_cast<double>(roi.y / s);
  const cv::Matx33d W = toMatx(crop * toPyramidPixel(level) * M);
  cv::Mat warped;
  cv::warpPerspective(im, warped, W, size, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, 0);
  warped.convertTo(*out, CV_32F);
  if (allSamplesInside(W, size, im.size())) {  // what the warp and erosion below give then
    *valid = cv::Mat(size, CV_8U, cv::Scalar(255));
    return;
  }
  const cv::Mat ones(im.size(), CV_8U, cv::Scalar(255));
  cv::warpPerspective(ones, *valid, W, size, cv::INTER_NEAREST | cv::WARP_INVERSE_MAP,
                      cv::BORDER_CONSTANT, 0);
  cv::erode(*valid, *valid, cv::Mat());  // no bilinear samples mixing in the border
}

// Local correlation with the template below which a textured part of it is
// taken as covered (an occluder's texture correlates near 0 with it; the
// target's own, aligned, near 1).
constexpr double kOccluderCorrelation = 0.3;
// Gray levels: the template's local spread from which it has texture to
// correlate (searchTemplate's featureless tiles alike).
constexpr double kTexturedStd = 2.0;

TemplateWindows TemplateWindows::of(const cv::Mat& tpl) { return templateWindows(tpl, cv::Mat()); }

cv::Mat unoccludedPixels(const cv::Mat& tpl, const cv::Mat& grad, const cv::Mat& aligned,
                         const cv::Mat& valid, double k_sigma, double shift,
                         const TemplateWindows* whole_windows) {
  const bool whole = cv::countNonZero(valid) == static_cast<int>(valid.total());
  cv::Mat fit = valid.clone(), predicted, resid;
  double sigma = 0;
  std::vector<float> buffer;
  for (int it = 0; it < 3; ++it) {
    const PairSums s = pairSums(tpl, aligned, fit);
    const double n = std::max(1.0, s.n);
    const double mt = s.a / n, mi = s.b / n;
    const double var_i = std::max(0.0, s.bb / n - mi * mi);
    const double cov = s.ab / n - mt * mi;
    const double gain = var_i > 1e-6 ? cov / var_i : 1.0;
    aligned.convertTo(predicted, CV_32F, gain, mt - gain * mi);
    cv::absdiff(tpl, predicted, resid);
    // The next fit from the best half; after the last, the noise level from
    // the best quarter (|N(0, s)| has its 25% quantile at 0.319 s).
    if (it < 2) {
      cv::bitwise_and(valid, resid <= quantile(resid, valid, whole, 0.5, &buffer), fit);
    } else {
      sigma = std::max(0.5, quantile(resid, valid, whole, 0.25, &buffer) / 0.319);
    }
  }
  cv::Mat expected;
  cv::magnitude(grad * shift, cv::Mat(grad.size(), CV_32F, cv::Scalar(sigma)), expected);
  cv::Mat outliers = (resid > k_sigma * expected) & valid, dense;
  const int win = occlusionWindow(tpl);
  cv::boxFilter(outliers, dense, CV_32F, cv::Size(win, win), cv::Point(-1, -1), true,
                cv::BORDER_REPLICATE);
  cv::Mat covered = dense > 0.5 * 255;
  // A textured occluder explains part of the residual test's tolerance (the
  // template's gradient times the shift allowed) by its own texture: it is
  // found by its local correlation with the template instead, near zero
  // whatever either texture is. Only where the template has texture to
  // correlate (flat parts are the residual test's).
  // After an alignment only (a small `shift`): around a prediction a few
  // pixels off, fine texture does not correlate with itself either.
  if (shift <= 1.0) {
    cv::Mat vf;  // empty: every pixel valid
    if (!whole) valid.convertTo(vf, CV_32F, 1.0 / 255);
    const TemplateWindows t = whole && whole_windows ? *whole_windows : templateWindows(tpl, vf);
    const cv::Mat sum_a = localSum(aligned, vf, win), sum_aa = localSum(aligned.mul(aligned), vf, win),
                  sum_ta = localSum(tpl.mul(aligned), vf, win);
    // The window correlation, pixel by pixel in one pass (an Eigen expression
    // over the images, all continuous: boxFilter's and TemplateWindows').
    cv::Mat ncc(tpl.size(), CV_32F);
    {
      using Image = Eigen::Map<const Eigen::ArrayXf>;
      const Eigen::Index n = static_cast<Eigen::Index>(tpl.total());
      CV_Assert(t.n.isContinuous() && t.mean.isContinuous() && t.var.isContinuous());
      const Image wn(t.n.ptr<float>(), n), tm(t.mean.ptr<float>(), n), tv(t.var.ptr<float>(), n);
      const Eigen::ArrayXf ma = Image(sum_a.ptr<float>(), n) / wn;
      const auto va = Image(sum_aa.ptr<float>(), n) / wn - ma * ma;
      const auto cov = Image(sum_ta.ptr<float>(), n) / wn - tm * ma;
      Eigen::Map<Eigen::ArrayXf>(ncc.ptr<float>(), n) = cov / (tv.max(0.0f) * va.max(0.0f) + 1e-6f).sqrt();
    }
    // (Not from the fit's noise level: with most of the target covered the
    // photometric fit is the occluder's, and its noise level is the texture's.)
    const cv::Mat textured = t.var > kTexturedStd * kTexturedStd;
    covered |= textured & (ncc < kOccluderCorrelation) & t.seen & valid;
  }
  cv::dilate(covered, covered, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(win, win)));
  cv::Mat keep;
  cv::bitwise_and(valid, ~covered, keep);
  return keep;
}

cv::Mat gradientMagnitude(const cv::Mat& im) {
  cv::Mat gx, gy, g;
  cv::Sobel(im, gx, CV_32F, 1, 0, 3, 1.0 / 8);
  cv::Sobel(im, gy, CV_32F, 0, 1, 3, 1.0 / 8);
  cv::magnitude(gx, gy, g);
  return g;
}

SearchMatch searchTemplate(const cv::Mat& tpl, const cv::Mat& mask, const cv::Mat& window,
                           int margin) {
  SearchMatch best;
  const int side = std::max(8, std::min(tpl.cols, tpl.rows) / 2);
  const int nx = std::max(1, static_cast<int>(std::lround(static_cast<double>(tpl.cols) / side)));
  const int ny = std::max(1, static_cast<int>(std::lround(static_cast<double>(tpl.rows) / side)));
  std::vector<cv::Mat> scores;
  std::vector<cv::Rect> rects;
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      const cv::Rect r(ix * tpl.cols / nx, iy * tpl.rows / ny,
                       (ix + 1) * tpl.cols / nx - ix * tpl.cols / nx,
                       (iy + 1) * tpl.rows / ny - iy * tpl.rows / ny);
      cv::Scalar mean, stddev;
      cv::meanStdDev(tpl(r), mean, stddev);
      if (cv::countNonZero(mask(r)) < 0.9 * r.area() || stddev[0] < 2.0)
        continue;  // partly unknown, or featureless
      cv::Mat res;
      cv::matchTemplate(window(cv::Rect(r.x, r.y, r.width + 2 * margin, r.height + 2 * margin)),
                        tpl(r), res, cv::TM_CCOEFF_NORMED);
      cv::patchNaNs(res, -1);
      scores.push_back(res);
      rects.push_back(r);
    }
  }
  best.tiles = static_cast<int>(scores.size());
  if (scores.size() < 2) return best;
  const int n = 2 * margin + 1;
  const size_t k = (scores.size() + 1) / 2;  // the better half of the tiles
  cv::Mat combined(n, n, CV_32F);
  std::vector<float> v(scores.size());
  for (int y = 0; y < n; ++y) {
    for (int x = 0; x < n; ++x) {
      for (size_t i = 0; i < scores.size(); ++i) v[i] = scores[i].at<float>(y, x);
      std::nth_element(v.begin(), v.begin() + (k - 1), v.end(), std::greater<float>());
      float sum = 0;
      for (size_t i = 0; i < k; ++i) sum += v[i];
      combined.at<float>(y, x) = sum / k;
    }
  }
  double max_val;
  cv::Point p;
  cv::minMaxLoc(combined, nullptr, &max_val, nullptr, &p);
  best.score = max_val;
  // Sub-pixel peak (parabola through the neighbours).
  const auto refinePeak = [&](float lo, float mid, float hi) {
    const float d = lo - 2 * mid + hi;
    return d < 0 ? std::clamp(0.5 * (lo - hi) / d, -0.5, 0.5) : 0.0;
  };
  double sx = p.x, sy = p.y;
  if (p.x > 0 && p.x < n - 1)
    sx += refinePeak(combined.at<float>(p.y, p.x - 1), combined.at<float>(p.y, p.x),
                     combined.at<float>(p.y, p.x + 1));
  if (p.y > 0 && p.y < n - 1)
    sy += refinePeak(combined.at<float>(p.y - 1, p.x), combined.at<float>(p.y, p.x),
                     combined.at<float>(p.y + 1, p.x));
  best.shift = cv::Point2d(sx - margin, sy - margin);
  cv::Mat away(n, n, CV_8U, cv::Scalar(255));
  cv::circle(away, p, std::max(2, side / 2), cv::Scalar(0), cv::FILLED);
  double second;
  cv::minMaxLoc(combined, nullptr, &second, nullptr, nullptr, away);
  best.second = second;
  best.seen = cv::Mat(tpl.size(), CV_8U, cv::Scalar(255));
  for (size_t i = 0; i < scores.size(); ++i)
    if (scores[i].at<float>(p) < 0.5 * best.score) best.seen(rects[i]).setTo(0);
  return best;
}

}  // namespace planar_detail
}  // namespace imt
