#include "instant_motion_tracking/core/planar/image_target_detector.h"

#include "instant_motion_tracking/core/planar/planar_target.h"

#include "planar_internal.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>

namespace imt {
namespace {

// A frame's keypoints: eight levels 1.2 apart, so a target larger on screen
// than the picture's largest scale is matched too.
cv::Ptr<cv::ORB> orb(int features) { return cv::ORB::create(features, 1.2f, 8); }

// A quad a tracker can start from (any physical size: only its shape is
// checked), partly in view, neither tiny nor many frames wide (a degenerate fit).
bool usableQuad(const std::array<cv::Point2d, 4>& c, const cv::Size& frame) {
  if (!validateTargetRequest(c, 1, 1).empty()) return false;
  const cv::Rect2d b = planar_detail::quadBounds(c);
  if (!(b.br().x > 0 && b.br().y > 0 && b.x < frame.width && b.y < frame.height)) return false;
  const double extent = std::max(b.width, b.height);
  return extent >= 16 && extent <= 4.0 * std::max(frame.width, frame.height);
}

}  // namespace

std::unique_ptr<ImageTargetDetector> ImageTargetDetector::create(const cv::Mat& picture,
                                                                 const PlanarTargetOptions& options,
                                                                 std::string* error) {
  if (std::string e = options.validate(); !e.empty()) {
    *error = e;
    return nullptr;
  }
  if (picture.empty() || picture.depth() != CV_8U || (picture.channels() != 1 && picture.channels() != 3)) {
    *error = "the picture must be an 8-bit gray or colour image";
    return nullptr;
  }
  if (picture.cols < 32 || picture.rows < 32) {
    *error = "the picture is " + std::to_string(picture.cols) + "x" + std::to_string(picture.rows) +
             " px: at least 32x32 is needed";
    return nullptr;
  }
  cv::Mat gray;
  if (picture.channels() == 3) cv::cvtColor(picture, gray, cv::COLOR_BGR2GRAY);
  else gray = picture;
  std::unique_ptr<ImageTargetDetector> d(new ImageTargetDetector);
  d->options_ = options;
  d->picture_ = gray.clone();
  // Described at one size whatever its resolution: ORB keeps no keypoint
  // within its patch radius of the border, which would leave little of a
  // small picture. `scale`: picture px per described px.
  const double scale = double(std::max(gray.cols, gray.rows)) / options.detect_picture_size;
  cv::resize(gray, gray, cv::Size(), 1 / scale, 1 / scale, scale > 1 ? cv::INTER_AREA : cv::INTER_LINEAR);
  // The picture is its own whole target: its keypoints may lie anywhere in
  // it. Its strongest keypoints only: matching costs keypoints x the frame's.
  // Eight scales 1.2 apart, each with an equal share of the keypoints (ORB's
  // own pyramid gives the small scales few: a target 140 px wide on screen
  // was found on one search in three), each scale padded by reflection so
  // that keypoints near the picture's border are described too.
  constexpr int kLevels = 8, kPad = 32;
  const int per_level = std::max(20, options.detect_picture_features / kLevels);
  std::vector<cv::Mat> parts;
  for (int l = 0; l < kLevels; ++l) {
    const double f = std::pow(1.2, -l);
    cv::Mat level, padded;
    cv::resize(gray, level, cv::Size(), f, f, l ? cv::INTER_AREA : cv::INTER_LINEAR);
    cv::copyMakeBorder(level, padded, kPad, kPad, kPad, kPad, cv::BORDER_REFLECT_101);
    std::vector<cv::KeyPoint> kps;
    cv::Mat desc;
    cv::ORB::create(per_level, 1.2f, 1)->detectAndCompute(padded, cv::noArray(), kps, desc);
    for (int i = 0; i < static_cast<int>(kps.size()); ++i) {
      const cv::Point2f p = kps[i].pt - cv::Point2f(kPad, kPad);
      if (p.x < 0 || p.y < 0 || p.x >= level.cols || p.y >= level.rows) continue;
      kps[i].pt = p * static_cast<float>(scale / f);  // in picture px
      d->keypoints_.push_back(kps[i]);
      parts.push_back(desc.row(i));
    }
  }
  if (!parts.empty()) cv::vconcat(parts, d->descriptors_);
  if (static_cast<int>(d->keypoints_.size()) < options.detect_min_inliers) {
    *error = "the picture has " + std::to_string(d->keypoints_.size()) +
             " keypoints, fewer than planar_tracking.detect_min_inliers (" +
             std::to_string(options.detect_min_inliers) + "): too little texture to be found";
    return nullptr;
  }
  return d;
}

ImageTargetDetector::Frame ImageTargetDetector::describeFrame(const cv::Mat& gray,
                                                              const PlanarTargetOptions& options) {
  Frame f;
  f.gray = gray;
  if (gray.empty()) return f;
  // Tiles, each with its share of the keypoints: a small target among
  // stronger texture elsewhere still gets its own. Each tile is described
  // with a margin (ORB keeps none within its patch of a border) and keeps
  // the keypoints of its own cells.
  constexpr int kCols = 4, kRows = 3, kMargin = 40;
  const int per_tile = std::max(50, options.detect_features / (kCols * kRows));
  std::vector<cv::Mat> parts;
  for (int r = 0; r < kRows; ++r) {
    for (int c = 0; c < kCols; ++c) {
      const cv::Rect cell(c * gray.cols / kCols, r * gray.rows / kRows, (c + 1) * gray.cols / kCols - c * gray.cols / kCols,
                          (r + 1) * gray.rows / kRows - r * gray.rows / kRows);
      const cv::Rect tile = (cell + cv::Size(2 * kMargin, 2 * kMargin) - cv::Point(kMargin, kMargin)) &
                            cv::Rect(0, 0, gray.cols, gray.rows);
      std::vector<cv::KeyPoint> kps;
      cv::Mat desc;
      orb(per_tile)->detectAndCompute(gray(tile), cv::noArray(), kps, desc);
      for (int i = 0; i < static_cast<int>(kps.size()); ++i) {
        kps[i].pt += cv::Point2f(tile.tl());
        if (!cell.contains(cv::Point(kps[i].pt))) continue;
        f.keypoints.push_back(kps[i]);
        parts.push_back(desc.row(i));
      }
    }
  }
  if (!parts.empty()) cv::vconcat(parts, f.descriptors);
  return f;
}

bool ImageTargetDetector::align(const cv::Mat& gray, const cv::Mat& H, Detection* d) const {
  // The picture at about its size on screen (no finer: ECC would chase
  // detail the frame does not have), mapped by H scaled to it.
  const double on_screen = std::sqrt(std::abs(planar_detail::quadArea(d->corners)));
  const double s = std::min(1.0, on_screen / std::sqrt(double(picture_.cols) * picture_.rows));
  if (!(s > 0)) return false;
  cv::Mat templ;
  cv::resize(picture_, templ, cv::Size(), s, s, cv::INTER_AREA);
  if (templ.cols < 16 || templ.rows < 16) return false;
  cv::Mat warp;
  cv::Mat(H * cv::Mat(cv::Matx33d(1 / s, 0, 0, 0, 1 / s, 0, 0, 0, 1))).convertTo(warp, CV_32F);
  double cc = 0;
  try {
    cc = cv::findTransformECC(templ, gray, warp, cv::MOTION_HOMOGRAPHY,
                              cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-5),
                              cv::noArray(), 5);
  } catch (const cv::Exception&) {
    return false;  // did not converge: no alignment
  }
  d->correlation = cc;
  if (!(cc >= options_.detect_min_correlation)) return false;
  cv::Mat Hd;
  cv::Mat(warp * cv::Mat(cv::Matx33f(float(s), 0, 0, 0, float(s), 0, 0, 0, 1))).convertTo(Hd, CV_64F);
  d->corners = cornersBy(Hd);
  return true;
}

