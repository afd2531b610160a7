// Planar target tracking end to end on the rendered `poster_orbit` scene (a
// 0.60 x 0.45 m poster on a textured wall; viewing angle up to ~50 degrees,
// roll +-30 degrees, distance x3, brightness +-25%; 600 frames): the real
// motion analysis, then the planar target manager, scored against the
// generator's corners and pose (the POT alignment error: RMS of the four
// corner distances).
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/planar/planar_target_manager.h"
#include "instant_motion_tracking/sim/scene.h"

#include "planar_real.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>

namespace imt {
namespace {

using test::cornerRms;
using test::percentile;

// Renders `scene` frame by frame through the motion analysis into a cache
// (frames kept for the appearance alignment), gives its target at frame
// `add_frame` (the generator's corners and size), and calls
// visit(frame, truth target, state, corner RMS error) for every later frame.
// jpeg_quality > 0: every frame goes through JPEG at that quality first, as
// from a phone's or a webcam's compressed stream; `alter` (if set) may
// change each rendered frame before it is tracked.
template <class Visit>
void trackRendered(const SceneGenerator& scene, int add_frame, Visit visit, int jpeg_quality = 0,
                   const std::function<void(int, cv::Mat&)>& alter = {}) {
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  MotionCache cache(0.0);
  cache.setImageBudget(size_t(1) << 30);
  PlanarTargetManager targets{PlanarTargetOptions(), &cache};
  uint32_t id = 0;
  std::string err;
  for (int i = 0; i < scene.frameCount(); ++i) {
    std::string reset;
    cv::Mat frame = scene.renderFrame(i);
    if (alter) alter(i, frame);
    if (jpeg_quality > 0) {
      std::vector<uchar> jpeg;
      cv::imencode(".jpg", frame, jpeg, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality});
      frame = cv::imdecode(jpeg, cv::IMREAD_GRAYSCALE);
    }
    // IMT_TEST_DUMP=DIR: every 30th frame as tracked, to look at the scene.
    if (const char* dump = std::getenv("IMT_TEST_DUMP"); dump && i % 30 == 0)
      cv::imwrite(std::string(dump) + "/frame" + std::to_string(i) + ".png", frame);
    cache.push(analyzer.process(frame, scene.frameStamp(i)), &reset, frame);
    if (i < add_frame) continue;
    const FrameTruth truth = scene.frameTruth(i);
    const FrameTruth::Target& t = truth.targets.at(0);
    if (i == add_frame) {
      ASSERT_TRUE(targets.add(t.id, scene.frameStamp(i), t.corners, t.width_m, t.height_m,
                              scene.intrinsics(), &id, &err))
          << err;
      continue;
    }
    const std::vector<PlanarTargetState> states = targets.update();
    ASSERT_EQ(states.size(), 1u);
    visit(i, t, states[0], cornerRms(states[0].corners, t.corners));
  }
}

class PosterOrbit : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto opt = SceneOptions::fromPreset("poster_orbit");
    ASSERT_TRUE(opt);
    std::string err;
    scene_ = SceneGenerator::create(*opt, &err).release();
    ASSERT_TRUE(scene_) << err;
    MotionAnalyzer analyzer{MotionAnalysisOptions()};
    cache_ = new MotionCache(0.0);
    cache_->setImageBudget(size_t(1) << 30);  // every frame: the appearance alignment uses them
    for (int i = 0; i < scene_->frameCount(); ++i) {
      std::string reset;
      const cv::Mat frame = scene_->renderFrame(i);
      cache_->push(analyzer.process(frame, scene_->frameStamp(i)), &reset, frame);
      truth_.push_back(scene_->frameTruth(i));
    }
  }
  static void TearDownTestSuite() {
    delete scene_;
    delete cache_;
    truth_.clear();
  }

  struct Errors {
    std::vector<double> corners, rot_deg, trans_rel;
    int not_tracked = 0;  // frames whose status is not `tracked`
  };

  static Errors track(const std::string& model) {
    PlanarTargetOptions opt;
    opt.model = model;
    PlanarTargetManager m(opt, cache_);
    const FrameTruth::Target& t0 = truth_[0].targets.at(0);
    uint32_t id;
    std::string err;
    EXPECT_TRUE(m.add(t0.id, cache_->at(cache_->firstSeq()).stamp, t0.corners, t0.width_m,
                      t0.height_m, scene_->intrinsics(), &id, &err))
        << err;
    Errors e;
    for (uint64_t seq = cache_->firstSeq() + 1; seq <= cache_->lastSeq(); ++seq) {
      std::vector<PlanarTargetState> states;
      EXPECT_TRUE(m.statesAt(cache_->at(seq).stamp, {id}, &states, &err)) << err;
      if (states.size() != 1) {
        ADD_FAILURE() << states.size() << " target states at frame " << seq - cache_->firstSeq() << ", not 1";
        continue;
      }
      const PlanarTargetState& s = states[0];
      const FrameTruth::Target& t = truth_[seq - cache_->firstSeq()].targets.at(0);
      e.corners.push_back(cornerRms(s.corners, t.corners));
      e.not_tracked += s.status != TargetStatus::kTracked;
      if (std::getenv("IMT_TEST_TRACE"))  // per-frame trace for tuning
        std::printf("%lu err %.2f cc %.3f pts %d st %d conf %.2f\n", (unsigned long)seq,
                    e.corners.back(), s.correlation, s.points, (int)s.status, s.confidence);
      const Eigen::AngleAxisd dR(t.T_cam_target.linear().transpose() * s.T_cam_target.linear());
      e.rot_deg.push_back(std::abs(dR.angle()) * 180 / M_PI);
      e.trans_rel.push_back((s.T_cam_target.translation() - t.T_cam_target.translation()).norm() /
                            t.T_cam_target.translation().norm());
    }
    std::printf(
        "%s: alignment error median %.3f p95 %.3f last %.3f px; rotation median %.3f deg; "
        "translation median %.3f%%\n",
        model.c_str(), percentile(e.corners, 0.5), percentile(e.corners, 0.95), e.corners.back(),
        percentile(e.rot_deg, 0.5), 100 * percentile(e.trans_rel, 0.5));
    return e;
  }

  static SceneGenerator* scene_;
  static MotionCache* cache_;
  static std::vector<FrameTruth> truth_;
};

