// Motion analysis against the scene generator's ground truth: camera-motion
// transfer error, model class, foreground/background classification.
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/sim/scene.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <ostream>
#include <string>
#include <vector>

namespace imt {
namespace {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<size_t>(p * v.size()))];
}

Eigen::Vector2d transfer(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  return (H * p.homogeneous()).hnormalized();
}

// Label values of the label rendering.
constexpr uint8_t kLabelBackground = 0;  // the wall and what lies flat on it (ids 4, 5)
constexpr uint8_t kLabelVoid = 255;      // no plane
uint8_t cardLabel(uint32_t id) { return static_cast<uint8_t>(60 * id); }  // moving cards, ids 1..3

// The same scene rendered as a label image: every plane flat in its label
// grey, no noise, no gain change. Anti-aliased edges get mixed values, which
// the classification below ignores.
std::unique_ptr<SceneGenerator> labelScene(const SceneOptions& o) {
  SceneOptions l = o;
  l.noise_sigma = 0;
  l.brightness_amplitude = 0;
  l.supersample = 1;
  l.exposure = 0;
  l.void_gray = kLabelVoid;
  for (ScenePlane& p : l.planes) {
    p.flat = true;
    const bool moving_card = p.kind == ScenePlane::Kind::kCard && p.id >= 1 && p.id <= 3;
    p.flat_gray = moving_card ? cardLabel(p.id) : kLabelBackground;
  }
  std::string err;
  return SceneGenerator::create(l, &err);
}

struct SceneRun {
  std::vector<double> transfer_errors;  // px, background grid points, every frame pair
  double worst_pair_median = 0, worst_pair_p95 = 0;  // px, the worst frame pair's
  int frames = 0;                       // frame pairs analysed
  int models[4] = {0, 0, 0, 0};         // frame pairs per chosen model
  int card_features = 0, card_flagged = 0;
  int bg_features = 0, bg_flagged = 0;
};

// Runs `frames` frames of `preset` from frame `first` through a default
// analyzer. A feature counts as card or background only when the label is
// uniform within `band` px of it: the Lucas-Kanade window (11 analysis px =
// 22 full-resolution px) of a feature closer to an edge straddles two motions,
// so it has no single true label.
SceneRun runScene(const std::string& preset, int first, int frames) {
  SceneRun run;
  std::optional<SceneOptions> o = SceneOptions::fromPreset(preset);
  EXPECT_TRUE(o.has_value()) << preset;
  if (!o) return run;
  o->duration = (first + frames) / o->fps + 1e-6;
  std::string err;
  auto scene = SceneGenerator::create(*o, &err);
  EXPECT_TRUE(scene) << err;
  auto labels = labelScene(scene->options());
  EXPECT_TRUE(labels);
  if (!scene || !labels) return run;

  const MotionAnalysisOptions options;
  MotionAnalyzer analyzer(options);
  const int band = 12;
  cv::Mat prev_label;
  for (int i = first; i < first + frames && i < scene->frameCount(); ++i) {
    const FrameTruth gt = scene->frameTruth(i);
    const MotionData md = analyzer.process(scene->renderFrame(i), gt.stamp);
    const cv::Mat label = labels->renderFrame(i);
    if (i > first) {
      ++run.frames;
      ++run.models[static_cast<int>(md.camera.model)];
      // Transfer error on a 16 x 12 grid of points that were background in
      // the previous frame.
      EXPECT_TRUE(gt.background_homography.has_value());
      if (gt.background_homography) {
        const size_t pair_start = run.transfer_errors.size();
        for (int gy = 0; gy < 12; ++gy) {
          for (int gx = 0; gx < 16; ++gx) {
            const Eigen::Vector2d p((gx + 0.5) * md.width / 16, (gy + 0.5) * md.height / 12);
            if (prev_label.at<uint8_t>(static_cast<int>(p.y()), static_cast<int>(p.x())) !=
                kLabelBackground)
              continue;
            run.transfer_errors.push_back(
                (transfer(md.camera.H, p) - transfer(*gt.background_homography, p)).norm());
          }
        }
        const std::vector<double> pair(run.transfer_errors.begin() + pair_start, run.transfer_errors.end());
        if (!pair.empty()) {
          run.worst_pair_median = std::max(run.worst_pair_median, percentile(pair, 0.5));
          run.worst_pair_p95 = std::max(run.worst_pair_p95, percentile(pair, 0.95));
        }
      }
      for (const FeatureMotion& f : md.features) {
        if (f.age == 0) continue;  // no motion measured yet
        const cv::Rect r = cv::Rect(static_cast<int>(f.x) - band, static_cast<int>(f.y) - band,
                                    2 * band + 1, 2 * band + 1) &
                           cv::Rect(0, 0, label.cols, label.rows);
        double lo, hi;
        cv::minMaxLoc(label(r), &lo, &hi);
        if (lo != hi) continue;
        if (lo == kLabelBackground) {
          ++run.bg_features;
          run.bg_flagged += f.foreground;
        } else if (lo == cardLabel(1) || lo == cardLabel(2) || lo == cardLabel(3)) {
          ++run.card_features;
          run.card_flagged += f.foreground;
        }
      }
    }
    prev_label = label;
  }
  return run;
}

