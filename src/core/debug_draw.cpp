#include "instant_motion_tracking/core/debug_draw.h"

#include <opencv2/imgproc.hpp>

#include <cstdio>

namespace imt {

cv::Mat drawMotionData(const cv::Mat& gray, const MotionData& md, double vector_scale) {
  cv::Mat out;
  if (gray.empty()) return out;
  cv::cvtColor(gray, out, cv::COLOR_GRAY2BGR);
  const cv::Scalar kBackground(60, 200, 60), kForeground(40, 40, 230);
  for (const FeatureMotion& f : md.features) {
    // Our pixel convention has centres at +0.5; OpenCV drawing at integers.
    const cv::Point2d p(f.x - 0.5, f.y - 0.5);
    const cv::Scalar colour = f.foreground ? kForeground : kBackground;
    cv::circle(out, p, 2, colour, cv::FILLED, cv::LINE_AA);
    if (f.foreground) {
      const cv::Point2d tail(p.x - vector_scale * f.dx, p.y - vector_scale * f.dy);
      cv::line(out, tail, p, colour, 1, cv::LINE_AA);
    }
  }
  char text[128];
  std::snprintf(text, sizeof(text), "%s  features %d  inliers %d", motionModelName(md.camera.model),
                md.camera.features, md.camera.inliers);
  cv::putText(out, text, cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 3,
              cv::LINE_AA);
  cv::putText(out, text, cv::Point(8, 20), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(255, 255, 255), 1,
              cv::LINE_AA);
  return out;
}

}  // namespace imt