SceneGenerator* PosterOrbit::scene_ = nullptr;
MotionCache* PosterOrbit::cache_ = nullptr;
std::vector<FrameTruth> PosterOrbit::truth_;

// The perspective model with the appearance alignment (refine: true): the
// features carry the pose from frame to frame, the alignment of the
// placement-time template removes what their drift would add up to.
TEST_F(PosterOrbit, RigidPoseMeetsThePotTargetsWithoutDrift) {
  ASSERT_EQ(truth_.size(), 600u);
  const Errors e = track("perspective");
  ASSERT_EQ(e.corners.size(), 599u);  // every frame after the first scored
  // The bars: alignment median <= 0.5 px, p95 <= 1.5 px, last frame
  // <= 1.0 px (no drift); rotation median <= 0.5 deg; translation median <= 1%.
  EXPECT_LE(percentile(e.corners, 0.5), 0.5);
  EXPECT_LE(percentile(e.corners, 0.95), 1.5);
  EXPECT_LE(e.corners.back(), 1.0);
  EXPECT_LE(percentile(e.rot_deg, 0.5), 0.5);
  EXPECT_LE(percentile(e.trans_rel, 0.5), 0.01);
  // In plain view every frame is placed by its evidence, none predicted.
  EXPECT_EQ(e.not_tracked, 0);
}

TEST_F(PosterOrbit, ChainedHomographyMeasuredForComparison) {
  const Errors h = track("homography");
  ASSERT_EQ(h.corners.size(), 599u);
  // Reported for the comparison table (measured 3.2 px median, 7.5 px on the
  // last frame: the chained model's skew drift). The bound only says it keeps
  // the poster; a broken option would lose it (tens of px).
  EXPECT_LT(percentile(h.corners, 0.5), 10.0);
}

