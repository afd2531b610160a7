// Placeholder motion analysis for the foundation: input checks and resets
// only; every frame reports `invalid`. The feature tracking and camera motion
// estimation arrive with the motion-analysis issue.
#include "instant_motion_tracking/core/motion_analysis.h"

namespace imt {

struct MotionAnalyzer::Impl {
  MotionAnalysisOptions options;
  cv::Size size;
  double last_stamp = 0;
  bool has_frame = false;
  std::string last_reset;
};

MotionAnalyzer::MotionAnalyzer(const MotionAnalysisOptions& options) : impl_(new Impl) {
  impl_->options = options;
}
MotionAnalyzer::~MotionAnalyzer() = default;
MotionAnalyzer::MotionAnalyzer(MotionAnalyzer&&) noexcept = default;
MotionAnalyzer& MotionAnalyzer::operator=(MotionAnalyzer&&) noexcept = default;

void MotionAnalyzer::reset() { impl_->has_frame = false; }
const std::string& MotionAnalyzer::lastReset() const { return impl_->last_reset; }
const MotionAnalysisOptions& MotionAnalyzer::options() const { return impl_->options; }

MotionData MotionAnalyzer::process(const cv::Mat& gray, double stamp) {
  Impl& s = *impl_;
  s.last_reset.clear();
  if (s.has_frame && gray.size() != s.size) {
    s.last_reset = "frame size changed";
    s.has_frame = false;
  } else if (s.has_frame && !(stamp > s.last_stamp)) {
    s.last_reset = "stamp did not increase";
    s.has_frame = false;
  }
  MotionData md;
  md.stamp = stamp;
  md.width = gray.cols;
  md.height = gray.rows;
  s.size = gray.size();
  s.last_stamp = stamp;
  s.has_frame = true;
  return md;
}

}  // namespace imt
