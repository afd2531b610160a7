// Region tracking end to end on rendered scenes: the scene generator's
// `cards` preset (textured wall, moving cards, an occlusion, a static and a
// featureless wall patch, camera pan/roll/zoom), the real motion analysis,
// then the region manager. Scored by IoU against the generator's boxes.
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "../box_metrics.h"
#include "instant_motion_tracking/core/region/region_manager.h"
#include "instant_motion_tracking/sim/scene.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <map>

namespace imt {
namespace {

using test::iouClipped;

const FrameTruth::Region* region(const FrameTruth& f, uint32_t id) {
  for (const auto& r : f.regions)
    if (r.id == id) return &r;
  return nullptr;
}

// The first frame (index into `truth`) from `from` on where region `id` is
// wholly in view and unoccluded, -1 when there is none: a box given on a
// partly visible card would stand for only that part of it, while the truth
// box grows as the card comes in.
int firstWholeFrame(const std::vector<FrameTruth>& truth, uint32_t id, int from = 0) {
  for (int k = from; k < static_cast<int>(truth.size()); ++k) {
    const FrameTruth::Region* r = region(truth[k], id);
    if (r && r->visible_fraction > 0.999 && r->occluded_fraction < 0.001) return k;
  }
  return -1;
}

// Mean IoU of region `id` given at its true box in truth[start], tracked
// forwards and backwards by `m` (which holds the motion data of exactly the
// frames of `truth`), over every frame where it is at least half visible.
double meanRegionIou(RegionManager& m, const std::vector<FrameTruth>& truth, cv::Size size, uint32_t id, int start,
                     int* scored = nullptr) {
  const FrameTruth::Region* r0 = region(truth[start], id);
  EXPECT_TRUE(r0);
  if (!r0) return 0;
  uint32_t assigned;
  std::string err;
  EXPECT_TRUE(m.add(id, truth[start].stamp, r0->box, &assigned, &err)) << err;
  double sum = 0;
  int n = 0;
  for (const FrameTruth& f : truth) {
    std::vector<RegionState> s;
    EXPECT_TRUE(m.statesAt(f.stamp, {id}, &s, &err)) << err;
    const FrameTruth::Region* r = region(f, id);
    if (!r || r->visible_fraction < 0.5 || s.empty()) continue;
    sum += s[0].status == RegionStatus::kLost ? 0.0 : iouClipped(s[0].box, r->box, size);
    ++n;
  }
  if (scored) *scored = n;
  return n ? sum / n : 0;
}

// Renders and analyses the scene once for every test of this file.
class CardsScene : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto opt = SceneOptions::fromPreset("cards");
    ASSERT_TRUE(opt);
    opt->duration = 8.0;
    opt->seed = 5;
    std::string err;
    scene_ = SceneGenerator::create(*opt, &err).release();
    ASSERT_TRUE(scene_) << err;
    MotionAnalyzer analyzer{MotionAnalysisOptions()};
    for (int i = 0; i < scene_->frameCount(); ++i) {
      md_.push_back(analyzer.process(scene_->renderFrame(i), scene_->frameStamp(i)));
      truth_.push_back(scene_->frameTruth(i));
    }
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
    md_.clear();
    truth_.clear();
  }

  // firstWholeFrame, or `from` when there is none.
  static int firstWhole(uint32_t id, int from) {
    const int k = firstWholeFrame(truth_, id, from);
    return k >= 0 ? k : from;
  }

  // meanRegionIou over the whole scene.
  static double meanIou(uint32_t id, int start, int* scored = nullptr) {
    RegionManager m(RegionTrackerOptions(), 0.0);  // keep everything (offline)
    for (const MotionData& md : md_) m.update(md);
    return meanRegionIou(m, truth_, cv::Size(md_[0].width, md_[0].height), id, start, scored);
  }

  static SceneGenerator* scene_;
  static std::vector<MotionData> md_;
  static std::vector<FrameTruth> truth_;
};

SceneGenerator* CardsScene::scene_ = nullptr;
std::vector<MotionData> CardsScene::md_;
std::vector<FrameTruth> CardsScene::truth_;

// The bar for every case is a mean IoU of 0.85.
constexpr double kMinIou = 0.85;

TEST_F(CardsScene, MovingCardsInFrontOfAMovingBackground) {
  for (uint32_t id : {1u, 3u}) {
    int n = 0;
    const int start = firstWhole(id, 0);
    const double iou = meanIou(id, start, &n);
    std::printf("card %u (given at frame %d): mean IoU %.3f over %d frames\n", id, start, iou, n);
    EXPECT_GT(n, 100);
    EXPECT_GE(iou, kMinIou) << "card " << id;
  }
}

TEST_F(CardsScene, CardOccludedByAnotherCard) {
  int n = 0;
  const int start = firstWhole(2, 0);
  const double iou = meanIou(2, start, &n);
  std::printf("occluded card 2 (given at frame %d): mean IoU %.3f over %d frames\n", start, iou, n);
  EXPECT_GE(iou, kMinIou);
}

TEST_F(CardsScene, StaticWallPatch) {
  const double iou = meanIou(4, 0);
  std::printf("static wall patch: mean IoU %.3f\n", iou);
  EXPECT_GE(iou, kMinIou);
}

TEST_F(CardsScene, FeaturelessWallPatch) {
  const double iou = meanIou(5, 0);
  std::printf("featureless patch: mean IoU %.3f\n", iou);
  EXPECT_GE(iou, kMinIou);
}