// A textured card (0.30 x 0.35 m, 0.2 m in front of the poster) slides across
// the poster and back while the camera orbits (the first 6 s of
// poster_orbit). On the way there it covers up to ~40% of the poster, on the
// way back (the camera closer, more parallax) up to ~80%; features on it move
// unlike the poster's. The tracker must neither follow the card nor lose the
// poster, and be back on it once the card has left.
struct OccludedRun {
  double median = 0, partly = 0, mostly = 0, after = 0, most_covered = 0;
  int predicted = 0, predicted_uncovered = 0;  // frames with status `predicted`: all, uncovered
};

OccludedRun trackOccludedPoster(uint64_t seed) {
  OccludedRun run;
  auto opt = SceneOptions::fromPreset("poster_orbit");
  EXPECT_TRUE(opt);
  if (!opt) return run;
  opt->duration = 6.0;
  opt->seed = seed;  // textures and sensor noise
  const ScenePlane* poster = nullptr;
  for (const ScenePlane& p : opt->planes)
    if (p.kind == ScenePlane::Kind::kTarget) poster = &p;
  EXPECT_TRUE(poster);
  if (!poster) return run;
  ScenePlane card;
  card.kind = ScenePlane::Kind::kCard;
  card.id = 2;
  card.width_m = 0.30;
  card.height_m = 0.35;
  card.T_world_plane = poster->T_world_plane;
  card.T_world_plane.translation().y() -= 0.2;  // in front: toward the camera
  card.texture_seed = 77;
  card.motion = "slide";  // x: A sin(wt - pi/2): from the left, across and back
  card.motion_amplitude = 0.65;
  card.motion_period = 6.0;
  card.motion_phase = -M_PI / 2;
  opt->planes.push_back(card);
  std::string err;
  auto scene = SceneGenerator::create(*opt, &err);
  EXPECT_TRUE(scene) << err;
  if (!scene) return run;

  std::vector<double> errors;
  std::vector<double> covered;  // occluded fraction of the poster per frame (truth)
  trackRendered(*scene, 0,
                [&](int i, const FrameTruth::Target& t, const PlanarTargetState& s, double e) {
                  errors.push_back(e);
                  covered.push_back(t.occluded_fraction);
                  if (s.status == TargetStatus::kPredicted) {
                    ++run.predicted;
                    run.predicted_uncovered += t.occluded_fraction == 0;
                  }
                  if (std::getenv("IMT_TEST_TRACE"))  // per-frame trace for tuning
                    std::printf("%d err %.2f covered %.2f cc %.3f visible %.2f pts %d st %d\n", i,
                                e, t.occluded_fraction, s.correlation, s.visible, s.points,
                                static_cast<int>(s.status));
                });
  if (errors.empty()) return run;
  // Worst error over frames up to 40% covered, more covered, and after the
  // card has left for good (none of the poster covered from then on).
  size_t last_covered = 0;
  for (size_t i = 0; i < errors.size(); ++i) {
    double& worst = covered[i] <= 0.4 ? run.partly : run.mostly;
    worst = std::max(worst, errors[i]);
    run.most_covered = std::max(run.most_covered, covered[i]);
    if (covered[i] > 0) last_covered = i;
  }
  EXPECT_LT(last_covered + 1, errors.size());
  for (size_t i = last_covered + 1; i < errors.size(); ++i)
    run.after = std::max(run.after, errors[i]);
  run.median = percentile(errors, 0.5);
  std::printf(
      "occluded poster, seed %d: up to %.0f%% covered; alignment error median %.3f px, worst %.2f "
      "px up to 40%% covered, %.2f px more covered, %.3f px after the card left; status "
      "predicted on %d frames\n",
      static_cast<int>(seed), 100 * run.most_covered, run.median, run.partly, run.mostly,
      run.after, run.predicted);
  return run;
}

