#include "instant_motion_tracking/core/region/region_appearance.h"

#include "area_resize.h"
#include "region_geometry.h"
#include "template_correlation.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace imt {
namespace {

using region_geometry::peakOffset;
using region_geometry::turnedExtent;

// The integer pixels of `rect` in `gray`; the part outside the image repeats
// its border. Empty when none of it is inside the image.
cv::Mat crop(const cv::Mat& gray, const cv::Rect& r) {
  const cv::Rect inside = r & cv::Rect(0, 0, gray.cols, gray.rows);
  if (inside.area() <= 0) return cv::Mat();
  cv::Mat roi = gray(inside);
  if (inside != r) {
    cv::copyMakeBorder(roi, roi, inside.y - r.y, r.br().y - inside.br().y, inside.x - r.x, r.br().x - inside.br().x,
                       cv::BORDER_REPLICATE);
  }
  return roi;
}

// `roi` halved (area averaging) while it is at least twice `size`, first
// cut to even sides (the crop is rounded to whole pixels anyway). OpenCV 4.6
// averages areas by a whole factor ~5 times faster than by another one: a
// 640 x 480 frame shrunk to 154 x 115 took 1.05 ms in one step, 0.25 ms
// halved first; the two differ by half a grey level on average.
cv::Mat halvedToward(cv::Mat roi, cv::Size size) {
  while (roi.cols >= 2 * std::max(1, size.width) && roi.rows >= 2 * std::max(1, size.height)) {
    cv::Mat half;
    cv::resize(roi(cv::Rect(0, 0, roi.cols & ~1, roi.rows & ~1)), half, cv::Size(roi.cols / 2, roi.rows / 2), 0, 0,
               cv::INTER_AREA);
    roi = half;
  }
  return roi;
}

// The area resize of the windows sampled below, its scratch kept by each
// thread (the looks' const methods may run concurrently). OpenCV's own
// resize, bit for bit, in under half its time at the factors a window is
// left with after its halvings (area_resize.h).
AreaResize& areaResize() {
  thread_local AreaResize resize;
  return resize;
}

// `rect` turned by `angle` about its centre, of `gray`, resampled to `size`
// (area averaging), as CV_32F: `size` px across the rect's own axes. The
// part outside the image repeats its border. False when less than
// `min_inside` of the turned rect's axis-aligned extent is inside the image.
bool sample(const cv::Mat& gray, const cv::Rect2d& rect, cv::Size size, double min_inside, cv::Mat* out,
            double angle = 0) {
  if (size.width < 1 || size.height < 1 || !(rect.width >= 1 && rect.height >= 1)) return false;
  const cv::Rect2d img(0, 0, gray.cols, gray.rows);
  const bool turned = !RegionAppearance::unturned(angle);
  const cv::Rect2d extent = turned ? turnedExtent(rect, angle) : rect;
  if ((extent & img).area() < min_inside * extent.area()) return false;
  const cv::Rect r(static_cast<int>(std::floor(extent.x + 0.5)), static_cast<int>(std::floor(extent.y + 0.5)),
                   std::max(1, static_cast<int>(std::lround(extent.width))),
                   std::max(1, static_cast<int>(std::lround(extent.height))));
  const cv::Mat roi = crop(gray, r);
  if (roi.empty()) return false;
  cv::Mat small;
  if (!turned) {
    const cv::Mat src = halvedToward(roi, size);
    if (src.cols > size.width) areaResize().apply(src, size, &small);
    else cv::resize(src, small, size, 0, 0, cv::INTER_LINEAR);
    small.convertTo(*out, CV_32F);
    return true;
  }
  // Turned: the extent is first brought to the output's scale by area
  // averaging (where it shrinks), then the rect is read off it along its own
  // axes (bilinear).
  const double sx = size.width / rect.width, sy = size.height / rect.height;  // output px per image px
  const double fx = std::min(1.0, sx), fy = std::min(1.0, sy);               // the first step's scale
  cv::Mat scaled = roi;
  if (fx < 1 || fy < 1) {
    const cv::Size to(std::max(1, static_cast<int>(std::lround(roi.cols * fx))),
                      std::max(1, static_cast<int>(std::lround(roi.rows * fy))));
    areaResize().apply(halvedToward(roi, to), to, &scaled);
  }
  const double kx = scaled.cols / static_cast<double>(roi.cols), ky = scaled.rows / static_cast<double>(roi.rows);
  // Output pixel (u, v) -> image point c + R (d(u, v)), d in image px along
  // the rect's axes -> the scaled extent's pixel.
  const double c = std::cos(angle), s = std::sin(angle);
  const double cx = rect.x + rect.width / 2, cy = rect.y + rect.height / 2;
  const double du0 = (0.5 - size.width / 2.0) / sx, dv0 = (0.5 - size.height / 2.0) / sy;
  // Image point of output (u, v): p = c0 + R diag(1/sx, 1/sy) (u, v) + R (du0, dv0).
  const double px0 = cx + c * du0 - s * dv0 - r.x, py0 = cy + s * du0 + c * dv0 - r.y;
  cv::Matx23d M(kx * c / sx, -kx * s / sy, kx * px0 - 0.5, ky * s / sx, ky * c / sy, ky * py0 - 0.5);
  cv::warpAffine(scaled, small, M, size, cv::INTER_LINEAR | cv::WARP_INVERSE_MAP, cv::BORDER_REPLICATE);
  small.convertTo(*out, CV_32F);
  return true;
}

// The best match of `templ` in `window` (both CV_32F), `scale` template px
// per image px in x and y, `origin` the window's top-left in the image.
AppearanceMatch bestMatch(const cv::Mat& templ, const cv::Mat& window, cv::Point2d origin, double sx, double sy,
                          cv::Mat* response) {
  AppearanceMatch m;
  if (window.cols < templ.cols || window.rows < templ.rows) return m;
  correlateNormed(window, templ, response);
  double best;
  cv::Point at;
  cv::minMaxLoc(*response, nullptr, &best, nullptr, &at);
  if (!std::isfinite(best)) return m;
  const cv::Mat& r = *response;
  double ox = 0, oy = 0;
  if (at.x > 0 && at.x + 1 < r.cols)
    ox = peakOffset(r.at<float>(at.y, at.x - 1), r.at<float>(at.y, at.x), r.at<float>(at.y, at.x + 1));
  if (at.y > 0 && at.y + 1 < r.rows)
    oy = peakOffset(r.at<float>(at.y - 1, at.x), r.at<float>(at.y, at.x), r.at<float>(at.y + 1, at.x));
  m.found = true;
  m.score = best;
  m.box = cv::Rect2d(origin.x + (at.x + ox) / sx, origin.y + (at.y + oy) / sy, templ.cols / sx, templ.rows / sy);
  return m;
}

// Turns (rad) the coarse whole-frame search ignores: a 12 px template's
// corners move by under a pixel.
constexpr double kCoarseTurn = 0.1;

// A scale change must earn its place: the unscaled match wins ties.
double scalePenalty(double scale) { return scale == 1.0 ? 0.0 : 0.01; }

// A match found in a window read along a region's axes turned by `angle`
// about `c`: its offset from `c`, along those axes, turned back into the image.
void turnBack(cv::Rect2d* box, const cv::Point2d& c, double angle) {
  const double u = box->x + box->width / 2 - c.x, v = box->y + box->height / 2 - c.y;
  const double ca = std::cos(angle), sa = std::sin(angle);
  box->x = c.x + ca * u - sa * v - box->width / 2;
  box->y = c.y + sa * u + ca * v - box->height / 2;
}

}  // namespace

