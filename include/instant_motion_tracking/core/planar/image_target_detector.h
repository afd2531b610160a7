// Finds a planar target in a frame from its reference picture (image
// targets, interface spec "image_targets"): ORB keypoints of the picture
// matched to the frame's (Lowe's ratio test), a homography by RANSAC over
// the matches, then the picture itself aligned with the frame from there
// (OpenCV's ECC): found when enough matches agree, the aligned picture
// correlates with the frame, and its corners make a usable quad (convex,
// clockwise, not tiny, partly in view).
// The corners it gives start a PlanarTargetTracker, which tracks from there.
//
// A frame's keypoints are described once (describeFrame) and matched against
// every target's picture.
//
// Usage:
//   std::string err;
//   auto d = imt::ImageTargetDetector::create(picture, options, &err);
//   const imt::ImageTargetDetector::Frame f = imt::ImageTargetDetector::describeFrame(gray, options);
//   imt::ImageTargetDetector::Detection found;
//   if (d->detect(f, &found)) start a tracker at found.corners;
// Threading: detect() is const and may run concurrently on one detector.
#pragma once

#include "instant_motion_tracking/core/planar/planar_target_options.h"

#include <opencv2/core.hpp>

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace imt {

class ImageTargetDetector {
 public:
  // A frame (CV_8UC1), its keypoints and their ORB descriptors.
  struct Frame {
    cv::Mat gray;
    std::vector<cv::KeyPoint> keypoints;
    cv::Mat descriptors;
  };
  struct Detection {
    std::array<cv::Point2d, 4> corners;  // the picture's TL, TR, BR, BL in the frame (px)
    int matches = 0;                     // ratio-test matches
    int inliers = 0;                     // of them, consistent with the homography
    double correlation = 0;              // ECC correlation of the picture aligned with the frame
  };

  // The picture: CV_8UC1 or CV_8UC3 (BGR), at least 32 px on each side, with
  // enough texture for options.detect_min_inliers keypoints. nullptr and
  // *error (why) otherwise.
  static std::unique_ptr<ImageTargetDetector> create(const cv::Mat& picture, const PlanarTargetOptions& options,
                                                     std::string* error);
  static Frame describeFrame(const cv::Mat& gray, const PlanarTargetOptions& options);
  // A picture file, gray; empty and *error ("cannot read image '<path>'")
  // when it cannot be read as an image.
  static cv::Mat readPicture(const std::string& path, std::string* error);

  // True with the picture's corners in the frame when it is found there.
  bool detect(const Frame& frame, Detection* found) const;
  const cv::Mat& picture() const { return picture_; }  // CV_8UC1

 private:
  ImageTargetDetector() = default;
  // Aligns the picture mapped by H (picture px -> frame px) with the frame;
  // true with d->corners from the aligned map when it correlates well.
  bool align(const cv::Mat& gray, const cv::Mat& H, Detection* d) const;
  // The picture's corners mapped by H (picture px -> frame px).
  std::array<cv::Point2d, 4> cornersBy(const cv::Mat& H) const;
  PlanarTargetOptions options_;
  cv::Mat picture_;                       // gray, as given
  std::vector<cv::KeyPoint> keypoints_;   // in picture px
  cv::Mat descriptors_;
};

}  // namespace imt