// Issue 15's hard scene (poster_handheld): an A4 page held in view by a
// shaking hand, motion blur, a textured card sweeping across the page and
// back, JPEG frames (quality 80). The goal: every frame within 5 px (P@5 =
// 1.0) and a median of 1 px at most.
TEST(PosterHandheld, ShakeBlurCardAndJpeg) {
  auto opt = SceneOptions::fromPreset("poster_handheld");
  ASSERT_TRUE(opt);
  if (const char* seed = std::getenv("IMT_TEST_SEED")) opt->seed = std::atoi(seed);
  std::string err;
  auto scene = SceneGenerator::create(*opt, &err);
  ASSERT_TRUE(scene) << err;
  std::vector<double> errors, speeds;  // speeds: the page's fastest corner, px/frame (truth)
  double most_covered = 0;
  std::array<cv::Point2d, 4> last_corners = scene->frameTruth(0).targets.at(0).corners;
  trackRendered(
      *scene, 0,
      [&](int i, const FrameTruth::Target& t, const PlanarTargetState& s, double e) {
        errors.push_back(e);
        most_covered = std::max(most_covered, t.occluded_fraction);
        double speed = 0;
        for (int c = 0; c < 4; ++c)
          speed = std::max(speed, cv::norm(t.corners[c] - last_corners[c]));
        speeds.push_back(speed);
        last_corners = t.corners;
        if (std::getenv("IMT_TEST_TRACE"))
          std::printf("%d err %.2f covered %.2f cc %.3f visible %.2f pts %d st %d\n", i, e,
                      t.occluded_fraction, s.correlation, s.visible, s.points,
                      static_cast<int>(s.status));
      },
      80);
  ASSERT_FALSE(errors.empty());
  const double p5 = test::precisionAt(errors, 5.0);
  std::printf(
      "handheld page: corners move %.1f px/frame median, %.1f p95, %.1f fastest; up to %.0f%% "
      "covered; "
      "P@5 %.3f, median %.3f px, p95 %.2f px, worst %.2f px\n",
      percentile(speeds, 0.5), percentile(speeds, 0.95),
      *std::max_element(speeds.begin(), speeds.end()), 100 * most_covered, p5,
      percentile(errors, 0.5), percentile(errors, 0.95),
      *std::max_element(errors.begin(), errors.end()));
  EXPECT_GE(most_covered, 0.4);  // the scene does what it says
  // The goal is P@5 = 1.0 and a median of 1 px. Measured (seeds 1-4):
  // median 0.124-0.130 px, worst 0.31-0.67 px; with a whole-frame exposure
  // (twice the blur) and JPEG quality 50, median 0.45 px and worst 2.2-2.8 px
  // (seeds 1-2). The bars are about three times this scene's figures, for
  // another CPU's rounding: worst 2 px, median 0.4 px.
  EXPECT_EQ(p5, 1.0);
  EXPECT_LE(*std::max_element(errors.begin(), errors.end()), 2.0);
  EXPECT_LE(percentile(errors, 0.5), 0.4);
}

