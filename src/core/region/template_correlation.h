// The normalised correlation a region's look is matched by, internal to the
// region tracker (see template_correlation.cpp).
#pragma once

#include <opencv2/core.hpp>

namespace imt {

// cv::matchTemplate(window, templ, *response, cv::TM_CCOEFF_NORMED), both
// CV_32F; computed shift by shift where that costs less. Empty when the
// window is smaller than the template.
void correlateNormed(const cv::Mat& window, const cv::Mat& templ, cv::Mat* response);

}  // namespace imt
