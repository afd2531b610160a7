// AreaResize against OpenCV's area resize (cv::INTER_AREA), which it stands
// in for in the motion analysis (what is left after the halvings) and the
// region's look (its windows).
#include "../../src/core/area_resize.h"
#include "test_motion_analysis_synthetic.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cstdio>

namespace imt {
namespace {

// The largest difference from OpenCV's, in gray levels, and how many pixels differ.
struct Diff {
  double max = 0;
  int pixels = 0;
};
Diff against(const cv::Mat& src, cv::Size size) {
  cv::Mat ours, theirs;
  AreaResize r;
  EXPECT_TRUE(r.apply(src, size, &ours));
  cv::resize(src, theirs, size, 0, 0, cv::INTER_AREA);
  EXPECT_EQ(ours.size(), size);
  EXPECT_EQ(ours.type(), CV_8UC1);
  if (ours.size() != theirs.size() || ours.type() != theirs.type()) return {255, static_cast<int>(size.area())};
  cv::Mat d;
  cv::absdiff(ours, theirs, d);
  Diff out;
  cv::minMaxLoc(d, nullptr, &out.max);
  out.pixels = cv::countNonZero(d);
  return out;
}

// The factors the motion analysis meets after its halvings (under 2: 480 ->
// 320, 800 -> 400 -> 320, 1920 -> 480 -> 320), larger ones (odd sizes are not
// halved), odd and one-pixel outputs, a factor of 1 on one axis, a window
// into a larger image, and what it leaves to OpenCV. The same products added
// in the same order as OpenCV's: equal bit for bit (measured here, GCC 12 on
// x86-64: no pixel differs on any of these). One level at one pixel in
// 10,000 is allowed for a build that fuses the multiply-adds (rounding once,
// not twice).
TEST(AreaResize, EqualsOpenCvsAreaResize) {
  const cv::Mat big = synthetic::texture(2000, 1200, 7);
  const struct {
    cv::Size from, to;
  } cases[] = {{{480, 640}, {320, 427}}, {{400, 300}, {320, 240}}, {{480, 270}, {320, 180}},
               {{1001, 37}, {320, 12}},  {{301, 173}, {100, 57}},  {{333, 333}, {1, 1}},
               {{640, 480}, {640, 317}}, {{97, 61}, {96, 60}},     {{1990, 1190}, {320, 191}},
               // OpenCV's own: whole factors, a side enlarged.
               {{960, 543}, {320, 181}}, {{99, 66}, {33, 22}},     {{100, 50}, {80, 60}}};
  int total = 0, differing = 0;
  for (const auto& c : cases) {
    const cv::Mat src = big(cv::Rect(3, 5, c.from.width, c.from.height));  // a window: rows not contiguous
    const Diff d = against(src, c.to);
    std::printf("%dx%d -> %dx%d: at most %.0f level(s), %d pixel(s) differ\n", c.from.width, c.from.height,
                c.to.width, c.to.height, d.max, d.pixels);
    EXPECT_LE(d.max, 1) << c.from << " -> " << c.to;
    total += c.to.area();
    differing += d.pixels;
  }
  EXPECT_LE(differing, total / 10000);
}

// One resizer and one output, as the looks use theirs: sizes in turn,
// larger and smaller (its tables, its work images and its block of rows
// made anew or reused), and an output that was another size or shared.
TEST(AreaResize, OneResizerAcrossSizesEqualsOpenCvs) {
  const cv::Mat big = synthetic::texture(800, 700, 11);
  const cv::Size sizes[][2] = {{{480, 640}, {320, 427}}, {{301, 173}, {100, 57}}, {{97, 61}, {96, 7}},
                               {{480, 640}, {320, 427}}, {{640, 480}, {320, 241}}, {{333, 250}, {101, 77}}};
  AreaResize r;
  cv::Mat ours = cv::Mat(5, 5, CV_8UC1, cv::Scalar(1)), shared = ours;
  for (const auto& s : sizes) {
    const cv::Mat src = big(cv::Rect(cv::Point(7, 2), s[0]));
    cv::Mat theirs;
    ASSERT_TRUE(r.apply(src, s[1], &ours));
    cv::resize(src, theirs, s[1], 0, 0, cv::INTER_AREA);
    ASSERT_EQ(ours.size(), theirs.size());
    // As EqualsOpenCvsAreaResize: bit for bit here, a level for a build that fuses multiply-adds.
    EXPECT_LE(cv::norm(ours, theirs, cv::NORM_INF), 1) << s[0] << " -> " << s[1];
  }
  EXPECT_EQ(shared.size(), cv::Size(5, 5));  // the first output's pixels were not written over
  EXPECT_EQ(cv::countNonZero(shared != 1), 0);
}

TEST(AreaResize, OtherPixelTypesAreOpenCvs) {
  const cv::Mat gray = synthetic::texture(90, 70, 3);
  cv::Mat colour, real;
  cv::cvtColor(gray, colour, cv::COLOR_GRAY2BGR);
  gray.convertTo(real, CV_32F, 1 / 255.0);
  for (const cv::Mat& src : {colour, real}) {
    cv::Mat ours, theirs;
    AreaResize r;
    ASSERT_TRUE(r.apply(src, cv::Size(60, 47), &ours));
    cv::resize(src, theirs, cv::Size(60, 47), 0, 0, cv::INTER_AREA);
    ASSERT_EQ(ours.type(), theirs.type());
    EXPECT_EQ(cv::norm(ours, theirs, cv::NORM_INF), 0);
  }
}

TEST(AreaResize, RefusesWhatItCannotDo) {
  AreaResize r;
  cv::Mat out(4, 4, CV_8UC1);
  const cv::Mat gray(40, 30, CV_8UC1, cv::Scalar(9));
  EXPECT_FALSE(r.apply(cv::Mat(), cv::Size(10, 10), &out));
  EXPECT_TRUE(out.empty());
  out.create(4, 4, CV_8UC1);
  EXPECT_FALSE(r.apply(gray, cv::Size(0, 10), &out));
  EXPECT_TRUE(out.empty());
  EXPECT_FALSE(r.apply(gray, cv::Size(10, -1), &out));
  // And works again after, with tables made for new sizes.
  ASSERT_TRUE(r.apply(gray, cv::Size(20, 27), &out));
  EXPECT_EQ(out.size(), cv::Size(20, 27));
  EXPECT_EQ(cv::countNonZero(out != 9), 0);
}

}  // namespace
}  // namespace imt
