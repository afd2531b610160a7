// RegionManager: many regions over the motion-data cache, added in the past,
// tracked backwards and forwards, seeked; bad requests named.
#include "instant_motion_tracking/core/region/region_manager.h"

#include "opencv_threads.h"
#include "synthetic_motion.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>

namespace imt {
namespace {

using namespace synthetic;

World cardWorld() {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(60, 120, 90, 5, true);
  card.half_size = {60, 45};
  card.centre = [](int k) { return Eigen::Vector2d(250 + 3.0 * k, 200 + 40 * std::sin(k / 15.0)); };
  card.scale = [](int k) { return 1.0 + 0.004 * k; };
  w.objects.push_back(card);
  return w;
}

TEST(RegionManager, RegionAddedInThePastCatchesUpAndSeeksBothWays) {
  const World w = cardWorld();
  const auto md = w.motionData(60);
  RegionManager m(RegionTrackerOptions(), 10.0);
  for (int k = 0; k < 60; ++k) m.update(md[k]);
  uint32_t id = 0;
  std::string err;
  // Given at frame 30, 1 s in the past.
  ASSERT_TRUE(m.add(0, md[30].stamp, w.box(0, 30), &id, &err)) << err;
  EXPECT_EQ(id, 1u);
  const auto now = m.latest();
  ASSERT_EQ(now.size(), 1u);
  EXPECT_DOUBLE_EQ(now[0].stamp, md[59].stamp);
  // Tracked forward to the present (measured IoU ~0.95; 0.85 is the bar).
  EXPECT_GT(iou(now[0].extent(), w.box(0, 59)), 0.85);
  // Backwards, down to the first cached frame, and forwards again.
  double sum = 0;
  for (int k = 0; k < 60; ++k) {
    std::vector<RegionState> s;
    ASSERT_TRUE(m.statesAt(md[k].stamp, {}, &s, &err)) << err;
    ASSERT_EQ(s.size(), 1u);
    EXPECT_DOUBLE_EQ(s[0].stamp, md[k].stamp);
    sum += iou(s[0].extent(), w.box(0, k));
  }
  EXPECT_GT(sum / 60, 0.85);
}

TEST(RegionManager, LiveRegionsAdvanceWithEachFrame) {
  const World w = cardWorld();
  const auto md = w.motionData(40);
  RegionManager m(RegionTrackerOptions(), 10.0);
  m.update(md[0]);
  uint32_t id;
  std::string err;
  ASSERT_TRUE(m.add(7, 0, w.box(0, 0), &id, &err)) << err;  // stamp 0 = latest frame
  EXPECT_EQ(id, 7u);
  for (int k = 1; k < 40; ++k) {
    const auto s = m.update(md[k]);
    ASSERT_EQ(s.size(), 1u);
    EXPECT_GT(iou(s[0].extent(), w.box(0, k)), 0.85) << "frame " << k;
  }
}

TEST(RegionManager, CacheIsBoundedAndOldStampsAreRejected) {
  const World w = cardWorld();
  const auto md = w.motionData(90);  // 3 s at 30 fps
  RegionManager m(RegionTrackerOptions(), 1.0);
  for (const auto& f : md) m.update(f);
  EXPECT_LE(m.newestStamp() - m.oldestStamp(), 1.0 + 1e-9);
  EXPECT_LE(m.cachedFrames(), 32u);
  uint32_t id;
  std::string err;
  EXPECT_FALSE(m.add(0, md[10].stamp, cv::Rect2d(10, 10, 50, 50), &id, &err));
  EXPECT_NE(err.find("outside the motion-data cache"), std::string::npos) << err;
}

TEST(MotionCache, ImagesStayWithinTheirBudgetOldestDroppedFirst) {
  const World w = cardWorld();
  const auto md = w.motionData(20);
  MotionCache cache(0.0);
  const size_t one = static_cast<size_t>(md[0].width) * md[0].height;  // bytes of one gray frame
  cache.setImageBudget(3 * one + one / 2);  // room for 3 frames, not 4
  std::string err;
  for (int k = 0; k < 10; ++k) {
    cv::Mat gray(md[k].height, md[k].width, CV_8UC1, cv::Scalar(k));
    ASSERT_TRUE(cache.push(md[k], &err, gray)) << err;
  }
  EXPECT_EQ(cache.imageBytes(), 3 * one);
  for (uint64_t seq = cache.firstSeq(); seq <= cache.lastSeq(); ++seq) {
    const int k = static_cast<int>(seq - cache.firstSeq());
    ASSERT_EQ(cache.image(seq).empty(), k < 7) << "frame " << k;
    if (k >= 7) {
      EXPECT_EQ(cache.image(seq).at<uchar>(0, 0), k);  // each frame keeps its own image
    }
  }
  // A colour image or one larger than the budget is not kept; frames still are.
  ASSERT_TRUE(cache.push(md[10], &err, cv::Mat(md[10].height, md[10].width, CV_8UC3))) << err;
  EXPECT_TRUE(cache.image(cache.lastSeq()).empty());
  EXPECT_EQ(cache.size(), 11u);
  cache.setImageBudget(one / 2);  // the kept ones dropped, a new one too large
  EXPECT_EQ(cache.imageBytes(), 0u);
  ASSERT_TRUE(cache.push(md[11], &err, cv::Mat(md[11].height, md[11].width, CV_8UC1, cv::Scalar(11)))) << err;
  EXPECT_TRUE(cache.image(cache.lastSeq()).empty());
  EXPECT_EQ(cache.imageBytes(), 0u);
  EXPECT_EQ(cache.size(), 12u);
  cache.setImageBudget(0);
  EXPECT_EQ(cache.imageBytes(), 0u);
  // A reset (time going backwards) clears the images with the frames.
  cache.setImageBudget(3 * one);
  ASSERT_TRUE(cache.push(md[12], &err, cv::Mat(md[12].height, md[12].width, CV_8UC1))) << err;
  EXPECT_FALSE(cache.push(md[5], &err, cv::Mat(md[5].height, md[5].width, CV_8UC1)));
  EXPECT_EQ(cache.size(), 1u);
  EXPECT_EQ(cache.imageBytes(), one);
}

struct BadAdd {
  const char* name;
  uint32_t id;
  cv::Rect2d box;
  double stamp_offset;  // added to the latest stamp
  const char* expected;
};

class RegionManagerRejects : public ::testing::TestWithParam<BadAdd> {};

TEST_P(RegionManagerRejects, WithAMessage) {
  const World w = cardWorld();
  const auto md = w.motionData(5);
  RegionManager m(RegionTrackerOptions(), 10.0);
  for (const auto& f : md) m.update(f);
  uint32_t id;
  std::string err;
  ASSERT_TRUE(m.add(1, 0, cv::Rect2d(10, 10, 50, 50), &id, &err)) << err;
  const BadAdd& p = GetParam();
  EXPECT_FALSE(m.add(p.id, md.back().stamp + p.stamp_offset, p.box, &id, &err));
  EXPECT_NE(err.find(p.expected), std::string::npos) << err;
  EXPECT_EQ(m.size(), 1u);
}

INSTANTIATE_TEST_SUITE_P(
    Cases, RegionManagerRejects,
    ::testing::Values(BadAdd{"zero", 0, cv::Rect2d(10, 10, 0, 5), 0, "must be positive"},
                      BadAdd{"negative", 0, cv::Rect2d(10, 10, -4, 5), 0, "must be positive"},
                      BadAdd{"nan", 0, cv::Rect2d(NAN, 10, 4, 5), 0, "NaN"},
                      BadAdd{"outside", 0, cv::Rect2d(700, 10, 40, 50), 0, "entirely outside"},
                      BadAdd{"duplicate", 1, cv::Rect2d(10, 10, 40, 50), 0, "already tracked"},
                      BadAdd{"future", 0, cv::Rect2d(10, 10, 40, 50), 5.0, "outside the motion-data cache"},
                      BadAdd{"past", 0, cv::Rect2d(10, 10, 40, 50), -100.0, "outside the motion-data cache"}),
    [](const auto& info) { return std::string(info.param.name); });

TEST(RegionManager, StampInAGapOfDroppedFramesIsRejected) {
  const World w = cardWorld();
  const auto md = w.motionData(30);
  RegionManager m(RegionTrackerOptions(), 10.0);
  for (int k = 0; k < 30; ++k)
    if (k < 10 || k > 20) m.update(md[k]);  // frames 10..20 dropped
  uint32_t id;
  std::string err;
  EXPECT_FALSE(m.add(0, md[15].stamp, cv::Rect2d(10, 10, 40, 50), &id, &err));
  EXPECT_NE(err.find("not within half a frame"), std::string::npos) << err;
  EXPECT_TRUE(m.add(0, md[21].stamp + 0.01, cv::Rect2d(10, 10, 40, 50), &id, &err)) << err;
}

TEST(RegionManager, UnknownIdsAreNamed) {
  RegionManager m(RegionTrackerOptions(), 10.0);
  std::string err;
  EXPECT_FALSE(m.remove(42, &err));
  EXPECT_NE(err.find("unknown region id 42"), std::string::npos);
  std::vector<RegionState> s;
  EXPECT_FALSE(m.statesAt(1000, {42}, &s, &err));
  EXPECT_NE(err.find("42"), std::string::npos);
}

TEST(RegionManager, TimeGoingBackwardsClearsEverything) {
  const World w = cardWorld();
  const auto md = w.motionData(10);
  RegionManager m(RegionTrackerOptions(), 10.0);
  for (const auto& f : md) m.update(f);
  uint32_t id;
  std::string err;
  ASSERT_TRUE(m.add(0, 0, w.box(0, 9), &id, &err));
  m.update(md[0]);  // a bag loop
  EXPECT_NE(m.lastReset().find("does not follow"), std::string::npos);
  EXPECT_EQ(m.size(), 0u);
  EXPECT_EQ(m.cachedFrames(), 1u);
}

// 100 boxes on a grid over the frame and the card's own region among them:
// every frame answers for all 101, and the card's region follows the card.
// The regions stepping into a frame step side by side on OpenCV's threads
// (RegionManager::stepBatch): on three threads (more than a 2-core machine
// has: the threads interleave) the states are those of one thread, to the bit.
TEST(RegionManager, HundredRegions) {
  const World w = cardWorld();
  const auto md = w.motionData(20);
  const auto run = [&](int threads, std::vector<std::vector<RegionState>>* frames) {
    const test::OpenCvThreads scope(threads);
    RegionManager m(RegionTrackerOptions(), 10.0);
    m.update(md[0]);
    uint32_t id;
    std::string err;
    for (int i = 0; i < 100; ++i) {
      const cv::Rect2d b(20 + (i % 10) * 60, 20 + (i / 10) * 44, 50, 40);
      ASSERT_TRUE(m.add(0, 0, b, &id, &err)) << err;
    }
    ASSERT_TRUE(m.add(0, 0, w.box(0, 0), &id, &err)) << err;
    EXPECT_EQ(id, 101u);
    for (int k = 1; k < 20; ++k) frames->push_back(m.update(md[k]));
  };
  std::vector<std::vector<RegionState>> three, one;
  run(3, &three);
  run(1, &one);
  ASSERT_EQ(three.size(), 19u);
  ASSERT_EQ(one.size(), 19u);
  double worst_iou = 1;
  for (int k = 1; k < 20; ++k) {
    const std::vector<RegionState>& a = three[k - 1];
    const std::vector<RegionState>& b = one[k - 1];
    ASSERT_EQ(a.size(), 101u) << "frame " << k;
    ASSERT_EQ(b.size(), 101u) << "frame " << k;
    for (size_t r = 0; r < a.size(); ++r) {
      ASSERT_EQ(a[r].id, b[r].id);
      EXPECT_EQ(a[r].status, b[r].status) << "region " << a[r].id << ", frame " << k;
      const cv::Rect2d ea = a[r].extent(), eb = b[r].extent();
      EXPECT_TRUE(ea.x == eb.x && ea.y == eb.y && ea.width == eb.width && ea.height == eb.height)
          << "region " << a[r].id << ", frame " << k << ": " << ea << " on three threads, " << eb << " on one";
      if (a[r].id == 101) worst_iou = std::min(worst_iou, iou(ea, w.box(0, k)));
    }
  }
  // The card's region among the 100 (measured: worst frame 0.961; 0.85 is the
  // issue's bar).
  std::printf("the card's region among 100 others: worst IoU %.3f\n", worst_iou);
  EXPECT_GT(worst_iou, 0.85);
}

}  // namespace
}  // namespace imt
