#include "region_shape.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace imt {
namespace {

// How concentrated the edges' orientation must be for a turned rectangle to
// be tried: a poster's or a screen's edges and print run two ways (0.73-0.74
// on POT-210's posters turned at their clips' middle frames), a boat's hull,
// its railings and their reflections less so (0.56-0.57 on UAV123's boat1),
// a textured card's not at all (0.02-0.07). docs/benchmarks.md has the
// figures of every real start; the thresholds were chosen between them.
constexpr double kMinConcentration = 0.7;
// How much stronger than the box's mean the edges across each side must be,
// on the weakest side: POT-210's turned posters 2.1-5.8 and as drawn
// 1.51-10.4, boat1's box as drawn 0.10-0.50 and, taken as a turned
// rectangle (its railings run along the hull), 0.6-1.7.
constexpr double kMinSideContrast = 1.5;
// Turns under this (rad) are read as none: the sides' sampling would not
// tell them apart.
constexpr double kMinTurn = 0.05;
// How far either way of the edges' mean orientation the rectangle's turn is
// looked for (rad, 3 degrees), in this many steps each way.
constexpr double kRefineTurn = 3 * M_PI / 180;
constexpr int kRefineSteps = 6;
// Sobel's margin, and how far across a side its edge is looked for (px).
constexpr int kAcross = 2;
constexpr int kMargin = kAcross + 2;

// The edges' orientation in `box` (mod pi/2) and its concentration: the mean
// of exp(4 i phi) over the gradients' directions phi, weighed by their
// squared magnitude, on the box shrunk to at most 96 px a side.
double edgeAngle(const cv::Mat& gray, const cv::Rect& box, double* concentration) {
  *concentration = 0;
  cv::Mat small, gx, gy;
  const double k = std::min(1.0, 96.0 / std::max(box.width, box.height));
  if (k < 1)
    cv::resize(gray(box), small, cv::Size(), k, k, cv::INTER_AREA);
  else
    small = gray(box);
  // Scharr's kernels: Sobel's read a turned edge's orientation up to 10%
  // closer to the axes (a poster turned 25 degrees at 23.2).
  cv::Scharr(small, gx, CV_32F, 1, 0);
  cv::Scharr(small, gy, CV_32F, 0, 1);
  double c = 0, s = 0, sum = 0;
  for (int y = 1; y < small.rows - 1; ++y)
    for (int x = 1; x < small.cols - 1; ++x) {
      const double a = gx.at<float>(y, x), b = gy.at<float>(y, x), w = a * a + b * b;
      if (w <= 0) continue;
      const double phi = std::atan2(b, a);
      c += w * std::cos(4 * phi);
      s += w * std::sin(4 * phi);
      sum += w;
    }
  if (sum <= 0) return 0;
  *concentration = std::hypot(c, s) / sum;
  return std::atan2(s, c) / 4;
}

// The frame's gradients on a crop, read by image pixel.
struct Gradients {
  cv::Mat gx, gy;
  cv::Point origin;
  cv::Size image;
  // |gradient . n| at the image pixel nearest p; -1 outside the image's inner part.
  double across(const cv::Point2d& p, const cv::Point2d& n) const {
    const int x = static_cast<int>(std::lround(p.x)), y = static_cast<int>(std::lround(p.y));
    if (x < 1 || y < 1 || x >= image.width - 1 || y >= image.height - 1) return -1;
    const int cx = x - origin.x, cy = y - origin.y;
    if (cx < 0 || cy < 0 || cx >= gx.cols || cy >= gx.rows) return -1;
    return std::abs(gx.at<float>(cy, cx) * n.x + gy.at<float>(cy, cx) * n.y);
  }
  double magnitude(const cv::Point2d& p) const {
    const double a = across(p, {1, 0}), b = across(p, {0, 1});
    return a < 0 ? -1 : std::hypot(a, b);
  }
};

// The edge strength across the weakest side of the w x h rectangle about m
// turned by t, over the mean gradient inside it: along each side, 32 samples
// over its middle 80%, each the strongest gradient across the side within
// kAcross px. Sides mostly outside the image are not counted; 0 when none is.
double weakestSide(const Gradients& g, const cv::Point2d& m, double w, double h, double t) {
  const cv::Point2d ux(std::cos(t), std::sin(t)), uy(-std::sin(t), std::cos(t));
  constexpr int kGrid = 40;
  double mean = 0;
  int n = 0;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j) {
      const double v = g.magnitude(m + ((i + 0.5) / kGrid - 0.5) * w * ux + ((j + 0.5) / kGrid - 0.5) * h * uy);
      if (v < 0) continue;
      mean += v;
      ++n;
    }
  if (n == 0 || mean <= 0) return 0;
  mean /= n;
  struct Side {
    cv::Point2d mid, along, normal;
    double length;
  };
  const Side sides[4] = {{m - 0.5 * h * uy, ux, uy, w}, {m + 0.5 * h * uy, ux, uy, w},
                         {m - 0.5 * w * ux, uy, ux, h}, {m + 0.5 * w * ux, uy, ux, h}};
  constexpr int kSamples = 32;
  double weakest = -1;
  for (const Side& s : sides) {
    double sum = 0;
    int count = 0;
    for (int i = 0; i < kSamples; ++i) {
      const cv::Point2d p = s.mid + (0.8 * (i + 0.5) / kSamples - 0.4) * s.length * s.along;
      double best = -1;
      for (int k = -kAcross; k <= kAcross; ++k) best = std::max(best, g.across(p + k * s.normal, s.normal));
      if (best < 0) continue;
      sum += best;
      ++count;
    }
    if (count < kSamples / 4) continue;
    const double contrast = sum / count / mean;
    weakest = weakest < 0 ? contrast : std::min(weakest, contrast);
  }
  return std::max(0.0, weakest);
}

}  // namespace

