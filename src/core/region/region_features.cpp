#include "region_features.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>

namespace imt {
namespace {

constexpr int kWindow = 13;              // LK window, crop px
constexpr int kLevels = 2;               // pyramid levels above the crop
constexpr double kFbMaxError = 0.7;      // crop px, forward-backward check
constexpr double kMinDistance = 4.0;     // crop px between corners
constexpr double kQuality = 0.01;        // relative to the crop's best corner

// Crop px per image px for a box: 1 for small boxes, less for large ones.
double cropScale(const cv::Rect2d& box, int scale_px) {
  const double side = std::max(box.width, box.height);
  return side > scale_px ? scale_px / side : 1.0;
}

// The integer pixels of `area` in `image` (clipped).
cv::Rect pixelsOf(const cv::Mat& image, const cv::Rect2d& area) {
  return cv::Rect(cv::Point(static_cast<int>(std::floor(area.x)), static_cast<int>(std::floor(area.y))),
                  cv::Point(static_cast<int>(std::ceil(area.br().x)), static_cast<int>(std::ceil(area.br().y)))) &
         cv::Rect(0, 0, image.cols, image.rows);
}

// `area` of `image` (clipped) resampled by `s`; `origin` its top-left in the image.
bool crop(const cv::Mat& image, const cv::Rect2d& area, double s, cv::Mat* out, cv::Point2d* origin) {
  const cv::Rect r = pixelsOf(image, area);
  if (r.width < 8 || r.height < 8) return false;
  *origin = cv::Point2d(r.x, r.y);
  if (s >= 1.0) {
    *out = image(r);
  } else {
    cv::resize(image(r), *out,
               cv::Size(std::max(1, static_cast<int>(std::lround(r.width * s))),
                        std::max(1, static_cast<int>(std::lround(r.height * s)))),
               0, 0, cv::INTER_AREA);
  }
  return true;
}

cv::Point2f toCrop(const cv::Point2f& p, const cv::Point2d& origin, double s) {
  return cv::Point2f(static_cast<float>((p.x - origin.x) * s), static_cast<float>((p.y - origin.y) * s));
}
cv::Point2f fromCrop(const cv::Point2f& p, const cv::Point2d& origin, double s) {
  return cv::Point2f(static_cast<float>(p.x / s + origin.x), static_cast<float>(p.y / s + origin.y));
}

}  // namespace

std::vector<OwnFeature> trackOwnFeatures(const cv::Mat& from, const cv::Mat& to,
                                         const std::vector<cv::Point2f>& points,
                                         const std::vector<uint32_t>& ids, const cv::Rect2d& box,
                                         const Eigen::Matrix3d& H, const Eigen::Vector2d& shift, int scale_px,
                                         const std::vector<cv::Mat>* from_pyramid,
                                         const std::vector<cv::Mat>* to_pyramid) {
  std::vector<OwnFeature> out;
  if (points.empty() || from.empty() || to.empty() || from.size() != to.size()) return out;
  const double s = cropScale(box, scale_px);
  // Guesses, and one crop that holds the points and their guesses with room
  // for LK's reach around them.
  std::vector<cv::Point2f> guess(points.size());
  cv::Rect2d area(box.tl(), box.br());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector3d q = H * Eigen::Vector3d(points[i].x, points[i].y, 1.0);
    guess[i] = cv::Point2f(static_cast<float>(q.x() / q.z() + shift.x()), static_cast<float>(q.y() / q.z() + shift.y()));
    if (!std::isfinite(guess[i].x) || !std::isfinite(guess[i].y)) guess[i] = points[i];
    area |= cv::Rect2d(guess[i].x, guess[i].y, 0, 0);
    area |= cv::Rect2d(points[i].x, points[i].y, 0, 0);
  }
  const double pad = (kWindow << kLevels) / s * 0.5;
  area = cv::Rect2d(area.x - pad, area.y - pad, area.width + 2 * pad, area.height + 2 * pad);
  // The whole frames' pyramids, shared by many regions, or each crop's
  // (with its derivatives), built once for both ways. Either way a point
  // must end inside the crop: the same points survive both.
  std::vector<cv::Mat> pa, pb;
  cv::Point2d oa, ob;  // the crop's top-left in the image
  cv::Rect2f inside;   // where a tracked point may end, in the crop (or the frame)
  const cv::Size win(kWindow, kWindow);
  int levels;
  if (s >= 1.0 && from_pyramid && to_pyramid && !from_pyramid->empty() && !to_pyramid->empty() &&
      (*from_pyramid)[0].size() == from.size() && (*to_pyramid)[0].size() == to.size()) {
    const cv::Rect r = pixelsOf(to, area);
    if (r.width < 8 || r.height < 8) return out;
    pa = *from_pyramid;
    pb = *to_pyramid;
    levels = static_cast<int>(std::min(pa.size(), pb.size())) / 2 - 1;
    inside = cv::Rect2f(static_cast<float>(r.x), static_cast<float>(r.y), static_cast<float>(r.width - 1),
                        static_cast<float>(r.height - 1));
  } else {
    cv::Mat a, b;
    if (!crop(from, area, s, &a, &oa) || !crop(to, area, s, &b, &ob)) return out;
    if (a.size() != b.size() || oa != ob) return out;
    levels = std::min(cv::buildOpticalFlowPyramid(a, pa, win, kLevels, true),
                      cv::buildOpticalFlowPyramid(b, pb, win, kLevels, true));
    inside = cv::Rect2f(0, 0, static_cast<float>(b.cols - 1), static_cast<float>(b.rows - 1));
  }
  std::vector<cv::Point2f> p0(points.size()), p1(points.size()), back;
  for (size_t i = 0; i < points.size(); ++i) {
    p0[i] = toCrop(points[i], oa, s);
    p1[i] = toCrop(guess[i], ob, s);
  }
  std::vector<uchar> st, st_back;
  std::vector<float> err;
  const cv::TermCriteria term(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01);
  cv::calcOpticalFlowPyrLK(pa, pb, p0, p1, st, err, win, levels, term, cv::OPTFLOW_USE_INITIAL_FLOW);
  back = p0;
  cv::calcOpticalFlowPyrLK(pb, pa, p1, back, st_back, err, win, levels, term, cv::OPTFLOW_USE_INITIAL_FLOW);
  for (size_t i = 0; i < points.size(); ++i) {
    if (!st[i] || !st_back[i] || !inside.contains(p1[i])) continue;
    const cv::Point2f d = back[i] - p0[i];
    if (std::hypot(d.x, d.y) > kFbMaxError) continue;
    out.push_back({ids[i], points[i], fromCrop(p1[i], ob, s)});
  }
  return out;
}

