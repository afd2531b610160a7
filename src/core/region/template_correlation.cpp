#include "template_correlation.h"

#include <Eigen/Core>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cfloat>
#include <cmath>

namespace imt {

// cv::matchTemplate(window, templ, response, TM_CCOEFF_NORMED) for both
// CV_32F. A search close around a place (the look's turn and shape tries, a
// score at one place, the refinement of a coarse find) is computed shift by
// shift: a dot product per shift, row by row in float, the window's sums from
// integral images. OpenCV correlates through DFTs, whose set-up dominates
// there. OpenCV 4.6, one core, a 40 x 33 template, OpenCV's against shift by
// shift: 1 shift 33 / 4 us, 5 x 5 51 / 8 us, 14 x 12 58 / 34 us, 20 x 20
// 75 / 77 us, 28 x 23 96 / 120 us; a 12 x 10 template, 60 x 45 shifts
// 101 / 91 us. Shift by shift up to kDirectProducts multiplications, where
// it costs no more. The same coefficient either way, to float rounding (4e-6
// apart), and the same answers where the window or the template is flat.
void correlateNormed(const cv::Mat& window, const cv::Mat& templ, cv::Mat* response) {
  constexpr double kDirectProducts = 350e3;
  const cv::Size shifts(window.cols - templ.cols + 1, window.rows - templ.rows + 1);
  if (shifts.width < 1 || shifts.height < 1 || templ.empty()) {  // no place to put the template
    response->release();
    return;
  }
  const double n = static_cast<double>(templ.total());
  if (shifts.area() * n > kDirectProducts) {
    cv::matchTemplate(window, templ, *response, cv::TM_CCOEFF_NORMED);
    return;
  }
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
  using Row = Eigen::Map<const Eigen::VectorXf>;
  const auto box = [&](const cv::Mat& s, int x, int y) {
    return s.at<double>(y + templ.rows, x + templ.cols) - s.at<double>(y, x + templ.cols) -
           s.at<double>(y + templ.rows, x) + s.at<double>(y, x);
  };
  for (int y = 0; y < shifts.height; ++y) {
    for (int x = 0; x < shifts.width; ++x) {
      const double s = box(sum, x, y);
      const double t = std::sqrt(std::max(0.0, box(sqsum, x, y) - s * s / n)) * templ_norm;
      double num = 0;
      for (int r = 0; r < templ.rows; ++r)
        num += Row(window.ptr<float>(y + r) + x, templ.cols).dot(Row(centred.ptr<float>(r), templ.cols));
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
