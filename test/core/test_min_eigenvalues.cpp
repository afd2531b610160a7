// MinEigenvalues against OpenCV's cv::cornerMinEigenVal(gray(area), out, 3,
// 3), which it stands in for in the feature tracker's corner detection.
#include "../../src/core/motion/min_eigenvalues.h"
#include "shared_data.h"
#include "test_motion_analysis_synthetic.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>

namespace imt {
namespace {

// The largest difference from OpenCV's map over `area`, relative to the
// largest eigenvalue there (1 where the sizes or types differ). The smaller
// eigenvalue is a difference, (a + c) - sqrt((a - c)^2 + b^2), so its float
// rounding is of the order of the larger one's: near an edge, or in a flat
// cell beside one, its relative error can be large without mattering.
double against(const cv::Mat& gray, const cv::Rect& area) {
  cv::Mat ours, theirs, both;
  MinEigenvalues eig;
  EXPECT_TRUE(eig.apply(gray, area, &ours)) << area;
  cv::cornerMinEigenVal(gray(area), theirs, 3, 3);
  if (ours.size() != theirs.size() || ours.type() != theirs.type()) return 1;
  cv::cornerEigenValsAndVecs(gray(area), both, 3, 3);
  cv::Mat larger;
  cv::extractChannel(both, larger, 0);
  double scale = 0, diff = 0;
  cv::minMaxLoc(larger, nullptr, &scale);
  cv::minMaxLoc(cv::abs(ours - theirs), nullptr, &diff);
  return scale > 0 ? diff / scale : diff;
}

// The areas the feature tracker asks for (a grid cell with a pixel of
// context, inside the frame or at its edges and corners), the whole frame,
// thin and one-pixel areas, and a 2-row frame. The integer sums are exact;
// only OpenCV's float Sobel and sums round differently: measured at most
// 1.5e-7 of the largest eigenvalue (GCC 12, x86-64; printed below). 1e-6
// leaves room for a build that fuses multiply-adds; a pixel read from the
// wrong side of a border is off by the order of the values themselves.
constexpr double kRelativeTolerance = 1e-6;

TEST(MinEigenvalues, EqualsOpenCvsOnSyntheticFrames) {
  const cv::Mat frame = synthetic::texture(320, 240, 11);
  const cv::Rect areas[] = {{39, 39, 42, 42}, {0, 0, 41, 41},   {279, 199, 41, 41},
                            {0, 100, 41, 42}, {279, 0, 41, 41}, {0, 0, 320, 240},
                            {100, 50, 1, 30}, {100, 50, 30, 1}, {5, 5, 1, 1},
                            {319, 239, 1, 1}, {0, 0, 2, 2},     {150, 1, 17, 238}};
  for (const cv::Rect& a : areas) {
    const double e = against(frame, a);
    std::printf("%dx%d at (%d, %d): %.2g of the largest eigenvalue\n", a.width, a.height, a.x, a.y,
                e);
    EXPECT_LE(e, kRelativeTolerance) << a;
  }
  const cv::Mat two_rows = synthetic::texture(50, 2, 5);
  EXPECT_LE(against(two_rows, cv::Rect(0, 0, 50, 2)), kRelativeTolerance);
  EXPECT_LE(against(two_rows, cv::Rect(10, 1, 20, 1)), kRelativeTolerance);
  // A window into a larger image: rows not contiguous.
  const cv::Mat big = synthetic::texture(700, 500, 3);
  EXPECT_LE(against(big(cv::Rect(13, 7, 320, 240)), cv::Rect(200, 100, 44, 44)),
            kRelativeTolerance);
}

// Every cell of real frames, where flat sky and road sit beside edges.
TEST(MinEigenvalues, EqualsOpenCvsOnRealFrames) {
  const std::string dir = test::sharedDataDir() + "/vot2015_car1/img/";
  if (!test::pathExists(dir)) GTEST_SKIP() << "no " << dir;
  double worst = 0;
  for (const char* name : {"00000001.jpg", "00000120.jpg", "00000250.jpg"}) {
    cv::Mat gray = cv::imread(dir + name, cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(gray.empty()) << name;
    cv::resize(gray, gray, cv::Size(320, gray.rows * 320 / gray.cols), 0, 0, cv::INTER_AREA);
    for (int y = 0; y + 42 <= gray.rows; y += 40)
      for (int x = 0; x + 42 <= gray.cols; x += 40)
        worst = std::max(worst, against(gray, cv::Rect(x, y, 42, 42)));
  }
  std::printf("car1, every cell of 3 frames: at most %.2g of a cell's largest eigenvalue\n", worst);
  EXPECT_LE(worst, kRelativeTolerance);
}

TEST(MinEigenvalues, RefusesWhatItCannotDo) {
  MinEigenvalues eig;
  const cv::Mat gray(40, 30, CV_8UC1, cv::Scalar(9));
  cv::Mat out(3, 3, CV_32F, cv::Scalar(7));
  EXPECT_FALSE(eig.apply(cv::Mat(), cv::Rect(0, 0, 5, 5), &out));
  EXPECT_FALSE(eig.apply(gray, cv::Rect(0, 0, 0, 5), &out));
  EXPECT_FALSE(eig.apply(gray, cv::Rect(-1, 0, 5, 5), &out));
  EXPECT_FALSE(eig.apply(gray, cv::Rect(26, 0, 5, 5), &out));
  cv::Mat colour;
  cv::cvtColor(gray, colour, cv::COLOR_GRAY2BGR);
  EXPECT_FALSE(eig.apply(colour, cv::Rect(0, 0, 5, 5), &out));
  EXPECT_EQ(out.size(), cv::Size(3, 3));  // untouched
  // And works after: a flat frame has no corners.
  ASSERT_TRUE(eig.apply(gray, cv::Rect(2, 3, 20, 30), &out));
  EXPECT_EQ(out.size(), cv::Size(20, 30));
  EXPECT_EQ(cv::countNonZero(out != 0), 0);
}

}  // namespace
}  // namespace imt