bool ownFeaturesAtFullResolution(const cv::Rect2d& box, int scale_px) { return cropScale(box, scale_px) >= 1.0; }

std::vector<cv::Mat> ownFeaturePyramid(const cv::Mat& image) {
  std::vector<cv::Mat> pyramid;
  if (!image.empty()) cv::buildOpticalFlowPyramid(image, pyramid, cv::Size(kWindow, kWindow), kLevels, true);
  return pyramid;
}

double ownCropPixels(const cv::Rect2d& box, int scale_px) {
  const double pad = kWindow << kLevels;  // both sides
  return ownFeaturesAtFullResolution(box, scale_px) ? 2 * (box.width + pad) * (box.height + pad) : 0.0;
}

bool wholeFramePyramidsPay(double crop_pixels, cv::Size frame) {
  // A crop's pyramid costs ~1.4 times a whole frame's per pixel (OpenCV 4.6,
  // one core: 13 us for a 112 x 102 crop, 0.24 ms for 640 x 480).
  constexpr double kCropCostRatio = 1.4;
  return kCropCostRatio * crop_pixels > frame.area();
}

std::vector<cv::Point2f> detectOwnFeatures(const cv::Mat& image, const cv::Rect2d& box, int count,
                                           const std::vector<cv::Point2f>& existing, int scale_px) {
  std::vector<cv::Point2f> out;
  if (count <= 0 || image.empty()) return out;
  const double s = cropScale(box, scale_px);
  cv::Mat c;
  cv::Point2d o;
  if (!crop(image, box, s, &c, &o)) return out;
  cv::Mat mask(c.size(), CV_8UC1, cv::Scalar(255));
  for (const cv::Point2f& p : existing) cv::circle(mask, toCrop(p, o, s), static_cast<int>(kMinDistance), 0, -1);
  std::vector<cv::Point2f> corners;
  cv::goodFeaturesToTrack(c, corners, count, kQuality, kMinDistance, mask, 3);
  for (const cv::Point2f& p : corners) out.push_back(fromCrop(p, o, s));
  return out;
}

}  // namespace imt
