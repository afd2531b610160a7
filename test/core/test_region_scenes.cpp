// Region tracking end to end on rendered scenes: the scene generator's
// `cards` preset (textured wall, moving cards, an occlusion, a static and a
// featureless wall patch, camera pan/roll/zoom), the real motion analysis,
// then the region manager. Scored by IoU against the generator's boxes.
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "../box_metrics.h"
#include "instant_motion_tracking/core/region/region_manager.h"
#include "instant_motion_tracking/core/tracking_session.h"
#include "instant_motion_tracking/sim/scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
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
    sum += s[0].status == RegionStatus::kLost ? 0.0 : iouClipped(s[0].extent(), r->box, size);
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

// A camera that rolls turns everything in the image: the static patch on the
// wall (4 of `cards`, the cards moving in front) under the `rotate`
// trajectory at 1.5 times its amplitude (roll +-18 deg, yaw +-22, pitch
// +-15), tracked by the whole session offline (the look included). The
// region's turn follows the patch's true turn in the image (its projected x
// axis against the frame it was given at), and the extent it reports fits
// the truth box as well as the bar asks (the box given at start is
// already the extent of a patch the roll had turned, so the unturned box
// fits about as well here: measured 0.876 against 0.883; the turn pays where
// a target turns far, docs/benchmarks.md).
TEST(RollingCamera, WallPatchTurnsWithTheCamera) {
  auto opt = SceneOptions::fromPreset("cards");
  ASSERT_TRUE(opt);
  opt->trajectory = "rotate";
  opt->trajectory_amplitude = 1.5;
  opt->duration = 6.0;
  opt->seed = 3;
  std::string err;
  const auto scene = SceneGenerator::create(*opt, &err);
  ASSERT_TRUE(scene) << err;
  constexpr uint32_t kPatch = 4;
  size_t plane = 0;
  while (plane < scene->options().planes.size() && scene->options().planes[plane].id != kPatch) ++plane;
  ASSERT_LT(plane, scene->options().planes.size());
  // The patch's turn in the image at frame k: its x axis projected.
  auto trueAngle = [&](int k) {
    const double t = k / opt->fps;
    const Eigen::Isometry3d T = scene->T_world_plane(plane, t);
    const auto a = scene->project(T * Eigen::Vector3d(0, 0, 0), t), b = scene->project(T * Eigen::Vector3d(0.1, 0, 0), t);
    return a && b ? std::atan2(b->y - a->y, b->x - a->x) : NAN;
  };
  std::vector<FrameTruth> truth;
  PipelineOptions po;
  po.cache_seconds = opt->duration + 1;
  TrackingSession session(po, TrackingSession::Mode::kOffline);
  session.setCameraInfo(scene->intrinsics());
  for (int k = 0; k < scene->frameCount(); ++k) {
    session.analyze(scene->renderFrame(k), scene->frameStamp(k));
    truth.push_back(scene->frameTruth(k));
  }
  const int start = firstWholeFrame(truth, kPatch);
  ASSERT_GE(start, 0);
  uint32_t id = 0;
  ASSERT_TRUE(session.addRegion(kPatch, truth[start].stamp, region(truth[start], kPatch)->box, &id, &err)) << err;
  const cv::Size size(opt->width, opt->height);
  double iou_extent = 0, iou_box = 0, max_roll = 0;
  std::vector<double> turn_errors;
  int lost = 0;  // frames of the patch in plain view where the region was lost (IoU 0)
  for (int k = 0; k < scene->frameCount(); ++k) {
    const FrameTruth::Region* r = region(truth[k], kPatch);
    std::vector<RegionState> states;
    ASSERT_TRUE(session.seekRegions(truth[k].stamp, {id}, &states, &err)) << err;
    if (!r || r->visible_fraction < 0.999 || r->occluded_fraction > 0.001 || states.empty()) continue;
    if (states[0].status == RegionStatus::kLost) {
      ++lost;
      continue;
    }
    const double roll = std::remainder(trueAngle(k) - trueAngle(start), 2 * M_PI);
    max_roll = std::max(max_roll, std::abs(roll));
    turn_errors.push_back(std::abs(std::remainder(states[0].angle - roll, 2 * M_PI)) * 180 / M_PI);
    iou_extent += iouClipped(states[0].extent(), r->box, size);
    iou_box += iouClipped(states[0].box, r->box, size);
  }
  const size_t n = turn_errors.size();
  ASSERT_GT(n, 60u);
  std::sort(turn_errors.begin(), turn_errors.end());
  const double median = turn_errors[n / 2], p90 = turn_errors[n * 9 / 10];
  std::printf("rolling camera (roll up to %.1f deg): turn error median %.2f deg, p90 %.2f deg over %zu frames, "
              "lost on %d; mean IoU of the extent %.3f, of the unturned box %.3f\n",
              max_roll * 180 / M_PI, median, p90, n, lost, iou_extent / (n + lost), iou_box / (n + lost));
  EXPECT_EQ(lost, 0) << "lost with the patch in plain view";
  EXPECT_GT(max_roll * 180 / M_PI, 15.0);  // the scene does turn the patch
  // Measured 0.79 / 1.15 deg (the camera model's turn at the patch, checked
  // by its look a 3-degree step either way): bars with a third in hand.
  EXPECT_LT(median, 1.2);
  EXPECT_LT(p90, 1.8);
  EXPECT_GE(iou_extent / (n + lost), kMinIou);
}

}  // namespace
}  // namespace imt
