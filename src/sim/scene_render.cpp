// Rasterisation of textured planes for the scene generator: exact edge
// coverage of a projected rectangle and trilinear (mip-mapped) texture lookup
// by inverse mapping. See scene.h for the design; pixel coordinates here are
// canvas coordinates in the corner convention (pixel (x, y) covers
// [x, x+1) x [y, y+1)).
#include "scene_internal.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace imt {
namespace scene_detail {

Polygon clipPolygon(const Polygon& poly, const HalfPlane& h) {
  Polygon out;
  const size_t n = poly.size();
  if (n == 0) return out;
  out.reserve(n + 1);
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector2d& p = poly[i];
    const Eigen::Vector2d& q = poly[(i + 1) % n];
    const double fp = h.eval(p.x(), p.y());
    const double fq = h.eval(q.x(), q.y());
    if (fp >= 0) out.push_back(p);
    if ((fp >= 0) != (fq >= 0)) {
      const double s = fp / (fp - fq);
      out.push_back(p + s * (q - p));
    }
  }
  return out;
}

double polygonArea(const Polygon& poly) {
  double a = 0;
  for (size_t i = 0, n = poly.size(); i < n; ++i) {
    const Eigen::Vector2d& p = poly[i];
    const Eigen::Vector2d& q = poly[(i + 1) % n];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * std::abs(a);
}

Polygon rectPolygon(double x0, double y0, double x1, double y1) {
  return {Eigen::Vector2d(x0, y0), Eigen::Vector2d(x1, y0), Eigen::Vector2d(x1, y1),
          Eigen::Vector2d(x0, y1)};
}

PlaneView makePlaneView(const Eigen::Matrix3d& K, const Eigen::Isometry3d& T_cam_plane,
                        double width_m, double height_m, int canvas_w, int canvas_h) {
  PlaneView v;
  Eigen::Matrix3d M;
  M.col(0) = T_cam_plane.linear().col(0);
  M.col(1) = T_cam_plane.linear().col(1);
  M.col(2) = T_cam_plane.translation();
  v.G = K * M;
  v.distance = std::abs(T_cam_plane.linear().col(2).dot(T_cam_plane.translation()));
  const double det = v.G.determinant();
  // det = 0: the camera centre lies in the plane (seen edge-on): nothing visible.
  if (!std::isfinite(det) || std::abs(det) < 1e-12 * std::pow(v.G.norm(), 3)) {
    v.empty = true;
    return v;
  }
  v.Ginv = v.G.inverse();
  const Eigen::RowVector3d rx = v.Ginv.row(0), ry = v.Ginv.row(1), rw = v.Ginv.row(2);
  // With (X, Y, w) = Ginv (u, v, 1) and w = 1 / depth, the visible set is
  // w > 0 and |X| <= W/2 w, |Y| <= H/2 w: all linear in (u, v). Dividing by w
  // first (as warpPerspective does) would also accept points behind the camera.
  const Eigen::RowVector3d rows[5] = {rw, rx + 0.5 * width_m * rw, 0.5 * width_m * rw - rx,
                                      ry + 0.5 * height_m * rw, 0.5 * height_m * rw - ry};
  for (const Eigen::RowVector3d& r : rows) {
    const double n = std::hypot(r(0), r(1));
    if (n <= 1e-15 * std::abs(r(2))) {  // constant over the image plane
      if (r(2) <= 0) v.empty = true;
      continue;
    }
    v.bounds.push_back({r(0) / n, r(1) / n, r(2) / n});  // signed distance in canvas px
  }
  if (v.empty) return v;
  v.visible = rectPolygon(0, 0, canvas_w, canvas_h);
  for (const HalfPlane& h : v.bounds) {
    v.visible = clipPolygon(v.visible, h);
    if (v.visible.size() < 3) break;
  }
  if (v.visible.size() < 3 || polygonArea(v.visible) <= 0) v.visible.clear();
  return v;
}

namespace {

// Pixels of one canvas row touched by the plane: [x0, x1); of those,
// [f0, f1) are fully inside it (coverage 1), the others partly.
struct RowSpan {
  int y = 0;
  int x0 = 0, x1 = 0;
  int f0 = 0, f1 = 0;
};

// x-interval of the horizontal line at height y inside all bounds and [0, w].
void lineInterval(const std::vector<HalfPlane>& bounds, double y, double w, double* lo,
                  double* hi) {
  *lo = 0;
  *hi = w;
  for (const HalfPlane& h : bounds) {
    const double rest = h.b * y + h.c;
    if (h.a > 0) {
      *lo = std::max(*lo, -rest / h.a);
    } else if (h.a < 0) {
      *hi = std::min(*hi, -rest / h.a);
    } else if (rest < 0) {
      *lo = w;
      *hi = 0;
    }
  }
}

std::vector<RowSpan> rowSpans(const PlaneView& view, int canvas_w, int canvas_h) {
  std::vector<RowSpan> spans;
  if (view.visible.empty()) return spans;
  double ymin = canvas_h, ymax = 0;
  for (const Eigen::Vector2d& p : view.visible) {
    ymin = std::min(ymin, p.y());
    ymax = std::max(ymax, p.y());
  }
  const int r0 = std::max(0, static_cast<int>(std::floor(ymin)));
  const int r1 = std::min(canvas_h, static_cast<int>(std::ceil(ymax)));
  spans.reserve(r1 - r0);
  for (int y = r0; y < r1; ++y) {
    Polygon strip = clipPolygon(view.visible, {0, 1, -double(y)});
    strip = clipPolygon(strip, {0, -1, double(y + 1)});
    if (strip.size() < 3) continue;
    double xmin = canvas_w, xmax = 0;
    for (const Eigen::Vector2d& p : strip) {
      xmin = std::min(xmin, p.x());
      xmax = std::max(xmax, p.x());
    }
    RowSpan s;
    s.y = y;
    s.x0 = std::max(0, static_cast<int>(std::floor(xmin)));
    s.x1 = std::min(canvas_w, static_cast<int>(std::ceil(xmax)));
    if (s.x1 <= s.x0) continue;
    // Fully covered: inside the polygon along both the row's top and bottom
    // edges (the left boundary of a convex polygon is a convex function of y,
    // so its maximum over [y, y+1] is at an end; likewise the right one).
    double lo0, hi0, lo1, hi1;
    lineInterval(view.bounds, y, canvas_w, &lo0, &hi0);
    lineInterval(view.bounds, y + 1, canvas_w, &lo1, &hi1);
    const double lo = std::max(lo0, lo1), hi = std::min(hi0, hi1);
    s.f0 = s.f1 = s.x0;
    if (lo < hi) {
      s.f0 = std::clamp(static_cast<int>(std::ceil(lo)), s.x0, s.x1);
      s.f1 = std::clamp(static_cast<int>(std::floor(hi)), s.f0, s.x1);
    }
    spans.push_back(s);
  }
  return spans;
}

// Exact area of pixel (x, y) inside the plane.
double pixelCoverage(const std::vector<HalfPlane>& bounds, int x, int y) {
  Polygon p = rectPolygon(x, y, x + 1, y + 1);
  for (const HalfPlane& h : bounds) {
    // Bounds are signed distances: beyond half the pixel diagonal from the
    // centre they contain the whole pixel (the common case) or none of it.
    const double d = h.eval(x + 0.5, y + 0.5);
    if (d >= 0.7072) continue;
    if (d <= -0.7072) return 0;
    p = clipPolygon(p, h);
    if (p.size() < 3) return 0;
  }
  return std::min(1.0, polygonArea(p));
}

// Linear function of canvas coordinates, not normalised: g(u, v) = r . (u, v, 1).
HalfPlane linear(const Eigen::RowVector3d& r) { return {r(0), r(1), r(2)}; }

// Pixel-centre interval [lo, hi) of row y inside all `bounds` -> the pixel
// indices [*x0, *x1) whose centres lie in it (adjacent cells whose bounds are
// exact negations of each other partition the row).
void centreRange(const std::vector<HalfPlane>& bounds, int y, int width, int* x0, int* x1) {
  double lo = -1e300, hi = 1e300;
  const double v = y + 0.5;
  for (const HalfPlane& h : bounds) {
    const double rest = h.b * v + h.c;
    if (h.a > 0) {
      lo = std::max(lo, -rest / h.a);
    } else if (h.a < 0) {
      hi = std::min(hi, -rest / h.a);
    } else if (rest < 0) {
      *x0 = *x1 = 0;
      return;
    }
  }
  *x0 = static_cast<int>(std::clamp(std::ceil(lo - 0.5), 0.0, double(width)));
  *x1 = static_cast<int>(std::clamp(std::ceil(hi - 0.5), 0.0, double(width)));
}

// Texture values (trilinear) of the plane's pixels into `val` (ROI-local).
// The plane's pixels are split into convex cells, each one mip band (lod in
// [a, a+1)) of one texture tile; both limits are straight lines in the image
// (lod depends on the depth only; tile edges are lines of the plane). Each
// cell is one or two warpPerspective calls over its bounding box.
void sampleTexture(const PlaneView& view, const PlaneLook& look, const std::vector<RowSpan>& spans,
                   const cv::Rect& roi, int canvas_w, cv::Mat* val) {
  const MipTexture& tex = *look.texture;
  const double width_m = look.width_m, height_m = look.height_m;
  const bool tiled = look.tile_w_m > 0;
  // Metres covered by the texture once: the tile, or the whole plane.
  const double span_x = tiled ? look.tile_w_m : width_m;
  const double span_y = tiled ? look.tile_w_m * tex.height() / tex.width() : height_m;
  const int tiles_x = tiled ? std::max(1, static_cast<int>(std::ceil(width_m / span_x - 1e-9))) : 1;
  const int tiles_y =
      tiled ? std::max(1, static_cast<int>(std::ceil(height_m / span_y - 1e-9))) : 1;
  const Eigen::RowVector3d rx = view.Ginv.row(0), ry = view.Ginv.row(1), rw = view.Ginv.row(2);
  const int nlev = static_cast<int>(tex.levels.size());

  // Mip level: log2 of the texel footprint (level-0 texels per canvas pixel)
  // along the plane's most compressed direction, so that oblique planes (the
  // floor toward the horizon) do not alias. The geometric mean of the two
  // directions is sqrt(|det J|), det J = sx sy det(Ginv) / w^3; the
  // anisotropy (ratio of the directions) is ~ range / h = z / h = 1 / (w h)
  // for a plane at distance h (off-axis pinhole factors < 1.2 ignored), so
  // lod = log2 sqrt|det J| + 0.5 log2(1 / (w h)): still a function of w only.
  const double sx = tex.width() / span_x, sy = tex.height() / span_y;
  const double h = std::max(1e-6, view.distance);
  const double c0 =
      0.5 * std::log2(sx * sy * std::abs(view.Ginv.determinant())) - 0.5 * std::log2(h);
  auto lodOfW = [&](double w) { return c0 - 2.0 * std::log2(std::max(w, 1e-300)); };
  auto wOfLod = [&](double lod) { return std::exp2((c0 - lod) / 2.0); };
  auto wAt = [&](const Eigen::Vector2d& p) { return rw(0) * p.x() + rw(1) * p.y() + rw(2); };

  double wmin = std::numeric_limits<double>::infinity(), wmax = 0;
  for (const Eigen::Vector2d& p : view.visible)
    wmin = std::min(wmin, wAt(p)), wmax = std::max(wmax, wAt(p));
  int a_lo = 0, a_hi = 0;
  if (nlev > 1 && lodOfW(wmin) > 0) {
    a_lo = std::clamp(static_cast<int>(std::floor(lodOfW(wmax))), 0, nlev - 2);
    a_hi = std::clamp(static_cast<int>(std::floor(lodOfW(wmin))), 0, nlev - 2);
  }

  // Pixel centres of the ROI that may belong to the plane: within 1 px of it
  // (edge pixels' centres may lie just outside) and strictly in front.
  Polygon centres =
      rectPolygon(roi.x + 0.5, roi.y + 0.5, roi.x + roi.width - 0.5, roi.y + roi.height - 0.5);
  for (const HalfPlane& h : view.bounds) centres = clipPolygon(centres, {h.a, h.b, h.c + 1.0});
  centres =
      clipPolygon(centres, {rw(0), rw(1), rw(2) - 1e-9 * (std::abs(rw(0)) + std::abs(rw(1)))});
  if (centres.size() < 3) return;

  cv::Mat bufA, bufB;
  std::vector<HalfPlane> cell;
  std::vector<float> lut;
  for (int a = a_lo; a <= a_hi; ++a) {
    // Band a: lod in [a, a+1), i.e. w in (w_lo, w_hi]; the first and last
    // bands also take what lies beyond them.
    const double w_hi = wOfLod(a), w_lo = wOfLod(a + 1);
    std::vector<HalfPlane> band;
    if (a != a_lo) band.push_back(linear(Eigen::RowVector3d(0, 0, w_hi) - rw));
    if (a != a_hi) band.push_back(linear(rw - Eigen::RowVector3d(0, 0, w_lo)));
    Polygon band_poly = centres;
    for (const HalfPlane& h : band) band_poly = clipPolygon(band_poly, h);
    if (band_poly.size() < 3) continue;

    // Tiles the band touches (from its outline in plane coordinates).
    double X0 = 1e300, X1 = -1e300, Y0 = 1e300, Y1 = -1e300, bwmin = 1e300, bwmax = 0;
    for (const Eigen::Vector2d& p : band_poly) {
      const double w = wAt(p);
      const double X = (rx(0) * p.x() + rx(1) * p.y() + rx(2)) / w;
      const double Y = (ry(0) * p.x() + ry(1) * p.y() + ry(2)) / w;
      X0 = std::min(X0, X), X1 = std::max(X1, X), Y0 = std::min(Y0, Y), Y1 = std::max(Y1, Y);
      bwmin = std::min(bwmin, w), bwmax = std::max(bwmax, w);
    }
    auto tileIndex = [](double coord, double span, int n) {
      return std::clamp(static_cast<int>(std::floor(std::clamp(coord / span, -1.0, n + 1.0))), 0,
                        n - 1);
    };
    const int i0 = tileIndex(X0 + 0.5 * width_m, span_x, tiles_x),
              i1 = tileIndex(X1 + 0.5 * width_m, span_x, tiles_x);
    const int j0 = tileIndex(Y0 + 0.5 * height_m, span_y, tiles_y),
              j1 = tileIndex(Y1 + 0.5 * height_m, span_y, tiles_y);

    // Blend weight t = clamp(lod - a, 0, 1): constant when lod hardly varies,
    // else from a table over w (1024 entries; t moves < 2e-3 between them).
    const double band_lod_min = lodOfW(bwmax), band_lod_max = lodOfW(bwmin);
    const bool need_b = nlev > 1 && band_lod_max > a;
    const bool const_t = band_lod_max - band_lod_min < 0.02;
    const float t_const =
        static_cast<float>(std::clamp(0.5 * (band_lod_min + band_lod_max) - a, 0.0, 1.0));
    constexpr int kLut = 1024;
    const double lut_scale = (kLut - 1) / std::max(bwmax - bwmin, 1e-300);
    if (need_b && !const_t) {
      lut.resize(kLut);
      for (int k = 0; k < kLut; ++k)
        lut[k] = static_cast<float>(std::clamp(lodOfW(bwmin + k / lut_scale) - a, 0.0, 1.0));
    }

    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        // Tile (i, j): X in [Xa, Xb), Y in [Ya, Yb) (plane metres, from the
        // centre); the plane's outermost tiles are open outwards.
        const double Xa = -0.5 * width_m + i * span_x, Xb = Xa + span_x;
        const double Ya = -0.5 * height_m + j * span_y, Yb = Ya + span_y;
        cell = band;
        if (i > 0) cell.push_back(linear(rx - Xa * rw));
        if (i + 1 < tiles_x) cell.push_back(linear(Xb * rw - rx));
        if (j > 0) cell.push_back(linear(ry - Ya * rw));
        if (j + 1 < tiles_y) cell.push_back(linear(Yb * rw - ry));
        Polygon poly = band_poly;
        for (size_t k = band.size(); k < cell.size() && poly.size() >= 3; ++k)
          poly = clipPolygon(poly, cell[k]);
        if (poly.size() < 3) continue;
        double bx0 = 1e300, by0 = 1e300, bx1 = -1e300, by1 = -1e300;
        for (const Eigen::Vector2d& p : poly) {
          bx0 = std::min(bx0, p.x()), bx1 = std::max(bx1, p.x());
          by0 = std::min(by0, p.y()), by1 = std::max(by1, p.y());
        }
        cv::Rect brect(static_cast<int>(std::floor(bx0 - 0.5)),
                       static_cast<int>(std::floor(by0 - 0.5)), 0, 0);
        brect.width = static_cast<int>(std::ceil(bx1 - 0.5)) + 1 - brect.x;
        brect.height = static_cast<int>(std::ceil(by1 - 0.5)) + 1 - brect.y;
        brect &= roi;
        if (brect.empty()) continue;

        // dst pixel (p, q) -> canvas corner coords -> plane metres -> texel of
        // level L relative to the tile, in the padded image, OpenCV centres.
        Eigen::Matrix3d T;
        T << 1, 0, brect.x + 0.5, 0, 1, brect.y + 0.5, 0, 0, 1;
        auto warpLevel = [&](int L, cv::Mat* out) {
          const cv::Mat& img = tex.levels[L];
          const double sxl = (img.cols - 2 * tex.pad) / span_x,
                       syl = (img.rows - 2 * tex.pad) / span_y;
          Eigen::Matrix3d A;
          A << sxl, 0, -sxl * Xa + tex.pad - 0.5, 0, syl, -syl * Ya + tex.pad - 0.5, 0, 0, 1;
          const Eigen::Matrix3d M = A * view.Ginv * T;
          cv::Matx33d Mcv;
          for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) Mcv(r, c) = M(r, c);
          cv::warpPerspective(img, *out, Mcv, brect.size(), cv::INTER_LINEAR | cv::WARP_INVERSE_MAP,
                              cv::BORDER_REPLICATE);
        };
        warpLevel(a, &bufA);
        if (need_b) warpLevel(a + 1, &bufB);

        for (const RowSpan& s : spans) {
          if (s.y < brect.y || s.y >= brect.y + brect.height) continue;
          int cx0, cx1;
          centreRange(cell, s.y, canvas_w, &cx0, &cx1);
          const int xa = std::max({s.x0, brect.x, cx0}),
                    xb = std::min({s.x1, brect.x + brect.width, cx1});
          if (xa >= xb) continue;
          const uint8_t* pa = bufA.ptr<uint8_t>(s.y - brect.y) - brect.x;
          float* pv = val->ptr<float>(s.y - roi.y) - roi.x;
          if (!need_b) {
            for (int x = xa; x < xb; ++x) pv[x] = pa[x];
            continue;
          }
          const uint8_t* pb = bufB.ptr<uint8_t>(s.y - brect.y) - brect.x;
          if (const_t) {
            for (int x = xa; x < xb; ++x) pv[x] = pa[x] + t_const * (float(pb[x]) - float(pa[x]));
            continue;
          }
          double w = rw(0) * (xa + 0.5) + rw(1) * (s.y + 0.5) + rw(2);
          for (int x = xa; x < xb; ++x, w += rw(0)) {
            const float t =
                lut[std::clamp(static_cast<int>((w - bwmin) * lut_scale + 0.5), 0, kLut - 1)];
            pv[x] = pa[x] + t * (float(pb[x]) - float(pa[x]));
          }
        }
      }
    }
  }
}

}  // namespace