struct SceneCase {
  std::string preset;
  int first, frames;
  MotionModel model;  // expected in every frame pair
  friend std::ostream& operator<<(std::ostream& os, const SceneCase& c) { return os << c.preset; }
};

class MotionAnalysisScene : public ::testing::TestWithParam<SceneCase> {};

// Targets of issue 3: median transfer error <= 0.3 px, 95th percentile <= 1 px
// per frame pair. Measured (default options, 640x480): cards median 0.012 /
// p95 0.030 px, wall_pan 0.009 / 0.022, rotate 0.011 / 0.032, planar 0.010 /
// 0.026, still 0.003 / 0.007; the targets hold with a wide margin. The worst
// frame pair's: 0.014 / 0.038, 0.047 / 0.087, 0.016 / 0.039, 0.005 / 0.009,
// cards 0.026 / 0.061.
// The model class: a textured wall seen whole (pure rotation, no motion, a
// fully planar scene, a pan) supports the 8DoF homography in every frame.
TEST_P(MotionAnalysisScene, CameraMotionMatchesGroundTruth) {
  const SceneCase& c = GetParam();
  const SceneRun run = runScene(c.preset, c.first, c.frames);
  ASSERT_GT(run.frames, 0);
  EXPECT_EQ(run.models[static_cast<int>(c.model)], run.frames)
      << "models T/S/H/I: " << run.models[1] << "/" << run.models[2] << "/" << run.models[3] << "/"
      << run.models[0];
  ASSERT_GT(run.transfer_errors.size(), 100u);
  const double median = percentile(run.transfer_errors, 0.5),
               p95 = percentile(run.transfer_errors, 0.95);
  EXPECT_LE(median, 0.3);
  EXPECT_LE(p95, 1.0);
  // And in every frame pair, not only over all of them pooled.
  EXPECT_LE(run.worst_pair_median, 0.3);
  EXPECT_LE(run.worst_pair_p95, 1.0);
  RecordProperty("transfer_median_px", std::to_string(median));
  RecordProperty("transfer_p95_px", std::to_string(p95));
  std::printf("[ %s ] transfer error median %.3f px, p95 %.3f px over %zu points; the worst pair's %.3f / %.3f px\n",
              c.preset.c_str(), median, p95, run.transfer_errors.size(), run.worst_pair_median,
              run.worst_pair_p95);
  // Background features flagged foreground: <= 5% (issue 3). Measured
  // 0.0-0.1% on the wall-only scenes.
  ASSERT_GT(run.bg_features, 100);
  EXPECT_LE(static_cast<double>(run.bg_flagged) / run.bg_features, 0.05);
}

INSTANTIATE_TEST_SUITE_P(MotionAnalysisPresets, MotionAnalysisScene,
                         ::testing::Values(SceneCase{"wall_pan", 0, 60, MotionModel::kHomography},
                                           SceneCase{"rotate", 0, 60, MotionModel::kHomography},
                                           SceneCase{"planar", 0, 60, MotionModel::kHomography},
                                           SceneCase{"still", 0, 30, MotionModel::kHomography},
                                           SceneCase{"cards", 0, 90, MotionModel::kHomography}),
                         [](const ::testing::TestParamInfo<SceneCase>& info) {
                           return info.param.preset;
                         });

// Cards moving over the wall (up to ~30% of the frame): >= 95% of the card
// features flagged foreground and <= 5% of the background features (issue 3).
// Measured: frames 0-89 99.0% / 0.55%, frames 100-189 (tested) 98.2% / 0.38%.
// Card 2 moves slowly relative to the wall for ~1 s (its own motion and the
// camera's parallax nearly cancel, 0.1-0.5 px/frame); the
// accumulated residual is what still flags it.
TEST(MotionAnalysisForeground, CardsAreForegroundWallIsBackground) {
  const SceneRun run = runScene("cards", 100, 90);
  ASSERT_GT(run.card_features, 500);
  ASSERT_GT(run.bg_features, 2000);
  const double card_rate = static_cast<double>(run.card_flagged) / run.card_features;
  const double bg_rate = static_cast<double>(run.bg_flagged) / run.bg_features;
  std::printf(
      "[ cards ] foreground: %.1f%% of %d card features, %.2f%% of %d background features\n",
      100 * card_rate, run.card_features, 100 * bg_rate, run.bg_features);
  EXPECT_GE(card_rate, 0.95);
  EXPECT_LE(bg_rate, 0.05);
}

// A flat wall has no corners: every frame is invalid with the identity, no
// features, and nothing throws.
TEST(MotionAnalysisScenes, FeaturelessWallIsInvalid) {
  std::optional<SceneOptions> o = SceneOptions::fromPreset("featureless_wall");
  ASSERT_TRUE(o);
  o->duration = 10 / o->fps;
  std::string err;
  auto scene = SceneGenerator::create(*o, &err);
  ASSERT_TRUE(scene) << err;
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  for (int i = 0; i < scene->frameCount(); ++i) {
    const MotionData md = analyzer.process(scene->renderFrame(i), scene->frameStamp(i));
    EXPECT_EQ(md.camera.model, MotionModel::kInvalid) << "frame " << i;
    EXPECT_TRUE(md.camera.H.isIdentity()) << "frame " << i;
    EXPECT_TRUE(md.features.empty()) << "frame " << i << ": " << md.features.size() << " features";
  }
}

}  // namespace
}  // namespace imt
