// Region tracking on the rendered failure-class presets of issue 13 (scene.h:
// region_small, region_follow, region_static_covered, region_midstart,
// region_hidden), each isolating one way region tracking fails on real video.
// The whole pipeline runs as live: a TrackingSession in Mode::kLive with the
// default options analyses each frame; the region is given at its true box
// right after the frame it belongs to was analysed. Frames after it are read
// from the live results, frames up to it (tracked backwards) with
// seekRegions(). Scored by mean IoU (a lost region scores 0) against the
// generator's boxes over the frames where at least half of the target is seen
// (in the image and not covered), the frame the region is given at excluded.
//
// The goal is 0.85 for every class and half. The floors below are
// today's figures less 0.05, so that a regression fails while the tracker is
// being improved; raise them as it improves. The floors hold seed 1; the
// other seeds' figures quoted beside them come from IMT_SEED=N (the scenes'
// seed), and IMT_TEST_TRACE=1 prints the target's state at every frame.
#include "../box_metrics.h"
#include "instant_motion_tracking/core/tracking_session.h"
#include "instant_motion_tracking/sim/scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace imt {
namespace {

using test::iouClipped;

constexpr uint32_t kId = 1;     // the target is plane id 1 in every preset
constexpr double kGoal = 0.85;  // the goal, printed beside each figure

const FrameTruth::Region* region(const FrameTruth& f, uint32_t id) {
  for (const auto& r : f.regions)
    if (r.id == id) return &r;
  return nullptr;
}

// The fraction of the target that is seen: in the image and not covered.
double seenFraction(const FrameTruth& f) {
  const FrameTruth::Region* r = region(f, kId);
  return r ? r->visible_fraction * (1 - r->occluded_fraction) : 0;
}

// The first frame from `from` on where the target is wholly in view and
// uncovered (a box given on a partly seen target stands for only that part),
// -1 when there is none.
int firstWholeFrame(const std::vector<FrameTruth>& truth, int from) {
  for (int k = std::max(0, from); k < static_cast<int>(truth.size()); ++k)
    if (seenFraction(truth[k]) > 0.999) return k;
  return -1;
}

// A preset run through a live session, with the target's state at every frame.
struct Tracked {
  std::unique_ptr<SceneGenerator> scene;
  std::vector<FrameTruth> truth;
  std::vector<std::optional<RegionState>> states;  // per frame; none: not reported
  int start = -1;                                  // the frame the region was given at
  cv::Size size;