// Over 4 seeds: one run's worst frame is chaotic (where the card's edge
// falls on the poster's texture decides which pixels are taken for it; the
// same seed measured 2.46 px on one CPU and 6.79 px on another), so each
// seed's worst is held to "not dragged" and their mean to the precision.
TEST(PosterOccluded, CardSlidingAcrossThePosterDoesNotDragIt) {
  double partly_sum = 0, mostly_sum = 0;
  int predicted = 0;
  // IMT_TEST_SEEDS=N runs seeds 1..N instead: a change that moves the
  // rounding moves single seeds' worst frames either way, and four seeds'
  // mean does not tell such noise from a real change.
  const char* seeds_env = std::getenv("IMT_TEST_SEEDS");
  const int seeds = seeds_env ? std::max(1, std::atoi(seeds_env)) : 4;
  for (uint64_t seed = 1; seed <= static_cast<uint64_t>(seeds); ++seed) {
    const OccludedRun r = trackOccludedPoster(seed);
    ASSERT_FALSE(HasFatalFailure());
    EXPECT_GE(r.most_covered, 0.7) << "seed " << seed;  // the scene does what it says
    // The card crosses hundreds of px: a poster dragged by it, or lost, is
    // tens of px off (before the local-correlation mask and the affine
    // alignment of a half-covered target, seeds 3-5 went 14-31 px while up
    // to 40% was covered, 14-31 px more covered). Measured worst 0.80 px
    // (seed 3) up to 40% covered, 5.70 px (seed 4) more covered.
    EXPECT_LE(r.partly, 8.0) << "seed " << seed;
    EXPECT_LE(r.mostly, 12.0) << "seed " << seed;
    // Once the card has left the alignment is as precise as without it
    // (poster_orbit: median 0.017 px; measured 0.03-0.06 px).
    EXPECT_LE(r.after, 0.5) << "seed " << seed;
    // The status says when the card took the evidence (features and look)
    // and the camera motion carried the poster: `predicted`, and only then
    // (measured 4 / 4 / 4 / 2 frames on seeds 1-4, at 46-72% covered).
    EXPECT_EQ(r.predicted_uncovered, 0) << "seed " << seed;
    predicted += r.predicted;
    partly_sum += r.partly;
    mostly_sum += r.mostly;
  }
  // Measured means 0.58 px up to 40% covered (seeds 1-4: 0.45, 0.30, 0.80,
  // 0.78) and 3.74 px more covered (2.28, 1.60, 5.38, 5.70; over 32 seeds
  // 0.80 and 4.09); before the few points' gate learnt how far the target
  // usually sits from the camera motion's prediction 0.59 and 4.03 (32
  // seeds: 1.10 and 5.69); with findTransformECC 2.22 (2.87, 1.37,
  // 1.12, 3.50; 6.79 px for seed 1 on another CPU) and 4.86; before the
  // occlusion masks, 6.47 and 14.2. The bar leaves 2.5 times the mean for
  // another CPU's rounding. While four fifths are covered the camera motion
  // and the few features left carry it to within a few px.
  std::printf(
      "occluded poster, seeds 1-%d: mean worst %.2f px up to 40%% covered, %.2f px more covered\n",
      seeds, partly_sum / seeds, mostly_sum / seeds);
  EXPECT_LE(partly_sum / seeds, 1.5);
  EXPECT_LE(mostly_sum / seeds, 7.0);
  EXPECT_GT(predicted, 0);
}

// The camera pans away until the poster is entirely out of view for ~1 s,
// then partly back (the poster_orbit layout under the wall_pan trajectory,
// amplitude 2.5; the poster is given at frame 90, wholly in view): while out
// of view the target is predicted by the camera motion (status out_of_view),
// and once back (at least 40% in view) it is picked up again.
TEST(PosterOutOfView, PredictedWhileOutAndPickedUpAgain) {
  auto opt = SceneOptions::fromPreset("poster_orbit");
  ASSERT_TRUE(opt);
  opt->trajectory = "pan";
  opt->trajectory_amplitude = 2.5;
  opt->duration = 12.0;
  opt->brightness_amplitude = 0;
  std::string err;
  auto scene = SceneGenerator::create(*opt, &err);
  ASSERT_TRUE(scene) << err;
  int out_frames = 0, out_status = 0;
  bool was_out = false;
  std::vector<double> back;  // corner error once back in view
  std::vector<double> out;   // corner error while out of view (predicted)
  ASSERT_EQ(scene->frameTruth(90).targets.at(0).visible_fraction, 1.0);  // given wholly in view
  trackRendered(
      *scene, 90, [&](int i, const FrameTruth::Target& t, const PlanarTargetState& s, double e) {
        if (std::getenv("IMT_TEST_TRACE"))  // per-frame trace for tuning
          std::printf("%d err %.2f visible %.2f st %d cc %.3f pts %d\n", i, e, t.visible_fraction,
                      static_cast<int>(s.status), s.correlation, s.points);
        if (t.visible_fraction == 0) {
          was_out = true;
          ++out_frames;
          out_status += s.status == TargetStatus::kOutOfView;
          out.push_back(e);
        } else if (was_out && t.visible_fraction >= 0.4) {
          back.push_back(e);
        }
      });
  ASSERT_FALSE(HasFatalFailure());
  const double out_worst = out.empty() ? NAN : *std::max_element(out.begin(), out.end());
  std::printf(
      "poster out of view: %d frames out (out_of_view status on %d, predicted %.2f px median, %.2f px at "
      "worst); back in view: median %.2f px, last %.2f px over %zu frames\n",
      out_frames, out_status, out.empty() ? NAN : percentile(out, 0.5), out_worst,
      back.empty() ? NAN : percentile(back, 0.5), back.empty() ? NAN : back.back(), back.size());
  ASSERT_GT(out_frames, 10) << "the scene should take the poster out of view";
  EXPECT_EQ(out_status, out_frames);
  ASSERT_GT(back.size(), 10u) << "and bring it back";
  // Measured: 0.51 px at worst while out (the camera motion's prediction;
  // held to 2 px, the pose's own bar at the 95th percentile in view being
  // 1.5), 0.04 px median once back; 1 px is the drift-free bar for
  // the last frame.
  EXPECT_LE(out_worst, 2.0);
  EXPECT_LE(percentile(back, 0.5), 1.0);
  EXPECT_LE(back.back(), 1.0);
}

