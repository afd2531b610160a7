#include "instant_motion_tracking/core/region/region_filter.h"

#include "region_geometry.h"

#include <opencv2/core/hal/hal.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <complex>
#include <list>

namespace imt {
namespace {

constexpr int kOrientations = 9;
constexpr int kChannels = kOrientations + 1;  // and the cells' gray level
// How far the window reaches beyond the box: this times the geometric mean
// of its sides, in all (CSR-DCF's padding).
constexpr double kPadding = 3.0;
// The solver (one ADMM step, from the closed-form unconstrained filter): its
// penalty and the filter's regulariser, as CSR-DCF's.
constexpr float kMu = 5.0f, kLambda = 0.05f;
// A mask with fewer of the box's cells than this is not used: the box's
// gray levels told nothing from its surround's (the whole box then).
constexpr double kMinMaskShare = 0.05;

using Complex = std::complex<float>;

cv::Mat spectrum(const cv::Mat& real) {
  cv::Mat out;
  cv::dft(real, out, cv::DFT_COMPLEX_OUTPUT);
  return out;
}

// The spectra of a filter's weights (each channel's zero-padded to the
// window, packed as cv::dft gives a real input's), for the filters a thread
// located last. A region's weights change only when it learns (at most every
// other frame), and each find between would transform the same ten again.
// An entry is known by its weights' buffers, which it holds: no other
// filter can be given those while it is kept.
class SpectraCache {
 public:
  // The spectra of `h` (per channel, `rect` of an n x n window), channels
  // whose `weights` are 0 left empty.
  const std::vector<cv::Mat>& of(const std::vector<cv::Mat>& h, const std::vector<float>& weights, const cv::Rect& rect,
                                 int n) {
    for (auto it = entries_.begin(); it != entries_.end(); ++it) {
      if (!same(it->h, h)) continue;
      if (it != entries_.begin()) entries_.splice(entries_.begin(), entries_, it);
      return entries_.front().spectra;
    }
    Entry e;
    e.h = h;
    e.spectra.resize(h.size());
    cv::Mat padded = cv::Mat::zeros(n, n, CV_32F);
    for (size_t c = 0; c < h.size(); ++c) {
      if (weights[c] <= 0) continue;
      h[c].copyTo(padded(rect));
      cv::dft(padded, e.spectra[c]);
    }
    entries_.push_front(std::move(e));
    if (entries_.size() > kKept) entries_.pop_back();
    return entries_.front().spectra;
  }

