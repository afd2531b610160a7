// A bounded ring buffer of motion data, addressed by a frame sequence number
// that keeps increasing while frames arrive (so positions stay valid as old
// frames are dropped). The trackers' random access (items added in the past,
// tracked backwards and forwards, seek) works on it. Optionally it also keeps
// each frame's gray image, within a memory budget (the planar targets align
// their appearance with them); the oldest images go first.
//
// Usage:
//   imt::MotionCache cache(10.0);           // seconds kept; <= 0 keeps everything
//   std::string reset;
//   if (!cache.push(md, &reset)) log(reset);  // cleared first: time went back or the size changed
//   uint64_t seq;
//   if (cache.find(stamp, &seq, &error)) use(cache.at(seq));
// Threading: not thread-safe.
#pragma once

#include "instant_motion_tracking/core/types.h"

#include <opencv2/core.hpp>

#include <deque>
#include <functional>
#include <string>

namespace imt {

class MotionCache {
 public:
  explicit MotionCache(double seconds) : seconds_(seconds) {}

  // Appends `md` (its features sorted by x, see MotionData::sortByX). When its
  // stamp does not increase or the image size changes, the cache is cleared
  // first and false is returned with the reason; `md` is still added.
  // `image` (optional, CV_8UC1) is kept while the image budget allows.
  bool push(const MotionData& md, std::string* reset_reason, const cv::Mat& image = cv::Mat());
  void clear();

  bool empty() const { return frames_.empty(); }
  size_t size() const { return frames_.size(); }
  uint64_t firstSeq() const { return first_seq_; }
  uint64_t lastSeq() const { return first_seq_ + frames_.size() - 1; }  // only when !empty()
  const MotionData& at(uint64_t seq) const { return frames_[seq - first_seq_]; }
  // The gray image of frame `seq`: the one kept with it, else the image
  // source's (setImageSource), else empty (none was given, or it was dropped
  // to stay within the budget).
  cv::Mat image(uint64_t seq) const;
  // Where images the cache did not keep are found (offline: read again from
  // the bag): called with the frame's stamp; returns an empty Mat when it
  // has none. An image of another size than the frames' is not used.
  using ImageSource = std::function<cv::Mat(double stamp)>;
  void setImageSource(ImageSource source) { image_source_ = std::move(source); }
  // Bytes of images kept at most (0, the default: none).
  void setImageBudget(size_t bytes);
  size_t imageBytes() const { return image_bytes_; }
  cv::Size imageSize() const { return size_; }
  double oldestStamp() const { return frames_.empty() ? 0 : frames_.front().stamp; }
  double newestStamp() const { return frames_.empty() ? 0 : frames_.back().stamp; }

  // The frame nearest `stamp` (0 = the latest frame) within half the mean
  // frame interval. False with a message naming the stamp and the cached
  // span otherwise.
  bool find(double stamp, uint64_t* seq, std::string* error) const;

  // Background motion from frame `from` to the adjacent frame `to`
  // (to = from +- 1), and whether it is valid.
  bool cameraMotion(uint64_t from, uint64_t to, Eigen::Matrix3d* H) const;

 private:
  double seconds_;
  void trimImages();

  std::deque<MotionData> frames_;
  std::deque<cv::Mat> images_;  // parallel to frames_
  size_t image_budget_ = 0, image_bytes_ = 0;
  size_t oldest_image_ = 0;  // index into images_ below which all are empty
  uint64_t first_seq_ = 0;
  cv::Size size_;
  ImageSource image_source_;
};

}  // namespace imt
