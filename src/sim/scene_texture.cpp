// Textures for the scene generator: procedural noise with detail at all
// scales plus shapes with corners, and their mip pyramids.
#include "scene_internal.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <list>
#include <mutex>
#include <tuple>

namespace imt {
namespace scene_detail {

uint64_t mixSeed(uint64_t a, uint64_t b) {
  uint64_t z = a * 0x9E3779B97F4A7C15ull + b + 0x632BE59BD9B4E019ull;
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

namespace {

// pyrUp of a periodic image, periodic again (exactly twice the size).
cv::Mat pyrUpWrap(const cv::Mat& src) {
  constexpr int kPad = 2;  // pyrUp's 5-tap kernel reaches 2 source pixels
  cv::Mat padded, up;
  cv::copyMakeBorder(src, padded, kPad, kPad, kPad, kPad, cv::BORDER_WRAP);
  cv::pyrUp(padded, up);
  return up(cv::Rect(2 * kPad, 2 * kPad, 2 * src.cols, 2 * src.rows)).clone();
}

// Octaves of smoothed uniform noise, coarse to fine: at each level the image
// is upsampled (pyrUp: Gaussian smoothing) and fresh white noise is added, so
// each octave contributes detail at its own scale. The finest octave has a
// 2-texel grain (texel-level noise would only alias). Periodic in both axes.
cv::Mat octaveNoise(cv::Size size, cv::RNG& rng) {
  int levels = 0;
  cv::Size base = size;
  while (base.width % 2 == 0 && base.height % 2 == 0 && std::min(base.width, base.height) > 8) {
    base = cv::Size(base.width / 2, base.height / 2);
    ++levels;
  }
  cv::Mat cur(base, CV_32FC1);
  rng.fill(cur, cv::RNG::UNIFORM, -1.0, 1.0);
  cur *= std::pow(2.0, 0.2 * levels);
  for (int k = levels - 1; k >= 0; --k) {
    cur = pyrUpWrap(cur);
    if (k >= 1) {
      // Slightly more contrast at coarse scales (amplitude ~ scale^0.2).
      cv::Mat n(cur.size(), CV_32FC1);
      rng.fill(n, cv::RNG::UNIFORM, -1.0, 1.0);
      cur += n * std::pow(2.0, 0.2 * k);
    }
  }
  return cur;
}

// Random shapes with sharp corners at every scale (rectangles, triangles,
// strokes with bends, blobs): each octave of sizes covers ~7% of the area
// (the two finest ~4%), drawn coarse to fine so that fine shapes lie on top.
// Shapes crossing a border are drawn again on the opposite side (periodic).
void drawShapes(cv::Mat* img, cv::RNG& rng) {
  const double area = double(img->cols) * img->rows;
  const double max_size = std::min(img->cols, img->rows) / 6.0;
  std::vector<double> octaves;
  for (double s = max_size; s >= 5.0; s /= 2) octaves.push_back(s);
  for (size_t o = 0; o < octaves.size(); ++o) {
    const double s_hi = octaves[o];
    const double coverage = o + 2 >= octaves.size() ? 0.04 : 0.07;
    const int count = std::max(1, static_cast<int>(coverage * area / (0.56 * s_hi * s_hi)));
    for (int i = 0; i < count; ++i) {
      const double s = rng.uniform(0.5 * s_hi, s_hi);
      const cv::Point2d c0(rng.uniform(0.0, double(img->cols)),
                           rng.uniform(0.0, double(img->rows)));
      const cv::Scalar grey(rng.uniform(25, 231));
      const double angle = rng.uniform(0.0, M_PI);
      const double ca = std::cos(angle), sa = std::sin(angle);
      const int kind = rng.uniform(0, 10);
      // Draw all random numbers first so the wrapped copies are identical.
      const double aspect = rng.uniform(0.3, 1.0);
      double tri[3];
      for (double& a : tri) a = rng.uniform(-0.5, 0.5);
      const int bends = rng.uniform(2, 5);
      double turn[5];
      for (double& a : turn) a = rng.uniform(0.8, 2.3) * (rng.uniform(0, 2) ? 1 : -1);
      const double thickness = rng.uniform(0.04, 0.15);
      constexpr int kShift = 4;      // sub-pixel vertex precision for the drawing calls
      const double reach = 2.5 * s;  // covers every shape drawn around c0
      for (int oy = -1; oy <= 1; ++oy) {
        for (int ox = -1; ox <= 1; ++ox) {
          const cv::Point2d c = c0 + cv::Point2d(ox * img->cols, oy * img->rows);
          if (c.x + reach < 0 || c.x - reach > img->cols || c.y + reach < 0 ||
              c.y - reach > img->rows)
            continue;
          auto fix = [](const cv::Point2d& p) {
            return cv::Point(cvRound(p.x * (1 << kShift)), cvRound(p.y * (1 << kShift)));
          };
          if (kind < 4) {  // rotated rectangle
            const double hw = 0.5 * s, hh = 0.5 * s * aspect;
            std::vector<cv::Point> pts;
            for (const auto& d : {cv::Point2d(-hw, -hh), cv::Point2d(hw, -hh), cv::Point2d(hw, hh),
                                  cv::Point2d(-hw, hh)})
              pts.push_back(fix(c + cv::Point2d(ca * d.x - sa * d.y, sa * d.x + ca * d.y)));
            cv::fillConvexPoly(*img, pts, grey, cv::LINE_AA, kShift);
          } else if (kind < 5) {  // triangle
            std::vector<cv::Point> pts;
            for (int k = 0; k < 3; ++k) {
              const double a = angle + k * 2.0944 + tri[k];
              pts.push_back(fix(c + 0.5 * s * cv::Point2d(std::cos(a), std::sin(a))));
            }
            cv::fillConvexPoly(*img, pts, grey, cv::LINE_AA, kShift);
          } else if (kind < 8) {  // stroke: a polyline with sharp bends
            std::vector<cv::Point> pts{fix(c)};
            cv::Point2d p = c;
            double a = angle;
            for (int k = 0; k < bends; ++k) {
              p += 0.5 * s * cv::Point2d(std::cos(a), std::sin(a));
              pts.push_back(fix(p));
              a += turn[k];
            }
            const int thick = std::max(1, static_cast<int>(s * thickness));
            cv::polylines(*img, pts, false, grey, thick, cv::LINE_AA, kShift);
          } else {  // blob
            cv::ellipse(*img, fix(c),
                        cv::Size(cvRound(0.5 * s * (1 << kShift)),
                                 cvRound(0.5 * s * aspect * (1 << kShift))),
                        angle * 180 / M_PI, 0, 360, grey, cv::FILLED, cv::LINE_AA, kShift);
          }
        }
      }
    }
  }
}

}  // namespace

cv::Mat proceduralTexture(cv::Size size, uint64_t seed) {
  CV_Assert(size.width > 0 && size.height > 0);
  cv::RNG rng(mixSeed(seed, 0x7e47u));
  cv::Mat noise = octaveNoise(size, rng);
  // Contrast: the 1st..99th percentile of the noise (on a subsample) onto grey 45..210.
  std::vector<float> v;
  v.reserve(noise.total() / 7 + 1);
  for (int y = 0; y < noise.rows; y += 3) {
    const float* row = noise.ptr<float>(y);
    for (int x = y % 3; x < noise.cols; x += 3) v.push_back(row[x]);
  }
  const size_t k = v.size() / 100;
  std::nth_element(v.begin(), v.begin() + k, v.end());
  const float lo = v[k];
  std::nth_element(v.begin(), v.end() - 1 - k, v.end());
  const float hi = v[v.size() - 1 - k];
  const double gain = 165.0 / std::max(1e-6f, hi - lo);
  cv::Mat tex;
  noise.convertTo(tex, CV_8UC1, gain, 45.0 - lo * gain);
  drawShapes(&tex, rng);
  // Soften texel-level steps; wrap so the texture stays periodic.
  cv::Mat padded;
  cv::copyMakeBorder(tex, padded, 2, 2, 2, 2, cv::BORDER_WRAP);
  cv::GaussianBlur(padded, padded, cv::Size(3, 3), 0.6, 0.6);
  return padded(cv::Rect(2, 2, tex.cols, tex.rows)).clone();
}

MipTexture buildMips(const cv::Mat& texture, bool periodic) {
  std::vector<cv::Mat> levels{texture};
  while (std::min(levels.back().cols, levels.back().rows) >= 8) {
    const cv::Mat& prev = levels.back();
    cv::Mat next;
    cv::resize(prev, next, cv::Size((prev.cols + 1) / 2, (prev.rows + 1) / 2), 0, 0,
               cv::INTER_AREA);
    levels.push_back(next);
  }
  MipTexture m;
  m.pad = 2;
  for (const cv::Mat& level : levels) {
    cv::Mat padded;
    cv::copyMakeBorder(level, padded, m.pad, m.pad, m.pad, m.pad,
                       periodic ? cv::BORDER_WRAP : cv::BORDER_REPLICATE);
    m.levels.push_back(padded);
  }
  return m;
}

std::shared_ptr<const MipTexture> proceduralMips(cv::Size size, uint64_t seed, bool periodic) {
  // Most recently used pyramids (a 2048^2 one is ~6 MB): tests create many
  // scenes with the same seeds, and a texture costs ~80 ms to make.
  constexpr size_t kKeep = 8;
  using Key = std::tuple<int, int, uint64_t, bool>;
  static std::mutex mutex;
  static std::list<std::pair<Key, std::shared_ptr<const MipTexture>>> cache;
  const Key key(size.width, size.height, seed, periodic);
  {
    std::lock_guard<std::mutex> lock(mutex);
    for (auto it = cache.begin(); it != cache.end(); ++it) {
      if (it->first != key) continue;
      cache.splice(cache.begin(), cache, it);
      return cache.front().second;
    }
  }
  auto mips =
      std::make_shared<const MipTexture>(buildMips(proceduralTexture(size, seed), periodic));
  std::lock_guard<std::mutex> lock(mutex);
  cache.emplace_front(key, mips);
  if (cache.size() > kKeep) cache.pop_back();
  return mips;
}

}  // namespace scene_detail

cv::Mat proceduralTexture(int size, uint64_t seed) {
  return scene_detail::proceduralTexture(cv::Size(size, size), seed);
}

}  // namespace imt