std::array<cv::Point2d, 4> ImageTargetDetector::cornersBy(const cv::Mat& H) const {
  const double w = picture_.cols, h = picture_.rows;
  std::vector<cv::Point2d> to;
  cv::perspectiveTransform(std::vector<cv::Point2d>{{0, 0}, {w, 0}, {w, h}, {0, h}}, to, H);
  return {to[0], to[1], to[2], to[3]};
}

cv::Mat ImageTargetDetector::readPicture(const std::string& path, std::string* error) {
  cv::Mat picture = cv::imread(path, cv::IMREAD_GRAYSCALE);
  if (picture.empty()) *error = "cannot read image '" + path + "'";
  return picture;
}

bool ImageTargetDetector::detect(const Frame& frame, Detection* found) const {
  if (frame.descriptors.empty() || frame.keypoints.size() < 4) return false;
  // Each frame keypoint's two nearest picture keypoints (brute force: FLANN's
  // LSH index was faster but let a false match through on POT V24_7).
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(cv::NORM_HAMMING).knnMatch(frame.descriptors, descriptors_, knn, 2);
  std::vector<cv::Point2f> from, to;
  for (const auto& m : knn) {
    if (m.size() < 2 || m[0].distance >= options_.detect_ratio * m[1].distance) continue;
    from.push_back(keypoints_[m[0].trainIdx].pt);
    to.push_back(frame.keypoints[m[0].queryIdx].pt);
  }
  Detection d;
  d.matches = static_cast<int>(from.size());
  if (d.matches < options_.detect_min_inliers) return false;
  std::vector<uchar> inlier;
  const cv::Mat H =
      cv::findHomography(from, to, cv::RANSAC, options_.detect_ransac_error, inlier, 2000, 0.995);
  if (H.empty()) return false;
  d.inliers = static_cast<int>(std::count(inlier.begin(), inlier.end(), 1));
  if (d.inliers < options_.detect_min_inliers) return false;
  d.corners = cornersBy(H);
  if (!usableQuad(d.corners, frame.gray.size())) return false;
  // The keypoints propose, the picture's look decides: the homography is
  // aligned with the frame (ECC), which also takes the corners from the
  // keypoints' pixel or so to a fraction of one.
  const bool aligned = align(frame.gray, H, &d);
  if (!aligned || !usableQuad(d.corners, frame.gray.size())) return false;
  *found = d;
  return true;
}

}  // namespace imt
