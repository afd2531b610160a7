#include "instant_motion_tracking/core/motion_cache.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace imt {
namespace {

std::string fmtStamp(double s) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.6f", s);
  return buf;
}

}  // namespace

void MotionCache::clear() {
  first_seq_ += frames_.size();  // sequence numbers never repeat
  frames_.clear();
  images_.clear();
  image_bytes_ = 0;
  oldest_image_ = 0;
}

cv::Mat MotionCache::image(uint64_t seq) const {
  if (frames_.empty() || seq < first_seq_ || seq > lastSeq()) return cv::Mat();  // not cached
  const cv::Mat& kept = images_[seq - first_seq_];
  if (!kept.empty() || !image_source_) return kept;
  cv::Mat im = image_source_(frames_[seq - first_seq_].stamp);
  if (im.type() != CV_8UC1 || im.size() != size_) return cv::Mat();
  return im;
}

void MotionCache::setImageBudget(size_t bytes) {
  image_budget_ = bytes;
  trimImages();
}

void MotionCache::trimImages() {
  while (image_bytes_ > image_budget_ && oldest_image_ < images_.size()) {
    cv::Mat& im = images_[oldest_image_++];
    image_bytes_ -= im.total() * im.elemSize();
    im.release();
  }
}

bool MotionCache::push(const MotionData& md, std::string* reset_reason, const cv::Mat& image) {
  bool ok = true;
  const cv::Size size(md.width, md.height);
  if (!frames_.empty() && !(md.stamp > frames_.back().stamp)) {
    *reset_reason = "stamp " + fmtStamp(md.stamp) + " does not follow " + fmtStamp(frames_.back().stamp) +
                    " (time went backwards): cache cleared";
    clear();
    ok = false;
  } else if (!frames_.empty() && size != size_) {
    *reset_reason = "image size changed: cache cleared";
    clear();
    ok = false;
  }
  size_ = size;
  frames_.push_back(md);
  if (!frames_.back().sorted_by_x) frames_.back().sortByX();
  const size_t bytes = image.total() * image.elemSize();
  if (!image.empty() && image.type() == CV_8UC1 && bytes <= image_budget_) {
    images_.push_back(image);
    image_bytes_ += bytes;
  } else {
    images_.emplace_back();
  }
  if (seconds_ > 0) {
    while (frames_.size() > 1 && frames_.back().stamp - frames_.front().stamp > seconds_) {
      frames_.pop_front();
      image_bytes_ -= images_.front().total() * images_.front().elemSize();
      images_.pop_front();
      if (oldest_image_ > 0) --oldest_image_;
      ++first_seq_;
    }
  }
  trimImages();
  return ok;
}

bool MotionCache::find(double stamp, uint64_t* seq, std::string* error) const {
  if (frames_.empty()) {
    *error = "no motion data received yet";
    return false;
  }
  if (stamp == 0) {
    *seq = lastSeq();
    return true;
  }
  if (!std::isfinite(stamp)) {
    *error = "stamp is not a finite number";
    return false;
  }
  const auto it = std::lower_bound(frames_.begin(), frames_.end(), stamp,
                                   [](const MotionData& m, double s) { return m.stamp < s; });
  size_t best = 0;
  double best_d = 1e300;
  for (auto c : {it - 1, it}) {
    if (c < frames_.begin() || c >= frames_.end()) continue;
    const double d = std::abs(c->stamp - stamp);
    if (d < best_d) {
      best_d = d;
      best = static_cast<size_t>(c - frames_.begin());
    }
  }
  // Half the mean frame interval around the nearest frame (one frame: exact only).
  const double interval =
      frames_.size() > 1 ? (frames_.back().stamp - frames_.front().stamp) / (frames_.size() - 1) : 0;
  if (best_d > 0.5 * interval + 1e-6) {
    if (stamp >= frames_.front().stamp && stamp <= frames_.back().stamp) {
      *error = "stamp " + fmtStamp(stamp) + " is not within half a frame of any cached frame";
    } else {
      *error = "stamp " + fmtStamp(stamp) + " is outside the motion-data cache (" +
               fmtStamp(frames_.front().stamp) + " .. " + fmtStamp(frames_.back().stamp) + ")";
    }
    return false;
  }
  *seq = first_seq_ + best;
  return true;
}

bool MotionCache::cameraMotion(uint64_t from, uint64_t to, Eigen::Matrix3d* H) const {
  const MotionData& later = at(std::max(from, to));
  const bool valid = later.camera.model != MotionModel::kInvalid && later.camera.H.allFinite();
  const Eigen::Matrix3d fwd = valid ? later.camera.H : Eigen::Matrix3d::Identity();
  *H = to > from ? fwd : Eigen::Matrix3d(fwd.inverse());
  return valid;
}

}  // namespace imt