 private:
  // A few: one region's finds hit; many regions' finds (a few a frame, each
  // region's every many frames) miss, and the entries only bound the memory
  // (at 50 cells, 100 kB each).
  static constexpr size_t kKept = 4;
  struct Entry {
    std::vector<cv::Mat> h, spectra;
  };
  static bool same(const std::vector<cv::Mat>& a, const std::vector<cv::Mat>& b) {
    if (a.size() != b.size()) return false;
    for (size_t c = 0; c < a.size(); ++c)
      if (a[c].data != b[c].data) return false;
    return true;
  }
  std::list<Entry> entries_;
};

SpectraCache& spectraCache() {
  thread_local SpectraCache cache;
  return cache;
}

}  // namespace

bool RegionFilter::create(const cv::Mat& gray, const cv::Rect2d& box, RegionFilter* out) {
  if (gray.empty() || gray.type() != CV_8UC1) return false;
  const double w = box.width, h = box.height;
  if (!(w > 0 && h > 0) || !std::isfinite(box.x) || !std::isfinite(box.y) || !std::isfinite(w) || !std::isfinite(h))
    return false;
  if (region_geometry::fractionInside(box, gray.size()) < 0.5) return false;
  const double size = std::sqrt(w * h);
  const double side = (w + h) / 2 + kPadding * size;
  const int cells = static_cast<int>(std::min<double>(side, kWindowPx) / kCellPx);
  if (cells < 8) return false;
  const double scale = cells * kCellPx / side;
  const double tw = w * scale / kCellPx, th = h * scale / kCellPx;  // the box in cells
  if (tw < 1 || th < 1) return false;

  RegionFilter f;
  f.cells_ = cells;
  f.side_ratio_ = side / size;
  // The cells whose centres lie in the box.
  const auto span = [cells](double t) {
    const int a = std::max(0, static_cast<int>(std::ceil(cells / 2.0 - t / 2 - 0.5)));
    const int b = std::min(cells - 1, static_cast<int>(std::floor(cells / 2.0 + t / 2 - 0.5)));
    return std::make_pair(a, std::max(a, b));
  };
  const auto [x0, x1] = span(tw);
  const auto [y0, y1] = span(th);
  f.rect_ = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
  // The wanted response: a Gaussian peak of one cell at zero shift (wrapped).
  cv::Mat label(cells, cells, CV_32F);
  for (int y = 0; y < cells; ++y)
    for (int x = 0; x < cells; ++x) {
      const int dx = std::min(x, cells - x), dy = std::min(y, cells - y);
      label.at<float>(y, x) = std::exp(-0.5f * static_cast<float>(dx * dx + dy * dy));
    }
  f.label_ = spectrum(label);
  cv::createHanningWindow(f.hann_, cv::Size(cells, cells), CV_32F);

  const cv::Mat win = f.window(gray, box, scale);
  const cv::Size2d target(w * scale, h * scale);
  f.histograms(win, target, &f.fg_, &f.bg_);
  f.train(f.features(win), f.mask(win, target), &f.h_, &f.weights_);
  *out = std::move(f);
  return true;
}

double RegionFilter::scaleFor(const cv::Rect2d& box) const {
  const double size = std::sqrt(box.width * box.height);
  if (!valid() || !(size > 0) || !std::isfinite(size) || !std::isfinite(box.x) || !std::isfinite(box.y)) return 0;
  return cells_ * kCellPx / (side_ratio_ * size);
}

cv::Mat RegionFilter::window(const cv::Mat& gray, const cv::Rect2d& box, double scale) const {
  const int side = cells_ * kCellPx;
  const double cx = box.x + box.width / 2, cy = box.y + box.height / 2;
  const cv::Matx23d a(scale, 0, side / 2.0 - scale * cx, 0, scale, side / 2.0 - scale * cy);
  cv::Mat out;
  cv::warpAffine(gray, out, a, cv::Size(side, side), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  return out;
}

std::vector<cv::Mat> RegionFilter::features(const cv::Mat& window) const {
  const int n = cells_, side = n * kCellPx;
  std::vector<cv::Mat> f(kChannels);
  for (cv::Mat& c : f) c = cv::Mat::zeros(n, n, CV_32F);
  // Each pixel's gradient (central differences, one-sided at the window's
  // edges) votes for the two nearest of 9 unsigned orientations, in
  // proportion, into its cell (the cell's mean); the gray channel is the
  // cell's mean level. A row at a time: its angles and magnitudes by
  // OpenCV's vectorised kernels, into buffers on the stack (whole-window
  // float images cost more in allocation than in arithmetic here).
  const float per_bin = kOrientations / 180.0f, per_pixel = 1.0f / (kCellPx * kCellPx * 255.0f);
  CV_DbgAssert(side <= kWindowPx);  // create(): at most kWindowPx / kCellPx cells
  float gx[kWindowPx], gy[kWindowPx], mag[kWindowPx], deg[kWindowPx];
  float lower[kWindowPx], upper[kWindowPx], level[kWindowPx];
  int bin[kWindowPx];
  float* rows[kOrientations + 1];
  for (int y = 0; y < side; ++y) {
    const uint8_t* p = window.ptr<uint8_t>(y);
    const uint8_t* up = window.ptr<uint8_t>(std::max(0, y - 1));
    const uint8_t* down = window.ptr<uint8_t>(std::min(side - 1, y + 1));
    gx[0] = static_cast<float>(p[1]) - p[0];
    gx[side - 1] = static_cast<float>(p[side - 1]) - p[side - 2];
    for (int x = 1; x < side - 1; ++x) gx[x] = static_cast<float>(p[x + 1]) - p[x - 1];
    for (int x = 0; x < side; ++x) gy[x] = static_cast<float>(down[x]) - up[x];
    cv::hal::magnitude32f(gx, gy, mag, side);
    cv::hal::fastAtan32f(gy, gx, deg, side, true);  // 0 .. 360
    for (int k = 0; k < kOrientations; ++k) rows[k] = f[k].ptr<float>(y / kCellPx);
    rows[kOrientations] = rows[0];  // orientation 9 is orientation 0
    float* gray = f[kOrientations].ptr<float>(y / kCellPx);
    // Each pixel's lower bin and its two votes (a loop GCC vectorises with
    // this file's options in CMakeLists.txt), then the votes added into the
    // cells in the same order as before: the same sums to the bit.
    for (int x = 0; x < side; ++x) {
      const float b = (deg[x] >= 180 ? deg[x] - 180 : deg[x]) * per_bin;
      const int b0 = std::min(static_cast<int>(b), kOrientations - 1);
      const float w1 = b - static_cast<float>(b0), m = mag[x] * per_pixel;
      bin[x] = b0;
      lower[x] = m * (1 - w1);
      upper[x] = m * w1;
      level[x] = static_cast<float>(p[x]) * per_pixel;
    }
    for (int x = 0; x < side; ++x) {
      const int cx = x / kCellPx;
      rows[bin[x]][cx] += lower[x];
      rows[bin[x] + 1][cx] += upper[x];
      gray[cx] += level[x];
    }
  }
  // Normalised by the gradient energy of the cell and its neighbours, clipped.
  cv::Mat energy = cv::Mat::zeros(n, n, CV_32F);
  for (int k = 0; k < kOrientations; ++k) cv::accumulateSquare(f[k], energy);
  cv::sqrt(energy, energy);
  cv::blur(energy, energy, cv::Size(3, 3));
  energy += 0.01;
  // Each orientation over the energy, clipped at 0.6, the gray level less
  // 0.5, each windowed: one pass over a channel in place.
  const float* e = energy.ptr<float>();
  const float* hann = hann_.ptr<float>();
  for (int k = 0; k < kChannels; ++k) {
    float* v = f[k].ptr<float>();
    if (k < kOrientations) {
      for (int i = 0; i < n * n; ++i) v[i] = std::min(v[i] / e[i], 0.6f) * hann[i];
    } else {
      for (int i = 0; i < n * n; ++i) v[i] = (v[i] - 0.5f) * hann[i];
    }
  }
  return f;
}

void RegionFilter::histograms(const cv::Mat& window, const cv::Size2d& target, Histogram* fg, Histogram* bg) const {
  fg->fill(0);
  bg->fill(0);
  const double half = window.cols / 2.0;
  double nf = 0, nb = 0;
  for (int y = 0; y < window.rows; ++y) {
    const uint8_t* p = window.ptr<uint8_t>(y);
    const double dy = std::abs(y + 0.5 - half);
    for (int x = 0; x < window.cols; ++x) {
      const double dx = std::abs(x + 0.5 - half);
      if (dx < target.width / 2 && dy < target.height / 2) {
        (*fg)[p[x] * kBins / 256] += 1;
        ++nf;
      } else if (dx > target.width || dy > target.height) {  // the surround: beyond twice the box
        (*bg)[p[x] * kBins / 256] += 1;
        ++nb;
      }
    }
  }
  for (float& v : *fg) v /= static_cast<float>(std::max(1.0, nf));
  for (float& v : *bg) v /= static_cast<float>(std::max(1.0, nb));
}

cv::Mat RegionFilter::mask(const cv::Mat& window, const cv::Size2d& target) const {
  // Each pixel's chance of being the region's, from its gray level and a
  // Gaussian prior about the box's centre (a half side its deviation).
  const double half = window.cols / 2.0;
  const double sx = std::max(0.5, target.width / 2), sy = std::max(0.5, target.height / 2);
  std::vector<float> px(window.cols), py(window.rows);  // the prior, separable
  for (int x = 0; x < window.cols; ++x) px[x] = static_cast<float>(std::exp(-0.5 * std::pow((x + 0.5 - half) / sx, 2)));
  for (int y = 0; y < window.rows; ++y) py[y] = static_cast<float>(std::exp(-0.5 * std::pow((y + 0.5 - half) / sy, 2)));
  // The cells' mean chance (only the box's cells are asked).
  cv::Mat cells = cv::Mat::zeros(cells_, cells_, CV_32F);
  for (int y = rect_.y * kCellPx; y < (rect_.y + rect_.height) * kCellPx; ++y) {
    const uint8_t* p = window.ptr<uint8_t>(y);
    float* o = cells.ptr<float>(y / kCellPx);
    for (int x = rect_.x * kCellPx; x < (rect_.x + rect_.width) * kCellPx; ++x) {
      const float prior = px[x] * py[y];
      const float pf = fg_[p[x] * kBins / 256] * prior, pb = bg_[p[x] * kBins / 256] * (1 - prior);
      o[x / kCellPx] += pf / (pf + pb + 1e-12f) / (kCellPx * kCellPx);
    }
  }
  cv::Mat m = cv::Mat::zeros(cells_, cells_, CV_32F);
  int on = 0;
  for (int y = rect_.y; y < rect_.y + rect_.height; ++y)
    for (int x = rect_.x; x < rect_.x + rect_.width; ++x)
      if (cells.at<float>(y, x) > 0.5f) {
        m.at<float>(y, x) = 1;
        ++on;
      }
  if (on < kMinMaskShare * rect_.area()) m(rect_).setTo(1);
  return m;
}

void RegionFilter::train(const std::vector<cv::Mat>& f, const cv::Mat& mask, std::vector<cv::Mat>* h,
                         std::vector<float>* weights) const {
  const int n = cells_;
  const float inv_n = 1.0f / static_cast<float>(n * n);
  h->assign(f.size(), cv::Mat());
  weights->assign(f.size(), 0.0f);
  cv::Mat g(n, n, CV_32FC2), full;
  for (size_t c = 0; c < f.size(); ++c) {
    const cv::Mat x = spectrum(f[c]);
    // The unconstrained filter in closed form, then one step toward the
    // filter kept to the mask (ADMM, from a zero multiplier).
    for (int i = 0; i < n; ++i) {
      const Complex* xs = x.ptr<Complex>(i);
      const Complex* ys = label_.ptr<Complex>(i);
      Complex* gs = g.ptr<Complex>(i);
      for (int j = 0; j < n; ++j) {
        const Complex sxy = xs[j] * std::conj(ys[j]);
        const float sxx = std::norm(xs[j]);
        const Complex h0 = sxy / (sxx + kLambda);
        gs[j] = kMu * (sxy + kMu * h0) / (sxx + kMu);
      }
    }
    cv::idft(g, full, cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
    cv::Mat hc;
    cv::multiply(full(rect_), mask(rect_), hc, 1.0 / (kLambda * inv_n + kMu));
    // How well the channel alone tells the region: its response at the box.
    (*weights)[c] = std::max(0.0f, static_cast<float>(hc.dot(f[c](rect_))));
    (*h)[c] = hc;
  }
  float sum = 0;
  for (float w : *weights) sum += w;
  for (float& w : *weights) w = sum > 0 ? w / sum : 1.0f / static_cast<float>(weights->size());
}

FilterMatch RegionFilter::locate(const cv::Mat& gray, const cv::Rect2d& box) const {
  FilterMatch out;
  const double scale = scaleFor(box);
  if (!(scale > 0) || gray.empty() || gray.type() != CV_8UC1) return out;
  const int n = cells_;
  const std::vector<cv::Mat> f = features(window(gray, box, scale));
  // The spectra packed (CCS: real input, half the products). The filter's
  // own are not kept with it: each state in a region's history (offline,
  // all of them) would hold 10 n x n spectra, 100 kB at 50 cells, instead of
  // its box's cells (about 8 kB); the thread keeps the last few filters'.
  const std::vector<cv::Mat>& spectra = spectraCache().of(h_, weights_, rect_, n);
  cv::Mat sum = cv::Mat::zeros(n, n, CV_32F), fc, prod;
  for (size_t c = 0; c < f.size(); ++c) {
    if (weights_[c] <= 0) continue;
    cv::dft(f[c], fc);
    cv::mulSpectrums(fc, spectra[c], prod, 0, true);
    cv::scaleAdd(prod, weights_[c], sum, sum);
  }
  cv::Mat response;
  cv::idft(sum, response, cv::DFT_REAL_OUTPUT | cv::DFT_SCALE);
  cv::Point at;
  double peak = 0;
  cv::minMaxLoc(response, nullptr, &peak, nullptr, &at);
  // Sub-cell: a parabola through the peak and its neighbours (wrapped).
  const auto r = [&](int y, int x) { return response.at<float>((y + n) % n, (x + n) % n); };
  using region_geometry::peakOffset;
  const double dx = (at.x > n / 2 ? at.x - n : at.x) + peakOffset(r(at.y, at.x - 1), peak, r(at.y, at.x + 1));
  const double dy = (at.y > n / 2 ? at.y - n : at.y) + peakOffset(r(at.y - 1, at.x), peak, r(at.y + 1, at.x));
  // Peak to sidelobe: the peak against the response beyond 2 cells of it.
  double sum_s = 0, sum_s2 = 0;
  int count = 0;
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      const int ddx = std::min(std::abs(x - at.x), n - std::abs(x - at.x));
      const int ddy = std::min(std::abs(y - at.y), n - std::abs(y - at.y));
      if (ddx <= 2 && ddy <= 2) continue;
      const double v = response.at<float>(y, x);
      sum_s += v;
      sum_s2 += v * v;
      ++count;
    }
  const double mean = sum_s / std::max(1, count);
  const double sd = std::sqrt(std::max(0.0, sum_s2 / std::max(1, count) - mean * mean));
  out.psr = sd > 0 ? (peak - mean) / sd : 0;
  out.found = std::isfinite(peak);
  out.shift = cv::Point2d(dx, dy) * (kCellPx / scale);
  out.peak = peak;
  return out;
}

void RegionFilter::learn(const cv::Mat& gray, const cv::Rect2d& box, double rate) {
  const double scale = scaleFor(box);
  if (!(scale > 0) || gray.empty() || gray.type() != CV_8UC1 || !(rate > 0)) return;
  rate = std::min(rate, 1.0);
  const cv::Mat win = window(gray, box, scale);
  const cv::Size2d target(box.width * scale, box.height * scale);
  Histogram fg, bg;
  histograms(win, target, &fg, &bg);
  const float kh = static_cast<float>(kHistogramRate);
  for (int i = 0; i < kBins; ++i) {
    fg_[i] = (1 - kh) * fg_[i] + kh * fg[i];
    bg_[i] = (1 - kh) * bg_[i] + kh * bg[i];
  }
  std::vector<cv::Mat> h;
  std::vector<float> weights;
  train(features(win), mask(win, target), &h, &weights);
  // New matrices: copies of this filter (earlier states) share the old ones.
  float sum = 0;
  for (size_t c = 0; c < h.size(); ++c) {
    cv::Mat blended;
    cv::addWeighted(h_[c], 1 - rate, h[c], rate, 0, blended);
    h_[c] = blended;
    weights_[c] = static_cast<float>((1 - rate) * weights_[c] + rate * weights[c]);
    sum += weights_[c];
  }
  for (float& w : weights_) w = sum > 0 ? w / sum : 1.0f / static_cast<float>(weights_.size());
}

}  // namespace imt