bool RegionAppearance::create(const cv::Mat& gray, const cv::Rect2d& box, int size, RegionAppearance* out, double angle) {
  if (gray.empty() || gray.type() != CV_8UC1 || !(box.width >= 4 && box.height >= 4) || size < 4) return false;
  const double s = std::min(1.0, size / std::max(box.width, box.height));
  const cv::Size tsize(std::max(4, static_cast<int>(std::lround(box.width * s))),
                       std::max(4, static_cast<int>(std::lround(box.height * s))));
  cv::Mat t;
  if (!sample(gray, box, tsize, 0.75, &t, angle)) return false;
  cv::Scalar mean, stddev;
  cv::meanStdDev(t, mean, stddev);
  if (stddev[0] < 2.0) return false;  // flat: every shift would match as well
  out->templ_ = t;
  return true;
}

const std::vector<double>& RegionAppearance::trackedScales() {
  static const std::vector<double> scales = {1.0, 1.0 / 1.05, 1.05};
  return scales;
}

const std::vector<double>& RegionAppearance::lostScales() {
  static const std::vector<double> scales = {1.0, 1.0 / 1.1, 1.1, 1.0 / 1.2, 1.2};
  return scales;
}

AppearanceMatch RegionAppearance::match(const cv::Mat& gray, const cv::Rect2d& box, double margin,
                                        const std::vector<double>& scales, double angle) const {
  AppearanceMatch best;
  if (!valid() || gray.empty() || !(box.width >= 1 && box.height >= 1)) return best;
  cv::Mat window, response;
  double best_key = -2;  // the score less the scale's penalty
  for (const double scale : scales) {
    const double w = box.width * scale, h = box.height * scale;
    const cv::Point2d c(box.x + box.width / 2, box.y + box.height / 2);
    const double sx = templ_.cols / w, sy = templ_.rows / h;
    // The search area along the region's own axes (turned by `angle` about its centre).
    const cv::Rect2d area(c.x - w / 2 - margin * w, c.y - h / 2 - margin * h, w * (1 + 2 * margin),
                          h * (1 + 2 * margin));
    const cv::Size wsize(static_cast<int>(std::lround(area.width * sx)),
                         static_cast<int>(std::lround(area.height * sy)));
    if (!sample(gray, area, wsize, 0.5, &window, angle)) continue;
    const double ax = wsize.width / area.width, ay = wsize.height / area.height;  // the window's own scale
    AppearanceMatch m = bestMatch(templ_, window, area.tl(), ax, ay, &response);
    if (!m.found) continue;
    if (!unturned(angle)) turnBack(&m.box, c, angle);
    if (scale == 1.0) {
      // The response at the box itself (no shift): how well the prediction looks.
      const int px = std::clamp(static_cast<int>(std::lround((box.x - area.x) * ax)), 0, response.cols - 1);
      const int py = std::clamp(static_cast<int>(std::lround((box.y - area.y) * ay)), 0, response.rows - 1);
      best.score_at_box = response.at<float>(py, px);
    }
    if (m.score - scalePenalty(scale) > best_key) {
      best_key = m.score - scalePenalty(scale);
      const double keep = best.score_at_box;
      best = m;
      best.score_at_box = keep;
    }
  }
  return best;
}

