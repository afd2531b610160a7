#include "template_correlation.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace imt {

// cv::matchTemplate(window, templ, response, TM_CCOEFF_NORMED) for both
// CV_32F. A search close around a place (a few shifts either way: the look's
// turn and shape tries, a score at one place) is computed shift by shift:
// OpenCV correlates through DFTs, whose set-up dominates there (OpenCV 4.6,
// one core, a 40 x 33 template: 53 us for one shift, 71 us for 5 x 5, against
// 6 and 24 us). Beyond kDirectShifts shifts the DFTs are cheaper. The same
// coefficient either way, to float rounding (2e-7 apart), and the same
// answers where the window or the template is flat.
void correlateNormed(const cv::Mat& window, const cv::Mat& templ, cv::Mat* response) {
  constexpr int kDirectShifts = 40;
  const cv::Size shifts(window.cols - templ.cols + 1, window.rows - templ.rows + 1);
  if (shifts.width < 1 || shifts.height < 1 || templ.empty()) {  // no place to put the template
    response->release();
    return;
  }
  if (shifts.area() > kDirectShifts) {
    cv::matchTemplate(window, templ, *response, cv::TM_CCOEFF_NORMED);
    return;
  }
  const double n = static_cast<double>(templ.total());
  cv::Mat centred;
  cv::subtract(templ, cv::mean(templ), centred);
  const double templ_norm = std::sqrt(centred.dot(centred));
  response->create(shifts, CV_32F);
  if (templ_norm < DBL_EPSILON) {  // a flat template matches anything (as OpenCV says)
    response->setTo(1);
    return;
  }
  cv::Mat sum, sqsum;
  cv::integral(window, sum, sqsum, CV_64F, CV_64F);
  const auto box = [&](const cv::Mat& s, int x, int y) {
    return s.at<double>(y + templ.rows, x + templ.cols) - s.at<double>(y, x + templ.cols) -
           s.at<double>(y + templ.rows, x) + s.at<double>(y, x);
  };
  for (int y = 0; y < shifts.height; ++y) {
    for (int x = 0; x < shifts.width; ++x) {
      const double s = box(sum, x, y);
      const double t = std::sqrt(std::max(0.0, box(sqsum, x, y) - s * s / n)) * templ_norm;
      const double num = window(cv::Rect(x, y, templ.cols, templ.rows)).dot(centred);
      // OpenCV's guard against rounding: just over the norm is a full match,
      // well over (a flat window) none.
      double r = 0;
      if (std::abs(num) < t) r = num / t;
      else if (std::abs(num) < t * 1.125) r = num > 0 ? 1 : -1;
      response->at<float>(y, x) = static_cast<float>(r);
    }
  }
}

}  // namespace imt
