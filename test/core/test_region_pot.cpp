// Region tracking on real video: the POT-210 excerpt (../shared/data/
// pot210_excerpt; skipped when absent). A region is given as the bounding box
// of the target's frame-1 corners and tracked on motion data alone; it is
// scored by IoU against the bounding box of the annotated corners on every
// annotated, unflagged frame. V25_2 turns the target in the image plane (an
// axis-aligned box of a turning quad is a loose fit for any box tracker);
// V24_7 moves freely, with a card covering most of the target and blur.
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/region/region_manager.h"

#include "../box_metrics.h"
#include "../pot210.h"
#include "shared_data.h"

#include <gtest/gtest.h>

#include <cstdio>

namespace imt {
namespace {

struct PotCase {
  const char* sequence;
  int frames;
  double min_iou;
};

class RegionPot : public ::testing::TestWithParam<PotCase> {};

TEST_P(RegionPot, TargetBoxIsFollowed) {
  const PotCase& c = GetParam();
  const std::string dir = test::sharedDataDir() + "/pot210_excerpt";
  if (!test::pathExists(dir + "/annotation")) GTEST_SKIP() << "POT-210 excerpt not found under " << dir;
  test::PotSequence pot;
  ASSERT_TRUE(pot.load(dir, c.sequence, c.frames));
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  RegionManager regions(RegionTrackerOptions(), 0.0);  // offline: keep every frame
  for (int f = 1; f <= pot.frames(); ++f) {
    const cv::Mat gray = pot.gray(f);
    ASSERT_FALSE(gray.empty()) << c.sequence << " frame " << f;
    regions.update(analyzer.process(gray, f / 30.0));
  }
  uint32_t id;
  std::string err;
  ASSERT_TRUE(regions.add(1, 1 / 30.0, pot.box(1), &id, &err)) << err;
  double sum = 0, worst = 1;
  int scored = 0;
  const cv::Size size = pot.gray(1).size();
  for (int f = 2; f <= pot.frames(); ++f) {
    if (!pot.scored(f)) continue;
    std::vector<RegionState> s;
    ASSERT_TRUE(regions.statesAt(f / 30.0, {id}, &s, &err)) << err;
    ASSERT_EQ(s.size(), 1u);
    const double iou = s[0].status == RegionStatus::kLost ? 0.0 : test::iouClipped(s[0].box, pot.box(f), size);
    sum += iou;
    worst = std::min(worst, iou);
    ++scored;
  }
  ASSERT_GT(scored, 20);
  std::printf("POT %s, region on the target's box: mean IoU %.3f, worst %.3f over %d frames\n", c.sequence,
              sum / scored, worst, scored);
  EXPECT_GE(sum / scored, c.min_iou);
}

// Measured 0.717 (V25_2) and 0.748 (V24_7); OpenCV's KCF reaches 0.706 / 0.673
// and CSRT 0.694 / 0.589 on the same boxes (benchmark_region_pot). Bars 0.05
// below ours: a change that loses the target on real video shows here.
INSTANTIATE_TEST_SUITE_P(Sequences, RegionPot,
                         ::testing::Values(PotCase{"V25_2", 50, 0.67}, PotCase{"V24_7", 110, 0.70}),
                         [](const ::testing::TestParamInfo<PotCase>& info) { return info.param.sequence; });

}  // namespace
}  // namespace imt
