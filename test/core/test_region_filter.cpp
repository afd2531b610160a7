// A region's discriminative look (region_filter.h): on a smooth random
// texture moved by known shifts, and on frames that do not hold the region.
#include "instant_motion_tracking/core/region/region_filter.h"
#include "texture_image.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <limits>
#include <vector>

namespace imt {
namespace {

const cv::Size kSize(640, 480);

cv::Mat texture(uint64_t seed) { return test::smoothTexture(kSize, seed, 2.0); }
using test::shifted;

const cv::Rect2d kBox(290, 200, 40, 70);

TEST(RegionFilter, FindsTheRegionWhereItMoved) {
  const cv::Mat frame = texture(3);
  RegionFilter f;
  ASSERT_TRUE(RegionFilter::create(frame, kBox, &f));
  for (const cv::Point2d d : {cv::Point2d(0, 0), cv::Point2d(5, -3), cv::Point2d(-11.5, 7.25), cv::Point2d(20, 16)}) {
    const FilterMatch m = f.locate(shifted(frame, d.x, d.y), kBox);
    ASSERT_TRUE(m.found);
    const double error = std::hypot(m.shift.x - d.x, m.shift.y - d.y);
    std::printf("moved (%.2f, %.2f): found (%.2f, %.2f), error %.2f px, peak %.3f, psr %.1f\n", d.x, d.y, m.shift.x,
                m.shift.y, error, m.peak, m.psr);
    // Its cells are 4 px (the window at 1:1 here); the peak's parabola
    // places it within about a quarter of a cell (measured 0.0-0.9 px).
    EXPECT_LT(error, 1.5);
    // The region tracker takes a find with a ratio of 6 or more (measured
    // 30-40 here).
    EXPECT_GT(m.psr, 12);
  }
}

TEST(RegionFilter, NoClearPeakWhereTheRegionIsNot) {
  const cv::Mat frame = texture(3);
  RegionFilter f;
  ASSERT_TRUE(RegionFilter::create(frame, kBox, &f));
  const FilterMatch at = f.locate(frame, kBox);
  for (uint64_t seed : {11u, 12u, 13u}) {
    const FilterMatch m = f.locate(texture(seed), kBox);
    ASSERT_TRUE(m.found);
    std::printf("another texture (seed %d): peak %.3f (%.3f on the region), psr %.1f (%.1f)\n",
                static_cast<int>(seed), m.peak, at.peak, m.psr, at.psr);
    // Not a sure find for the tracker: a ratio of 6 or more and a peak of
    // 0.4 of the usual or more. The ratio alone can pass (measured 4.1-6.8
    // against 21.5 on the region); the peak does not (0.23-0.33 of the
    // region's). Nor one it learns from (a ratio of 8).
    EXPECT_LT(m.peak, 0.4 * at.peak);
    EXPECT_LT(m.psr, 8);
  }
}

// The region tracker keeps a box at the size its filter last checked when
// the filter peaks higher there by kFilterSizeMargin (3%): the filter's
// peak must tell a box 1.1x off its region's size, either way, and must
// prefer the larger box when the region itself grew.
TEST(RegionFilter, PeaksHighestAtTheRegionsSize) {
  const cv::Mat frame = texture(3);
  RegionFilter f;
  ASSERT_TRUE(RegionFilter::create(frame, kBox, &f));
  const cv::Point2d c(kBox.x + kBox.width / 2, kBox.y + kBox.height / 2);
  const auto sized = [&](double k) {
    return cv::Rect2d(c.x - k * kBox.width / 2, c.y - k * kBox.height / 2, k * kBox.width, k * kBox.height);
  };
  const double at = f.locate(frame, kBox).peak;
  for (const double k : {1.1, 1 / 1.1}) {
    const double off = f.locate(frame, sized(k)).peak;
    std::printf("the box %.2fx its region's size: peak %.3f (%.3f at its size)\n", k, off, at);
    // Measured 0.78-0.80 of the peak at the region's size.
    EXPECT_GT(at, 1.03 * off);
  }
  // The region grown 1.1x about its centre.
  cv::Mat grown;
  const cv::Matx23d a(1.1, 0, c.x * (1 - 1.1), 0, 1.1, c.y * (1 - 1.1));
  cv::warpAffine(frame, grown, a, frame.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  const double kept = f.locate(grown, kBox).peak, grown_peak = f.locate(grown, sized(1.1)).peak;
  std::printf("the region grown 1.1x: peak %.3f at its new size, %.3f at its old\n", grown_peak, kept);
  EXPECT_GT(grown_peak, 1.03 * kept);
}

TEST(RegionFilter, LearningLeavesCopiesAsTheyWere) {
  const cv::Mat frame = texture(3), other = texture(21);
  RegionFilter f;
  ASSERT_TRUE(RegionFilter::create(frame, kBox, &f));
  const RegionFilter copy = f;  // an earlier frame's state keeps this
  const FilterMatch before = copy.locate(frame, kBox);
  f.learn(other, kBox, 0.5);
  const FilterMatch after = copy.locate(frame, kBox);
  EXPECT_EQ(before.peak, after.peak);
  EXPECT_EQ(before.psr, after.psr);
  // The learner itself took on half of the other texture: measured 0.44 of
  // its peak before; 0.8 tells a filter that learnt from one that did not.
  const double learnt = f.locate(frame, kBox).peak;
  std::printf("learnt half of another texture: peak %.3f of before\n", learnt / before.peak);
  EXPECT_LT(learnt, 0.8 * before.peak);
}

// A thread keeps the spectra of the filters it located last (a filter's
// weights change only when it learns): more filters than it keeps, located
// in turn, in one order and then the other, each on its own region, must
// find exactly what they found the first time, each with its own weights.
TEST(RegionFilter, ManyFiltersFindAlikeInAnyOrder) {
  constexpr int kFilters = 7;  // more than the thread keeps
  std::vector<cv::Mat> frames, moved;
  std::vector<RegionFilter> filters(kFilters);
  const cv::Point2d d(5, -3);
  for (int i = 0; i < kFilters; ++i) {
    frames.push_back(texture(40 + i));
    moved.push_back(shifted(frames.back(), d.x, d.y));
    ASSERT_TRUE(RegionFilter::create(frames.back(), kBox, &filters[i]));
  }
  std::vector<FilterMatch> first(kFilters);
  for (int i = 0; i < kFilters; ++i) {
    first[i] = filters[i].locate(moved[i], kBox);
    ASSERT_TRUE(first[i].found);
    // Each finds its region where it moved (as FindsTheRegionWhereItMoved).
    EXPECT_LT(std::hypot(first[i].shift.x - d.x, first[i].shift.y - d.y), 1.5) << i;
  }
  for (const bool reverse : {true, false}) {
    for (int k = 0; k < kFilters; ++k) {
      const int i = reverse ? kFilters - 1 - k : k;
      const FilterMatch m = filters[i].locate(moved[i], kBox);
      EXPECT_EQ(m.peak, first[i].peak) << i;
      EXPECT_EQ(m.psr, first[i].psr) << i;
      EXPECT_EQ(m.shift, first[i].shift) << i;
    }
  }
  // Another filter's weights on this region peak lower (so the checks above
  // would see a mix-up): measured 0.23 of its own.
  const double mixed = filters[1].locate(moved[0], kBox).peak;
  std::printf("another filter's weights: peak %.3f of its own\n", mixed / first[0].peak);
  EXPECT_LT(mixed, 0.8 * first[0].peak);
}

TEST(RegionFilter, LearnsAChangedLook) {
  // The region's texture swapped for another: the filter finds the new one
  // clearly after learning it for a while at the tracker's rate.
  const cv::Mat frame = texture(3), other = texture(21);
  RegionFilter f;
  ASSERT_TRUE(RegionFilter::create(frame, kBox, &f));
  const double psr0 = f.locate(other, kBox).psr;
  for (int i = 0; i < 60; ++i) f.learn(other, kBox, 0.04);
  const FilterMatch m = f.locate(shifted(other, 4, 2), kBox);
  std::printf("the new look: psr %.1f before learning it, %.1f after 60 frames at 0.04; found (%.2f, %.2f)\n", psr0,
              m.psr, m.shift.x, m.shift.y);
  EXPECT_GT(m.psr, 12);
  EXPECT_LT(std::hypot(m.shift.x - 4, m.shift.y - 2), 1.5);
}

TEST(RegionFilter, RefusesWhatItCannotUse) {
  const cv::Mat frame = texture(3);
  RegionFilter f;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_FALSE(RegionFilter::create(frame, cv::Rect2d(nan, 10, 20, 20), &f));
  EXPECT_FALSE(RegionFilter::create(frame, cv::Rect2d(10, 10, 0, 20), &f));
  EXPECT_FALSE(RegionFilter::create(frame, cv::Rect2d(10, 10, 1, 1), &f));         // under a cell
  EXPECT_FALSE(RegionFilter::create(frame, cv::Rect2d(-100, 10, 60, 60), &f));     // mostly outside
  EXPECT_FALSE(RegionFilter::create(cv::Mat(), kBox, &f));
  cv::Mat colour;
  cv::cvtColor(frame, colour, cv::COLOR_GRAY2BGR);
  EXPECT_FALSE(RegionFilter::create(colour, kBox, &f));
  EXPECT_FALSE(f.valid());
  EXPECT_FALSE(f.locate(frame, kBox).found);  // an invalid filter finds nothing
  ASSERT_TRUE(RegionFilter::create(frame, kBox, &f));
  EXPECT_FALSE(f.locate(frame, cv::Rect2d(nan, 0, 10, 10)).found);
  EXPECT_FALSE(f.locate(colour, kBox).found);
  // A box leaving the image: the window reads the image's edge replicated.
  EXPECT_TRUE(f.locate(frame, cv::Rect2d(620, 460, 40, 70)).found);
  f.learn(frame, cv::Rect2d(nan, 0, 10, 10), 0.5);  // ignored
  EXPECT_GT(f.locate(frame, kBox).psr, 12);
}

}  // namespace
}  // namespace imt
