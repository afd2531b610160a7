// A region's own features (private to the region tracker): corners found
// inside its box and tracked between two frames with OpenCV's pyramidal
// Lucas-Kanade on crops around the box, at a resolution that fits the box
// (full resolution for small boxes, downscaled so the box's longer side is
// about `scale_px` px for large ones; with many regions at full resolution,
// the whole frame's pyramid shared by them all), checked forward-backward. They make
// sure a region has motion vectors of its own however small it is and
// whatever the motion analysis's uniform grid gave it, and they work the same
// in both time directions, on any cached frame.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace imt {

struct OwnFeature {
  uint32_t id = 0;
  cv::Point2f from, to;  // full-resolution px in the two frames
};

// Tracks `points` (full-resolution px in `from`) into `to` (both CV_8UC1, the
// same size). The guess for each is `H` (from -> to pixels) applied to it,
// shifted by `shift`. Only the survivors of the forward-backward check are
// returned. `from_pyramid` and `to_pyramid` (ownFeaturePyramid() of the two
// frames), when given, are used in place of crops for a box tracked at full
// resolution.
std::vector<OwnFeature> trackOwnFeatures(const cv::Mat& from, const cv::Mat& to,
                                         const std::vector<cv::Point2f>& points,
                                         const std::vector<uint32_t>& ids, const cv::Rect2d& box,
                                         const Eigen::Matrix3d& H, const Eigen::Vector2d& shift, int scale_px,
                                         const std::vector<cv::Mat>* from_pyramid = nullptr,
                                         const std::vector<cv::Mat>* to_pyramid = nullptr);

// Whether a box's own features are tracked at full resolution (else on a
// downscaled crop).
bool ownFeaturesAtFullResolution(const cv::Rect2d& box, int scale_px);

// The whole frame's pyramid for trackOwnFeatures() (its window and levels,
// with derivatives), to share among many regions.
std::vector<cv::Mat> ownFeaturePyramid(const cv::Mat& image);

// The pixels of the crops a region with own features at `box` builds
// pyramids of per frame (two: the frames it steps between); 0 for a large
// box (downscaled crops, which a whole-frame pyramid cannot serve).
double ownCropPixels(const cv::Rect2d& box, int scale_px);
// Whether whole-frame pyramids (one new per frame, the previous frame's
// reused) cost less than crops of `crop_pixels` (ownCropPixels() summed over
// the regions) in a `frame`-sized image.
bool wholeFramePyramidsPay(double crop_pixels, cv::Size frame);

// Up to `count` new corners inside `box` of `image`, at least a few crop px
// from each other and from `existing`; full-resolution px.
std::vector<cv::Point2f> detectOwnFeatures(const cv::Mat& image, const cv::Rect2d& box, int count,
                                           const std::vector<cv::Point2f>& existing, int scale_px);

}  // namespace imt
