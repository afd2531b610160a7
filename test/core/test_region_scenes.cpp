// Region tracking end to end on rendered scenes: the scene generator's
// `cards` preset (textured wall, moving cards, an occlusion, a static and a
// featureless wall patch, camera pan/roll/zoom), the real motion analysis,
// then the region manager. Scored by IoU against the generator's boxes.
#include "instant_motion_tracking/core/motion_analysis.h"
#include "../box_metrics.h"
#include "instant_motion_tracking/core/region_manager.h"
#include "instant_motion_tracking/core/scene.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <map>

namespace imt {
namespace {

using test::iouClipped;

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

  static const FrameTruth::Region* region(const FrameTruth& f, uint32_t id) {
    for (const auto& r : f.regions)
      if (r.id == id) return &r;
    return nullptr;
  }

  // The first frame from `from` on where region `id` is wholly in view and
  // unoccluded: a box given on a partly visible card would stand for only
  // that part of it, while the truth box grows as the card comes in.
  static int firstWhole(uint32_t id, int from) {
    for (int k = from; k < static_cast<int>(truth_.size()); ++k) {
      const FrameTruth::Region* r = region(truth_[k], id);
      if (r && r->visible_fraction > 0.999 && r->occluded_fraction < 0.001) return k;
    }
    return from;
  }

  // Mean IoU of region `id` given at frame `start`, over every frame where it
  // is at least half visible; tracked forwards and backwards from `start`.
  static double meanIou(uint32_t id, int start, int* scored = nullptr) {
    RegionManager m(RegionTrackerOptions(), 0.0);  // keep everything (offline)
    for (const MotionData& md : md_) m.update(md);
    const FrameTruth::Region* r0 = region(truth_[start], id);
    EXPECT_TRUE(r0);
    if (!r0) return 0;
    uint32_t assigned;
    std::string err;
    EXPECT_TRUE(m.add(id, md_[start].stamp, r0->box, &assigned, &err)) << err;
    double sum = 0;
    int n = 0;
    const cv::Size size(md_[0].width, md_[0].height);
    for (size_t k = 0; k < md_.size(); ++k) {
      std::vector<RegionState> s;
      EXPECT_TRUE(m.seek(md_[k].stamp, {id}, &s, &err)) << err;
      const FrameTruth::Region* r = region(truth_[k], id);
      if (!r || r->visible_fraction < 0.5 || s.empty()) continue;
      sum += s[0].status == RegionStatus::kLost ? 0.0 : iouClipped(s[0].box, r->box, size);
      ++n;
    }
    if (scored) *scored = n;
    return n ? sum / n : 0;
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

}  // namespace
}  // namespace imt