// The camera is covered (a hand, a passer-by) for a second while it keeps
// moving: the frames are flat gray, no camera motion is measured, and when
// the view comes back the target is elsewhere (poster_orbit, 124 px away).
// Features alone would take the background's inside the stale quad for the
// target; its look at placement finds it again by its keypoints.
TEST(PosterCovered, CameraBlindForASecondThenFoundAgain) {
  auto opt = SceneOptions::fromPreset("poster_orbit");
  ASSERT_TRUE(opt);
  opt->duration = 10.0;
  std::string err;
  auto scene = SceneGenerator::create(*opt, &err);
  ASSERT_TRUE(scene) << err;
  const int blind_from = 150, blind_frames = 30;
  std::vector<double> after;  // corner error from 0.5 s after the view is back
  int tracked_far = 0;        // frames said `tracked` more than 5 px off
  double jump = 0;
  std::array<cv::Point2d, 4> before_corners{};
  trackRendered(
      *scene, 0,
      [&](int i, const FrameTruth::Target& t, const PlanarTargetState& s, double e) {
        if (i == blind_from - 1) before_corners = t.corners;
        if (i == blind_from + blind_frames)
          for (int c = 0; c < 4; ++c) jump = std::max(jump, cv::norm(t.corners[c] - before_corners[c]));
        if (std::getenv("IMT_TEST_TRACE"))
          std::printf("%d err %.2f st %d cc %.3f pts %d\n", i, e, static_cast<int>(s.status),
                      s.correlation, s.points);
        if (i >= blind_from + blind_frames + 15) after.push_back(e);
        tracked_far += s.status == TargetStatus::kTracked && e > 5;
      },
      0,
      [&](int i, cv::Mat& frame) {
        if (i >= blind_from && i < blind_from + blind_frames) frame.setTo(40);
      });
  ASSERT_FALSE(after.empty());
  std::printf(
      "covered camera: the poster moved %.0f px while blind; from 0.5 s after: median %.2f px, "
      "worst %.2f px, last %.2f px\n",
      jump, percentile(after, 0.5), *std::max_element(after.begin(), after.end()), after.back());
  EXPECT_GT(jump, 50);  // the scene does what it says
  // Measured: found by the search of the first frame back (answered 5
  // frames later), then median 0.01 px, worst 0.02, last 0.02 px (0.18 /
  // 0.28 px while the found target's look was blown up to template_size, as
  // an image target's picture is); before (no search) 62 / 86 / 80 px, with
  // status `tracked`. Found, it is as precise as a tracked target
  // (poster_orbit: median 0.017 px); the bar leaves 10x for another CPU.
  EXPECT_LE(*std::max_element(after.begin(), after.end()), 0.2);
  // Until then it is not said to be tracked: carried by the camera motion
  // (blind, then the features in the stale quad until the look confirms
  // them), it is `predicted`.
  EXPECT_EQ(tracked_far, 0);
}

}  // namespace
}  // namespace imt
