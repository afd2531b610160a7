// Debug overlays for the `debug_image` topics and the demo: features coloured
// by foreground (red) / background (green) with their motion vectors, and the
// camera model's name. Pure OpenCV; pixel coordinates as in docs/conventions.md.
#pragma once

#include "instant_motion_tracking/core/types.h"

namespace imt {

// Returns a BGR copy of `gray` (CV_8UC1) with the motion data drawn on it.
// Vectors are drawn `vector_scale` times their length (they are small).
cv::Mat drawMotionData(const cv::Mat& gray, const MotionData& md, double vector_scale = 3.0);

}  // namespace imt