  // Mean IoU over frames [from, to) (the start frame excluded) where at
  // least half of the target is seen; *n: how many frames were scored.
  double meanIou(int from, int to, int* n) const {
    double sum = 0;
    *n = 0;
    for (int k = std::max(0, from); k < std::min(to, static_cast<int>(truth.size())); ++k) {
      if (k == start || seenFraction(truth[k]) < 0.5) continue;
      const std::optional<RegionState>& s = states[k];
      if (s && s->status != RegionStatus::kLost)
        sum += iouClipped(s->extent(), region(truth[k], kId)->box, size);
      ++*n;
    }
    return *n ? sum / *n : 0;
  }
};

// Renders preset `name` (seed 1, or IMT_SEED; `seed` when given) through a
// live session and gives the target's true box at the frame `chooseStart`
// picks from the truth, and `other_regions` boxes at random places (a
// twentieth of the image's sides) with it.
Tracked track(const std::string& name,
              const std::function<int(const std::vector<FrameTruth>&)>& chooseStart,
              const RegionTrackerOptions& region_options = RegionTrackerOptions(), int other_regions = 0,
              int seed = 0) {
  Tracked t;
  std::optional<SceneOptions> opt = SceneOptions::fromPreset(name);
  EXPECT_TRUE(opt) << name;
  if (!opt) return t;
  opt->seed = seed > 0 ? seed : std::getenv("IMT_SEED") ? std::atoi(std::getenv("IMT_SEED")) : 1;
  std::string err;
  t.scene = SceneGenerator::create(*opt, &err);
  EXPECT_TRUE(t.scene) << err;
  if (!t.scene) return t;
  const int frames = t.scene->frameCount();
  for (int k = 0; k < frames; ++k) t.truth.push_back(t.scene->frameTruth(k));
  t.start = chooseStart(t.truth);
  EXPECT_GE(t.start, 0) << name;
  if (t.start < 0) return t;
  t.size = cv::Size(opt->width, opt->height);
  t.states.resize(frames);

  PipelineOptions po;  // the defaults, with a cache that holds the whole scene
  po.region_tracking = region_options;
  po.cache_seconds = std::max(po.cache_seconds, opt->duration + 1.0);
  TrackingSession session(po, TrackingSession::Mode::kLive);
  session.setCameraInfo(t.scene->intrinsics());
  // The live results: the target's state at each frame after the start.
  auto takeResults = [&] {
    for (FrameResult& r : session.takeResults()) {
      const int i = static_cast<int>(std::lround((r.motion.stamp - opt->start_time) * opt->fps));
      for (const RegionState& s : r.regions)
        if (s.id == kId && i > t.start && i < frames) t.states[i] = s;
    }
  };
  for (int k = 0; k < frames; ++k) {
    const double stamp = t.scene->frameStamp(k);
    session.analyze(t.scene->renderFrame(k), stamp);
    session.advance();
    takeResults();
    if (k == t.start) {
      uint32_t id = 0;
      EXPECT_TRUE(session.addRegion(kId, stamp, region(t.truth[k], kId)->box, &id, &err)) << err;
      EXPECT_EQ(id, kId);
      cv::RNG rng(3);
      const cv::Size2d b(t.size.width / 20.0, t.size.height / 20.0);
      for (int i = 0; i < other_regions; ++i) {
        const cv::Rect2d box(rng.uniform(0.0, t.size.width - b.width), rng.uniform(0.0, t.size.height - b.height),
                             b.width, b.height);
        EXPECT_TRUE(session.addRegion(0, stamp, box, &id, &err)) << err;
      }
    }
  }
  session.advance(true);
  takeResults();
  // The frames up to the start: tracked backwards through the cache.
  for (int k = 0; k <= t.start; ++k) {
    std::vector<RegionState> s;
    EXPECT_TRUE(session.seekRegions(t.scene->frameStamp(k), {kId}, &s, &err)) << err;
    if (!s.empty()) t.states[k] = s[0];
  }
  // IMT_TEST_TRACE=1: the target's state and truth at every frame, on stdout.
  if (std::getenv("IMT_TEST_TRACE"))
    for (int k = 0; k < frames; ++k)
      if (const auto& s = t.states[k]; s && region(t.truth[k], kId))
        std::printf("%d %s %s turn %.1f app %.2f conf %.2f inliers %zu box %.0fx%.0f extent %.0f %.0f %.0f %.0f truth %.0f %.0f %.0f %.0f seen %.2f\n",
                    k, regionStatusName(s->status), s->reason.c_str(), s->angle * 180 / M_PI, s->appearance_score,
                    s->confidence, s->inliers.size(), s->box.width, s->box.height, s->extent().x, s->extent().y, s->extent().width, s->extent().height,
                    region(t.truth[k], kId)->box.x,
                    region(t.truth[k], kId)->box.y, region(t.truth[k], kId)->box.width,
                    region(t.truth[k], kId)->box.height, seenFraction(t.truth[k]));
  return t;
}

int firstWhole(const std::vector<FrameTruth>& truth) { return firstWholeFrame(truth, 0); }
// The first frame from half way on with the target wholly in view.
int middleWhole(const std::vector<FrameTruth>& truth) {
  return firstWholeFrame(truth, static_cast<int>(truth.size()) / 2);
}

// 1. A small target: ~35 x 85 px at 1280x720 (~9 x 21 px at the 320 px
// analysis width), moving on its own in front of a textured wall while the
// camera pans slowly.
TEST(RegionFailureClass, SmallTargetAt720p) {
  const Tracked t = track("region_small", firstWhole);
  ASSERT_FALSE(t.states.empty());
  const cv::Rect2d b = region(t.truth[t.start], kId)->box;
  int n = 0;
  const double iou = t.meanIou(0, static_cast<int>(t.truth.size()), &n);
  std::printf(
      "region_small: target %.0f x %.0f px at %dx%d, given at frame %d: mean IoU %.3f over %d "
      "frames (goal %.2f)\n",
      b.width, b.height, t.size.width, t.size.height, t.start, iou, n, kGoal);
  EXPECT_GT(n, 200);
  // Measured 0.898 (seeds 2-4: 0.877, 0.879, 0.902) since the motion fit
  // is made again from the inliers alone; 0.903 (0.875, 0.893, 0.900) since the look sizes
  // a region its features carry weakly (RegionTracker::reshapeByLook);
  // 0.893 (0.850, 0.900, 0.900) since a look's window
  // is halved first (numbers' order only); 0.890 (0.850, 0.917, 0.895) since the look takes
  // the box's aspect along (0.905; 0.855, 0.926, 0.918 before: it stretches
  // this thin card a little too far, while boat1 gains 0.05). Since the motion
  // analysis's features weigh 1 / analysis_scale against the region's own
  // (full-resolution) corners: before, one of them at the box's edge,
  // measured at 4 px per analysis px, set the box's scale and shrank it on
  // seed 2 (0.893; 0.755, 0.893, 0.881). Earlier, 0.893 since the region keeps
  // the background features it saw moving with the camera down-weighted
  // while they stay near it (before: 0.861; 0.772, 0.890, 0.791: the curb
  // behind the walker took over its box where the walker turned back).
  // Earlier, the region turning with the camera's roll (before that: 0.837; seeds 2-4 0.746, 0.714, 0.745; 0.836,
  // 0.750, 0.684, 0.711 with its own corners' LK on 3 pyramid levels): the region tracks 6
  // corners of its own inside the small box (region_features), which the
  // motion analysis's uniform grid does not give it. Without them 0.475
  // (0.484, 0.522, 0.596), and 0.101 on motion data alone (the target gets
  // no features, turns featureless and rides the camera motion). Floor 0.05
  // under, at the goal. Goal 0.85, reached on seeds 1-4.
  EXPECT_GE(iou, 0.85);
}

// The same with each region tracking corners of its own (region_features):
// full-resolution features inside the small box.
TEST(RegionFailureClass, SmallTargetAt720pWithOwnFeatures) {
  RegionTrackerOptions o;
  o.region_features = 24;
  const Tracked t = track("region_small", firstWhole, o);
  ASSERT_FALSE(t.states.empty());
  int n = 0;
  const double iou = t.meanIou(0, static_cast<int>(t.truth.size()), &n);
  std::printf("region_small, own features: mean IoU %.3f over %d frames (goal %.2f)\n", iou, n, kGoal);
  EXPECT_GT(n, 200);
  // Measured 0.900 (seeds 2-4: 0.892, 0.906, 0.905) with a look's window
  // halved first; 0.896 (0.889, 0.899, 0.899) with the box's aspect
  // taken along by the look; 0.913 (0.902, 0.918, 0.916) before, with the
  // motion analysis's features weighed by their resolution; 0.909 before
  // that (0.874, 0.927, 0.909; before the background memory 0.900: 0.863,
  // 0.906, 0.899), against 0.893 with the default 6. Not the default: on
  // the real sequences 12 cost Human3 0.035 success AUC (corners on the
  // curb behind the walker's legs), 20 more (docs/benchmarks.md). Floor
  // 0.05 under.
  EXPECT_GE(iou, 0.85);
}

// 2. A target that moves with the camera (a card riding with it, shaking a
// little in the image) while the textured background streams past.
TEST(RegionFailureClass, TargetMovingWithTheCamera) {
  const Tracked t = track("region_follow", firstWhole);
  ASSERT_FALSE(t.states.empty());
  int n = 0;
  const double iou = t.meanIou(0, static_cast<int>(t.truth.size()), &n);
  std::printf("region_follow: given at frame %d: mean IoU %.3f over %d frames (goal %.2f)\n",
              t.start, iou, n, kGoal);
  EXPECT_GT(n, 200);
  // Measured 0.974 (seeds 2-4: 0.973, 0.973, 0.968) since features are
  // weighed by how well their LK windows matched (the road's edge features
  // behind the target no longer stretch its box); floor raised from 0.89.
  // 0.939 (0.950, 0.952, 0.879) since the motion fit is
  // made again from the inliers alone; 0.940 (0.928, 0.949, 0.873; before the background
  // memory 0.923: 0.932, 0.939, 0.880), drifting slowly (IoU 0.98 at
  // 0.7 s, 0.89 at 7 s). Goal 0.85.
  EXPECT_GE(iou, 0.92);
}

// 3. A static wall patch that a moving card partly covers at the init frame
// and then leaves: the region must stay on the patch.
TEST(RegionFailureClass, StaticPatchPartlyCoveredAtInit) {
  const Tracked t =
      track("region_static_covered", [](const std::vector<FrameTruth>&) { return 0; });
  ASSERT_FALSE(t.states.empty());
  const FrameTruth::Region* r0 = region(t.truth[0], kId);
  int uncovered = -1;  // the first frame the card no longer covers the patch
  for (int k = 0; k < static_cast<int>(t.truth.size()) && uncovered < 0; ++k)
    if (region(t.truth[k], kId)->occluded_fraction < 0.001) uncovered = k;
  int n = 0;
  const double iou = t.meanIou(0, static_cast<int>(t.truth.size()), &n);
  std::printf(
      "region_static_covered: %.0f%% of the patch covered at init, uncovered from frame %d: "
      "mean IoU %.3f over %d frames (goal %.2f)\n",
      100 * r0->occluded_fraction, uncovered, iou, n, kGoal);
  EXPECT_GT(n, 150);
  // Measured 0.930 (seeds 2-8: 0.931, 0.938, 0.939, 0.910, 0.926, 0.927,
  // 0.946) since a scale seen only between the motion analysis's two
  // classes is refused (seed 7 followed the card's edge before: the box grew
  // 4% a frame, 0.213; seed 2 0.953 had its box 3% too large from frame 1,
  // which the wall's zoom then caught up with). 0.930 (seeds 2-4: 0.953,
  // 0.938, 0.939) since features are
  // weighed by how well their LK windows matched; 0.932 (0.947, 0.946,
  // 0.952) since the motion fit is made again from the inliers alone; 0.945 (0.954, 0.959, 0.951) before:
  // the region stays on the patch.
  // Goal 0.85.
  EXPECT_GE(iou, 0.88);
}

// 4. A region given at the middle frame, tracked backwards and forwards
// from there: each half is scored on its own.
TEST(RegionFailureClass, GivenMidSequenceBothWays) {
  const Tracked t = track("region_midstart", middleWhole);
  ASSERT_FALSE(t.states.empty());
  int nb = 0, nf = 0;
  const double backward = t.meanIou(0, t.start, &nb);
  const double forward = t.meanIou(t.start + 1, static_cast<int>(t.truth.size()), &nf);
  std::printf(
      "region_midstart: given at frame %d: backward half mean IoU %.3f over %d frames, "
      "forward half %.3f over %d frames (goal %.2f each)\n",
      t.start, backward, nb, forward, nf, kGoal);
  EXPECT_GT(nb, 100);
  EXPECT_GT(nf, 100);
  // Measured backward 0.864, forward 0.873 (seeds 2-4: 0.860 / 0.868,
  // 0.857 / 0.886, 0.859 / 0.828; seeds 5-8 backward 0.860-0.874, forward
  // 0.851-0.907) since a region's fit takes a rotation from 12 inliers, not
  // 20 (seed 4 below). Before: 0.864 / 0.874 (seeds 2-4: 0.863 / 0.869,
  // 0.857 / 0.887, 0.859 / 0.764; seeds 5-8 backward 0.860-0.874, forward
  // 0.849-0.910) since features are weighed by how well their LK windows
  // matched: those straddling the card's edges and the wall it uncovers
  // lagged the card and grew its box (139 -> 164 px over frames 120-90
  // backward against the card's 139 -> 144); floors raised from 0.78 /
  // 0.77.
  // Before: 0.823 / 0.810 (0.829 / 0.811,
  // 0.812 / 0.845, 0.818 / 0.712) since the motion fit is made again from
  // the inliers alone (the wall around the card, fitting it worse, pulled
  // its scale); before 0.817 / 0.800. Earlier 0.817 / 0.796 (seeds 2-4: 0.823 / 0.802,
  // 0.801 / 0.836, 0.813 / 0.708); before the background memory 0.815 /
  // 0.804 (0.816 / 0.807, 0.812 / 0.834, 0.811 / 0.707). Before regions turned: 0.832 / 0.813
  // (0.827 / 0.810, 0.828 / 0.840, 0.826 / 0.716): the card rolls +-15 deg
  // on its own, against the camera's roll, and its region turns with the
  // camera's (the card's own turn shows only to its look, which its tilt
  // spoils). Forward 0.819 when a firmly carried region's look was also
  // matched at 5% either side of its size; on motion data alone 0.832 /
  // 0.802. Floors 0.05 under. Goal 0.85 each.
  EXPECT_GE(backward, 0.81);
  EXPECT_GE(forward, 0.82);
}

// 4b. The card of region_midstart on seed 4, given mid-sequence: forward it
// rolls and tilts while 12-19 features carry it. A fit of shift and scale
// alone (the rotation was taken from 20 inliers) leaves the rolling card's
// features to fit it worse, and the box fell behind it by 7-22 px from
// frame 164 (forward 0.764). With the rotation from 12 inliers the fit
// follows the roll (the region's turn is still the camera's and its
// look's). Seed 1 above does not show this.
TEST(RegionFailureClass, RollingCardGivenMidSequenceForward) {
  const Tracked t = track("region_midstart", middleWhole, RegionTrackerOptions(), 0, /*seed=*/4);
  ASSERT_FALSE(t.states.empty());
  int nf = 0;
  const double forward = t.meanIou(t.start + 1, static_cast<int>(t.truth.size()), &nf);
  std::printf("region_midstart, seed 4: given at frame %d: forward half mean IoU %.3f over %d frames\n", t.start,
              forward, nf);
  EXPECT_GT(nf, 100);
  // Measured 0.827 (0.828 before a scale that a shift of each class of
  // features explains as well was refused); 0.767 with the rotation from 15
  // inliers, 0.764 from 20. Floor 0.03 under, above what 20 gave.
  EXPECT_GE(forward, 0.80);
}

// 4c. The card of region_midstart on seed 10, given mid-sequence: forward it
// tilts away from frame 150 while 13-26 features carry it, and its look's
// score fell from 0.72 to 0.29 in 12 frames, under the 0.6 at which the
// template learned; after 60 checks under 0.3 the region was lost with 26
// inliers (frame 226) and stayed where it was (forward 0.735). A region the
// features carry firmly now teaches its template the views it still half
// recognises. Seed 1 above does not show this.
TEST(RegionFailureClass, TiltingCardGivenMidSequenceForward) {
  const Tracked t = track("region_midstart", middleWhole, RegionTrackerOptions(), 0, /*seed=*/10);
  ASSERT_FALSE(t.states.empty());
  int nf = 0;
  const double forward = t.meanIou(t.start + 1, static_cast<int>(t.truth.size()), &nf);
  int lost = 0;
  for (int k = t.start + 1; k < static_cast<int>(t.states.size()); ++k)
    lost += t.states[k] && t.states[k]->status == RegionStatus::kLost;
  std::printf("region_midstart, seed 10: given at frame %d: forward half mean IoU %.3f over %d frames, %d lost\n",
              t.start, forward, nf, lost);
  EXPECT_GT(nf, 100);
  // Measured 0.835, never lost (the box still lags the card's shrink as it
  // tilts: 123 px over 107 at frame 195). Floor 0.035 under, well above the
  // 0.735 of a region lost at frame 226.
  EXPECT_GE(forward, 0.80);
  EXPECT_EQ(lost, 0);
}

// 5. A target hidden completely (behind an opaque panel) for 2 s and then
// back in view: scored before the hiding, and from 0.5 s after it is wholly
// back in view.
TEST(RegionFailureClass, HiddenFor2sThenBack) {
  const Tracked t = track("region_hidden", firstWhole);
  ASSERT_FALSE(t.states.empty());
  const int frames = static_cast<int>(t.truth.size());
  int hidden_from = -1, hidden_to = -1;  // the hidden frames: [hidden_from, hidden_to)
  for (int k = 0; k < frames; ++k) {
    if (seenFraction(t.truth[k]) < 0.001) {
      if (hidden_from < 0) hidden_from = k;
      hidden_to = k + 1;
    }
  }
  ASSERT_GE(hidden_from, 0) << "the target is never hidden";
  const double fps = t.scene->options().fps;
  const int back = firstWholeFrame(t.truth, hidden_to);
  ASSERT_GE(back, 0) << "the target does not come back";
  const int after = back + static_cast<int>(std::lround(0.5 * fps));
  int nb = 0, na = 0;
  const double before = t.meanIou(0, hidden_from, &nb);
  const double again = t.meanIou(after, frames, &na);
  std::printf(
      "region_hidden: given at frame %d, hidden over frames %d-%d (%.2f s), wholly back at "
      "frame %d: mean IoU before %.3f over %d frames, from 0.5 s after %.3f over %d frames "
      "(goal %.2f each)\n",
      t.start, hidden_from, hidden_to - 1, (hidden_to - hidden_from) / fps, back, before, nb, again,
      na, kGoal);
  // The preset's point: hidden for about 2 s.
  EXPECT_NEAR((hidden_to - hidden_from) / fps, 2.0, 0.2);
  EXPECT_GT(nb, 30);
  EXPECT_GT(na, 30);
  // Seed 1 after 0.922; seeds 4-8 after 0.935 / 0.953 / 0.902 / 0.939 /
  // 0.928 since a region found again is grown by its look at placement
  // where a larger box matches better (0.902 / 0.909 / 0.890 / 0.893 /
  // 0.876 before; seeds 1-3 the same).
  // Measured before 0.897, after 0.913 (seeds 2-4: 0.894 / 0.910, 0.889 /
  // 0.933, 0.884 / 0.903; seeds 5-8 after 0.876-0.905) since features are
  // weighed by how well their LK windows matched and the look at placement
  // is searched for over the whole frame at 1.2 times smaller and larger
  // too, in turn (seed 3 with the weighing alone: after 0.475, the card back
  // 18% smaller than its box found 40 frames late); floors raised from
  // 0.81 / 0.83. Before: 0.879 / 0.864 (0.885 / 0.930, 0.882 /
  // 0.884, 0.889 / 0.904) since the motion fit is made again from the
  // inliers alone. Before 0.865, after 0.878 (seeds 2-4: 0.890 / 0.911, 0.885 /
  // 0.884, 0.890 / 0.920) since the look sizes a region its features carry
  // weakly (seed 2: found again 8% small, at 68 x 53 px against 74 x 61,
  // carried by 10-15 inliers: the look grows it back within a second);
  // floors raised to 0.81 / 0.83 then. Before 0.853, after 0.899 (seeds 2-4: 0.890 / 0.810, 0.875 /
  // 0.811, 0.890 / 0.899) with a look's window halved first (the numbers'
  // order moves when the card is found again); before 0.856, after 0.827
  // (0.887 / 0.809, 0.874 / 0.923, 0.886 / 0.888) with the box's aspect
  // taken along by the look;
  // before 0.854, after 0.818 (0.887 / 0.809, 0.877 / 0.923, 0.886 / 0.889)
  // since the motion analysis's features weigh
  // 1 / analysis_scale and a lost region is also searched at the size its
  // look was last confirmed at. Weighed so, the region grows on the panel
  // covering it (72 x 58 px to 106 x 85, the card 80 x 65) before it is
  // lost, and the search at that size never found it (0.000 on seed 1);
  // at its look's size it is found on the frame it is wholly back, but 7%
  // small, and its scale lags the card's growth after. Before both: 0.847 /
  // 0.864 (0.887 / 0.803, 0.877 / 0.906, 0.886 / 0.853); before the background memory 0.838 / 0.846
  // (0.886 / 0.866, 0.872 / 0.883, 0.882 / 0.843; after 0.841 (0.864, 0.864, 0.831) before the lost
  // searches ran coarse to fine), with regions turning (before: 0.837 / 0.862;
  // 0.879 / 0.887, 0.859 / 0.863, 0.887 / 0.882): found again a few frames
  // later at the turn it had when lost, carried on by the camera's. The
  // region is lost as it goes under (it no
  // longer looks like itself) and found again by its look 6 frames after it
  // is wholly back, at its latest size (the target grew meanwhile: after
  // 0.913 on seed 1 without the region's own features, where the whole-frame
  // search found it 1.1x larger). Before the lost search tried the look at
  // placement and a wider scale range it was found 20 frames later, or never
  // (after 0.743; seeds 2-4: 0.000, 0.504, 0.140). Floors 0.05 under. Goal
  // 0.85 each.
  EXPECT_GE(before, 0.84);
  EXPECT_GE(again, 0.86);
}

// With many regions (region_tracking.appearance_budget, 8 by default) a
// region has its look checked on its turn only, in doubt or not, and a lost
// one searches around its last place on its turns: the cost stays bounded.
// region_hidden among 99 other regions: the target's mean IoU from 0.5 s
// after it is wholly back in view (printed); *n: the frames scored.
double hiddenAmong99Again(const Tracked& t, int* n) {
  const int frames = static_cast<int>(t.truth.size());
  int hidden_to = -1;
  for (int k = 0; k < frames; ++k)
    if (seenFraction(t.truth[k]) < 0.001) hidden_to = k + 1;
  EXPECT_GE(hidden_to, 0) << "the target is never hidden";
  if (hidden_to < 0) return 0;
  const int back = firstWholeFrame(t.truth, hidden_to);
  EXPECT_GE(back, 0) << "the target does not come back";
  if (back < 0) return 0;
  const double again = t.meanIou(back + static_cast<int>(std::lround(0.5 * t.scene->options().fps)), frames, n);
  std::printf("region_hidden among 99 other regions: mean IoU from 0.5 s after it is back %.3f over %d frames\n",
              again, *n);
  return again;
}

// The target among 99 other regions, through the partial cover at init and
// through the 2 s hiding, each held 0.05 under what is measured: nearly as
// well as alone (region_hidden alone is held to 0.86, here to 0.83: found
// again later, those searches come every ceil(100 / 8) = 13 frames).
TEST(RegionFailureClass, TargetAmong99OtherRegions) {
  {
    const Tracked t = track("region_static_covered", [](const std::vector<FrameTruth>&) { return 0; },
                            RegionTrackerOptions(), 99);
    ASSERT_FALSE(t.states.empty());
    int n = 0;
    const double iou = t.meanIou(0, static_cast<int>(t.truth.size()), &n);
    std::printf("region_static_covered among 99 other regions: mean IoU %.3f over %d frames\n", iou, n);
    // Measured 0.930 (seeds 2-4: 0.953, 0.937, 0.939), as alone, since
    // features are weighed by how well their LK windows matched; 0.933
    // (0.947, 0.946, 0.954), as alone (0.932),
    // since the motion fit is made again from the inliers alone; 0.945
    // (0.955, 0.959, 0.951) before;
    // 0.935 while regions in doubt took a look on every frame. Floor 0.05 under.
    EXPECT_GE(iou, 0.89);
  }
  {
    const Tracked t = track("region_hidden", firstWhole, RegionTrackerOptions(), 99);
    ASSERT_FALSE(t.states.empty());
    int n = 0;
    const double again = hiddenAmong99Again(t, &n);
    // Seeds 6-8 0.880 / 0.916 / 0.925 (0.799 / 0.834 / 0.789 before) since a
    // region found again is grown by its look at placement where a larger
    // box matches better; seeds 1-5 the same (0.888, 0.902, 0.910, 0.927,
    // 0.968).
    // Measured 0.888 (seeds 2-4: 0.902, 0.907, 0.927; seeds 5-8 0.965,
    // 0.799, 0.834, 0.788 against 0.816, 0.709, 0.747, 0.784 before) since
    // features are weighed by how well their LK windows matched and the look
    // at placement is searched for at 1.2 times smaller and larger too;
    // floor raised to 0.83 then. 0.865 (0.940, 0.940, 0.919) since the motion fit
    // is made again from the inliers alone; floor raised to 0.81 then.
    // 0.851 (0.811, 0.938, 0.838) with a look's window
    // halved first; 0.855 (0.805, 0.937, 0.831; alone 0.818, 0.809,
    // 0.923, 0.889) since the motion analysis's features weigh 1 /
    // analysis_scale and the lost search tries the look's size too; 0.842
    // (0.797, 0.932, 0.804) before. 0.796 (0.924, 0.867, 0.805) before the background
    // memory, 0.788 (0.930, 0.871, 0.809) before live = offline with many
    // regions: found later than alone on seeds 1, 2 and 4. While a region
    // in doubt took a look on every frame: 0.753 (0.887, 0.572, 0.864). With
    // its patience before `lost` read as 20 checks rather than 20 frames, it
    // waited 13 times as long before searching (0.479). Before a
    // region took new corners only on the frames its look was checked, its
    // stale score let it take corners on the panel coming over it, and it
    // rode the panel (0.561); with the searches around its last place also
    // on turns only after the first 10 frames lost, never found (0.000).
    // Floor 0.05 under.
    EXPECT_GE(again, 0.83);
  }
}

// Found again while still partly out from behind the panel, the card
// matched a box 10% smaller than itself best (seed 8: 71 x 56 px against 75
// x 61), and 10-14 inliers then carried that size for the rest of the run:
// with 99 other regions its look is checked every 13 frames, and the look
// sizes only a region its features carry weakly. For 30 frames after it is
// found its look at placement grows it where a larger box matches better
// (RegionTracker::checkFoundSize).
TEST(RegionFailureClass, HiddenAmong99OthersFoundAtItsSize) {
  const Tracked t = track("region_hidden", firstWhole, RegionTrackerOptions(), 99, /*seed=*/8);
  ASSERT_FALSE(t.states.empty());
  int n = 0;
  const double again = hiddenAmong99Again(t, &n);
  EXPECT_GT(n, 30);
  // Measured 0.880 since each region keeps a correlation filter and the
  // filter moves a region only where its template did not (2026-11-29,
  // third session; 0.907 before it, 0.923 with the filter moving it first),
  // 0.925 when the found size was first checked, 0.789 before. Floor: the
  // presets' goal (0.85), well above 0.789.
  EXPECT_GE(again, 0.85);
}

}  // namespace
}  // namespace imt