AppearanceMatch RegionAppearance::matchAnywhere(const cv::Mat& gray, const cv::Rect2d& box,
                                               const std::vector<double>& scales, double angle) const {
  return matchCoarse(gray, box, cv::Rect2d(0, 0, gray.cols, gray.rows), 1.0, false, scales, angle);
}

AppearanceMatch RegionAppearance::matchWide(const cv::Mat& gray, const cv::Rect2d& box, double margin,
                                            const std::vector<double>& scales, double angle) const {
  // Wide enough for the largest scale's box (and the coarse search's own, at
  // scale 1) shifted by the margin, along the region's turned axes.
  double largest = 1.0;
  for (const double s : scales) largest = std::max(largest, s);
  const double kx = (0.5 * largest + margin) * box.width, ky = (0.5 * largest + margin) * box.height;
  const cv::Point2d c(box.x + box.width / 2, box.y + box.height / 2);
  return matchCoarse(gray, box, cv::Rect2d(c.x - kx, c.y - ky, 2 * kx, 2 * ky), 0.5, true, scales, angle);
}

AppearanceMatch RegionAppearance::matchCoarse(const cv::Mat& gray, const cv::Rect2d& box, const cv::Rect2d& area,
                                              double min_inside, bool along_axes, const std::vector<double>& scales,
                                              double angle) const {
  if (!valid() || gray.empty() || !(box.width >= 1 && box.height >= 1)) return AppearanceMatch();
  // Coarse to fine: `area` is read shrunk so that the box's template is 12
  // px along its shorter side (a quarter of the cost of a 40 x 24 one) and
  // searched with the template shrunk as far; the best place is then
  // matched with the whole template close around it at each of `scales`.
  // At 640x480, a 60 x 50 box, five scales: 1.1 ms over the whole frame
  // (each scale searched coarsely on its own took 2.6 ms), 0.41 ms three
  // boxes wide (the full template at each scale there took 1.5 ms).
  const double coarse = std::min(1.0, 12.0 / std::min(templ_.cols, templ_.rows));
  const cv::Size tsize(std::max(4, static_cast<int>(std::lround(templ_.cols * coarse))),
                       std::max(4, static_cast<int>(std::lround(templ_.rows * coarse))));
  cv::Mat t = templ_;
  if (tsize != templ_.size()) cv::resize(templ_, t, tsize, 0, 0, cv::INTER_AREA);
  // The window at the coarse template's own scale (its size rounded).
  const double sx = t.cols / box.width, sy = t.rows / box.height;
  const cv::Size wsize(static_cast<int>(std::lround(area.width * sx)), static_cast<int>(std::lround(area.height * sy)));
  // A turned region: read along its axes (`area` is about the box's centre
  // in them), or, over the whole frame, the coarse template turned instead
  // (its corners repeat its border; the refinement below reads it turned; a
  // small turn moves a 12 px template's corners by under a pixel).
  const bool axes = along_axes && !unturned(angle);
  cv::Mat window, response;
  if (!sample(gray, area, wsize, min_inside, &window, axes ? angle : 0)) return AppearanceMatch();
  const double ax = wsize.width / area.width, ay = wsize.height / area.height;  // the window's own scale
  if (!axes && std::abs(angle) > kCoarseTurn) {
    cv::Mat turned;
    const cv::Point2f tc(static_cast<float>(t.cols / 2.0 - 0.5), static_cast<float>(t.rows / 2.0 - 0.5));
    cv::warpAffine(t, turned, cv::getRotationMatrix2D(tc, -angle * 180 / M_PI, 1.0), t.size(), cv::INTER_LINEAR,
                   cv::BORDER_REPLICATE);
    t = turned;
  }
  AppearanceMatch m = bestMatch(t, window, area.tl(), ax, ay, &response);
  if (m.found && axes) turnBack(&m.box, cv::Point2d(area.x + area.width / 2, area.y + area.height / 2), angle);
  // Refined within two coarse pixels either way (along the shorter side too).
  return m.found ? match(gray, m.box, 2.0 / std::min(t.cols, t.rows), scales, angle) : m;
}

double RegionAppearance::scoreAt(const cv::Mat& gray, const cv::Rect2d& box, double angle) const {
  cv::Mat now, response;
  if (!valid() || gray.empty() || !sample(gray, box, templ_.size(), 0.5, &now, angle)) return -1;
  correlateNormed(now, templ_, &response);
  const float r = response.at<float>(0, 0);
  return std::isfinite(r) ? r : -1;
}

void RegionAppearance::blend(const cv::Mat& gray, const cv::Rect2d& box, double rate, double angle) {
  cv::Mat now;
  if (!valid() || !(rate > 0) || !sample(gray, box, templ_.size(), 0.75, &now, angle)) return;
  cv::Mat next;
  cv::addWeighted(templ_, 1 - std::min(rate, 1.0), now, std::min(rate, 1.0), 0, next);
  templ_ = next;  // a new buffer: states that share the old template keep it
}

}  // namespace imt