void paintPlane(const PlaneView& view, const PlaneLook& look, cv::Mat* canvas) {
  CV_Assert(canvas->type() == CV_32FC1);
  if (view.empty || view.visible.empty()) return;
  const std::vector<RowSpan> spans = rowSpans(view, canvas->cols, canvas->rows);
  if (spans.empty()) return;
  int x0 = canvas->cols, x1 = 0;
  for (const RowSpan& s : spans) x0 = std::min(x0, s.x0), x1 = std::max(x1, s.x1);
  const cv::Rect roi(x0, spans.front().y, x1 - x0, spans.back().y + 1 - spans.front().y);

  cv::Mat val;
  const bool textured = look.texture != nullptr && !look.texture->levels.empty();
  if (textured) {
    val.create(roi.size(), CV_32FC1);
    sampleTexture(view, look, spans, roi, canvas->cols, &val);
  }
  const float flat = static_cast<float>(look.flat_gray);
  for (const RowSpan& s : spans) {
    float* dst = canvas->ptr<float>(s.y);
    const float* src = textured ? val.ptr<float>(s.y - roi.y) - roi.x : nullptr;
    for (int x = s.x0; x < s.x1; ++x) {
      const float v = textured ? src[x] : flat;
      if (x >= s.f0 && x < s.f1) {
        dst[x] = v;
      } else {
        const float alpha = static_cast<float>(pixelCoverage(view.bounds, x, s.y));
        dst[x] += alpha * (v - dst[x]);
      }
    }
  }
}

}  // namespace scene_detail
}  // namespace imt