TEST_F(CardsScene, RegionGivenMidSequenceIsTrackedBothWays) {
  for (uint32_t id : {1u, 4u}) {
    const int mid = firstWhole(id, static_cast<int>(md_.size()) / 2);
    const double iou = meanIou(id, mid);
    std::printf("region %u given at frame %d: mean IoU %.3f (backwards and forwards)\n", id, mid, iou);
    EXPECT_GE(iou, kMinIou) << "region " << id;
  }
}


// A loaded live graph drops frames (the image queue overflows): the motion
// analysis then sees steps of several frames. On the live demo's scene
// (cards, seed 1) regions must be tracked as well as without the gaps.
// Measured before the interval-aware prediction: card 1 mean IoU 0.09 after
// 3 frames dropped once (its features all lost, the region left on the wall).
TEST(CardsSceneDroppedFrames, RegionsAreTrackedAsWellAsWithoutGaps) {
  auto opt = SceneOptions::fromPreset("cards");
  ASSERT_TRUE(opt);
  opt->duration = 4.0;
  opt->seed = 1;
  std::string err;
  auto scene = SceneGenerator::create(*opt, &err);
  ASSERT_TRUE(scene) << err;
  const int n = scene->frameCount();
  std::vector<cv::Mat> images;
  for (int k = 0; k < n; ++k) images.push_back(scene->renderFrame(k));
  // Bursts of 2, 3, 5 and 6 dropped frames, and a stretch at half rate.
  auto dropped = [](int k) {
    return (k >= 12 && k < 14) || (k >= 28 && k < 31) || (k >= 50 && k < 55) || (k >= 78 && k < 84) ||
           (k >= 95 && k < 110 && k % 2 == 1);
  };
  std::map<uint32_t, double> base, with_gaps;  // mean IoU by card
  for (bool drop : {false, true}) {
    MotionAnalyzer analyzer{MotionAnalysisOptions()};
    RegionManager m(RegionTrackerOptions(), 0.0);
    std::vector<int> frames;  // scene frame numbers analysed
    std::vector<FrameTruth> truth;
    for (int k = 0; k < n; ++k) {
      if (drop && dropped(k)) continue;
      frames.push_back(k);
      truth.push_back(scene->frameTruth(k));
      m.update(analyzer.process(images[k], truth.back().stamp));
    }
    for (uint32_t id : {1u, 2u, 3u}) {
      // Given where the card is first whole in view (and kept, not dropped).
      const int start = firstWholeFrame(truth, id);
      ASSERT_GE(start, 0) << "card " << id;
      int scored = 0;
      const double iou = meanRegionIou(m, truth, images[0].size(), id, start, &scored);
      std::printf("card %u given at frame %d, %s: mean IoU %.3f over %d frames\n", id, frames[start],
                  drop ? "frames dropped" : "every frame", iou, scored);
      (drop ? with_gaps : base)[id] = iou;
    }
  }
  // Measured: every card within 0.01 of its figure without gaps (0.942,
  // 0.918, 0.934). Bars: the 0.85 for every card (the failure this
  // guards against left card 1 at 0.09; card 3, half out of view on 6-9
  // features, was at 0.841 while a scale needed 8 inliers), and the mean
  // within 0.02 of the mean without gaps.
  double mean = 0, mean_base = 0;
  for (const auto& [id, iou] : with_gaps) {
    EXPECT_GE(iou, kMinIou) << "card " << id;
    mean += iou / with_gaps.size();
    mean_base += base[id] / with_gaps.size();
  }
  EXPECT_GE(mean, mean_base - 0.02);
}

// A card seen on few features (card 3 of these seeds runs along the bottom
// edge, half out of view, on 6-8 inliers while it comes closer): its scale
// is still estimated (region_tracking.min_inliers_scale 6). Measured over 8
// seeds of the cards scene: card 3 mean IoU 0.890 -> 0.909 on average when
// the bar went from 8 inliers to 6, the other cards within 0.002; on these
// two seeds 0.704 -> 0.884 and 0.687 -> 0.886.
TEST(CardsSceneFewFeatures, CardAlongTheEdgeKeepsItsScale) {
  for (uint32_t seed : {6u, 7u}) {
    auto opt = SceneOptions::fromPreset("cards");
    ASSERT_TRUE(opt);
    opt->duration = 6.0;
    opt->seed = seed;
    std::string err;
    auto scene = SceneGenerator::create(*opt, &err);
    ASSERT_TRUE(scene) << err;
    MotionAnalyzer analyzer{MotionAnalysisOptions()};
    RegionManager m(RegionTrackerOptions(), 0.0);
    std::vector<FrameTruth> truth;
    cv::Size size;
    for (int k = 0; k < scene->frameCount(); ++k) {
      const cv::Mat image = scene->renderFrame(k);
      size = image.size();
      truth.push_back(scene->frameTruth(k));
      m.update(analyzer.process(image, truth.back().stamp));
    }
    const int start = firstWholeFrame(truth, 3);
    ASSERT_GE(start, 0);
    int n = 0;
    const double iou = meanRegionIou(m, truth, size, 3, start, &n);
    ASSERT_GT(n, 60);
    std::printf("seed %u: card 3 mean IoU %.3f over %d frames\n", seed, iou, n);
    EXPECT_GE(iou, kMinIou) << "seed " << seed;
  }
}

}  // namespace
}  // namespace imt