PlacedShape placedShape(const cv::Mat& gray, const cv::Rect2d& box) {
  PlacedShape out;
  out.box = box;
  if (gray.empty() || gray.type() != CV_8UC1 || !(box.width >= 8 && box.height >= 8)) return out;
  const cv::Rect inside = cv::Rect(box) & cv::Rect(0, 0, gray.cols, gray.rows);
  if (inside.width < 8 || inside.height < 8 || inside.area() < 0.75 * box.area()) return out;
  out.edge_angle = edgeAngle(gray, inside, &out.edge_concentration);
  const cv::Rect crop = cv::Rect(static_cast<int>(std::floor(box.x)) - kMargin,
                                 static_cast<int>(std::floor(box.y)) - kMargin,
                                 static_cast<int>(std::ceil(box.width)) + 2 * kMargin + 1,
                                 static_cast<int>(std::ceil(box.height)) + 2 * kMargin + 1) &
                        cv::Rect(0, 0, gray.cols, gray.rows);
  Gradients g;
  g.origin = crop.tl();
  g.image = gray.size();
  cv::Sobel(gray(crop), g.gx, CV_32F, 1, 0);
  cv::Sobel(gray(crop), g.gy, CV_32F, 0, 1);
  const cv::Point2d m(box.x + box.width / 2, box.y + box.height / 2);
  out.drawn_sides = weakestSide(g, m, box.width, box.height, 0);
  // The rectangle turned by t whose extent is the box (w c + h s = W,
  // w s + h c = H), tried at turns up to kRefineTurn either way of the
  // edges' mean orientation: a poster seen in perspective has sides a
  // degree or two apart, and a side 2 degrees off leaves its ends 7 px from
  // a 400 px edge. The turn whose rectangle's sides lie on the edges best.
  cv::Rect2d best_box;
  double best_turn = 0;
  if (out.edge_concentration >= kMinConcentration) {
    for (int k = -kRefineSteps; k <= kRefineSteps; ++k) {
      const double t = out.edge_angle + k * kRefineTurn / kRefineSteps;
      const double c = std::cos(t), s = std::abs(std::sin(t)), d = c * c - s * s;
      const double w = (box.width * c - box.height * s) / d, h = (box.height * c - box.width * s) / d;
      if (std::abs(t) <= kMinTurn || d < 0.1 || w < 0.3 * box.width || h < 0.3 * box.height) continue;
      const double sides = weakestSide(g, m, w, h, t);
      if (sides > out.turned_sides) {
        out.turned_sides = sides;
        best_turn = t;
        best_box = cv::Rect2d(m.x - w / 2, m.y - h / 2, w, h);
      }
    }
  }
  if (out.turned_sides >= kMinSideContrast && out.turned_sides > out.drawn_sides) {
    out.rectangle = true;
    out.box = best_box;
    out.angle = best_turn;
  } else if (out.drawn_sides >= kMinSideContrast) {
    out.rectangle = true;
  }
  return out;
}

}  // namespace imt
