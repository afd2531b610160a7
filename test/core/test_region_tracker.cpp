// Region tracker on synthetic motion data with exact ground truth: a textured
// background seen by a moving camera (a chain of homographies), objects with
// their own motion in front of it, features with persistent IDs that vanish
// when they leave the image or are covered. No pixels are involved: the
// tracker only ever sees motion data.
#include "instant_motion_tracking/core/region/region_tracker.h"

#include "synthetic_motion.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <functional>
#include <random>

namespace imt {
namespace {

using namespace synthetic;

struct Track {
  std::vector<RegionState> states;
};

Track trackForward(const std::vector<MotionData>& md, const cv::Rect2d& box, int from) {
  RegionTracker t(RegionTrackerOptions(), kImage);
  Track tr;
  RegionState s = RegionState::start(1, box, md[from].stamp);
  tr.states.push_back(s);
  for (size_t k = from + 1; k < md.size(); ++k) {
    s = t.step(s, md[k], Direction::kForward);
    tr.states.push_back(s);
  }
  return tr;
}

TEST(RegionTracker, MovingCardInFrontOfAMovingBackground) {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(60, 120, 90, 5, true);
  card.half_size = {60, 45};
  card.centre = [](int k) { return Eigen::Vector2d(250 + 3.0 * k, 200 + 40 * std::sin(k / 15.0)); };
  card.scale = [](int k) { return 1.0 + 0.004 * k; };  // grows 24% over 60 frames
  w.objects.push_back(card);
  const auto md = w.motionData(60);
  const Track tr = trackForward(md, w.box(0, 0), 0);
  double sum = 0;
  for (int k = 0; k < 60; ++k) {
    EXPECT_EQ(tr.states[k].status, RegionStatus::kTracked) << "frame " << k;
    sum += iou(tr.states[k].extent(), w.box(0, k));
  }
  // Measured ~0.97; 0.9 leaves room for the synthetic 0.1 px noise and the
  // axis-aligned box of a slightly rotating card.
  EXPECT_GT(sum / 60, 0.9);
  EXPECT_GT(iou(tr.states.back().extent(), w.box(0, 59)), 0.85) << "drifted by the end";
  std::printf("card growing 24%%: confidence at the end %.3f\n", tr.states.back().confidence);
  // Carried by all of its 60 features to the end: measured 1.000.
  EXPECT_GT(tr.states.back().confidence, 0.9);
}

TEST(RegionTracker, StaticWallPatchFollowsTheCamera) {
  World w = makeWorld();
  const auto md = w.motionData(60);
  const cv::Rect2d world_box(300, 150, 100, 80);
  const Track tr = trackForward(md, w.backgroundBox(world_box, 0), 0);
  double sum = 0;
  for (int k = 0; k < 60; ++k) {
    sum += iou(tr.states[k].extent(), w.backgroundBox(world_box, k));
  }
  EXPECT_GT(sum / 60, 0.9);  // the background fit is exact up to 0.1 px noise
}

TEST(RegionTracker, FeaturelessPatchMovesWithTheCamera) {
  World w = makeWorld();
  // A flat patch: no background features inside it (erase them).
  const cv::Rect2d world_box(250, 180, 90, 70);
  std::vector<Eigen::Vector2d> kept;
  for (const auto& p : w.background)
    if (!world_box.contains(cv::Point2d(p.x(), p.y()))) kept.push_back(p);
  w.background = kept;
  const auto md = w.motionData(60);
  const Track tr = trackForward(md, w.backgroundBox(world_box, 0), 0);
  double sum = 0;
  for (int k = 1; k < 60; ++k) {
    EXPECT_EQ(tr.states[k].status, RegionStatus::kFeatureless) << "frame " << k;
    sum += iou(tr.states[k].extent(), w.backgroundBox(world_box, k));
  }
  // Moved by the exact camera homography; the ground truth is the bounding
  // box of the patch as it rolls (3.4 degrees by the end) while the tracked
  // box stays axis-aligned: measured 0.94, which that alone explains.
  EXPECT_GT(sum / 59, 0.92);
}

TEST(RegionTracker, BackwardTrackingFromTheLastFrame) {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(60, 120, 90, 6, true);
  card.half_size = {60, 45};
  card.centre = [](int k) { return Eigen::Vector2d(200 + 2.5 * k, 260 - 1.5 * k); };
  card.scale = [](int k) { return 1.2 - 0.003 * k; };
  w.objects.push_back(card);
  const auto md = w.motionData(60);
  RegionTracker t(RegionTrackerOptions(), kImage);
  RegionState s = RegionState::start(1, w.box(0, 59), md[59].stamp);
  double sum = 0;
  for (int k = 59; k > 0; --k) {
    s = t.step(s, md[k], Direction::kBackward, md[k - 1].stamp);
    EXPECT_DOUBLE_EQ(s.stamp, md[k - 1].stamp);
    EXPECT_EQ(s.status, RegionStatus::kTracked) << "frame " << k - 1;
    sum += iou(s.extent(), w.box(0, k - 1));
  }
  const double first = iou(s.extent(), w.box(0, 0));
  std::printf("backward: mean IoU %.3f, at frame 0 %.3f\n", sum / 59, first);
  // Measured 0.943 on average and 0.881 at frame 0, where the card is
  // largest and the box's scale, followed from its smallest, lags most
  // (failure class 4: backward no worse than the 0.85 anywhere).
  EXPECT_GT(sum / 59, 0.9);
  EXPECT_GT(first, 0.85) << "drifted by frame 0";
}

TEST(RegionTracker, OcclusionByAnotherCardDoesNotDragTheRegion) {
  World w = makeWorld();
  Object target, occluder;
  target.points = randomPoints(60, 110, 90, 7, true);
  target.half_size = {55, 45};
  target.centre = [](int k) { return Eigen::Vector2d(300 + 1.0 * k, 240); };
  target.scale = [](int) { return 1.0; };
  occluder.points = randomPoints(80, 130, 130, 8, true);
  occluder.half_size = {65, 65};
  // Sweeps across the target from left to right in front of it, ~1 s.
  occluder.centre = [](int k) { return Eigen::Vector2d(60 + 9.0 * k, 250); };
  occluder.scale = [](int) { return 1.0; };
  w.objects = {target, occluder};
  const auto md = w.motionData(75);
  const Track tr = trackForward(md, w.box(0, 0), 0);
  double sum = 0, worst_covered = 1;
  for (int k = 0; k < 75; ++k) {
    const double v = iou(tr.states[k].extent(), w.box(0, k));
    sum += v;
    if ((w.box(0, k) & w.box(1, k)).area() > 0) worst_covered = std::min(worst_covered, v);
  }
  const double end = iou(tr.states.back().extent(), w.box(0, 74));
  std::printf("occluded: mean IoU %.3f, worst while covered %.3f, at the end %.3f\n", sum / 75, worst_covered, end);
  // Measured: 0.930 on average, 0.909 at worst while the occluder covers
  // part of the target, 0.878 at the end. A region the occluder drags
  // (9 px a frame faster than the target) falls under 0.5 within a few
  // frames: each bar is the measure less about 0.03, the 0.85 where
  // it is higher.
  EXPECT_GT(sum / 75, 0.9);
  EXPECT_GT(worst_covered, 0.87) << "dragged while covered";
  EXPECT_GT(end, 0.85) << "not recovered after the occluder passed";
}

// A card swinging to and fro in front of a panning wall, its box drawn with
// a margin of wall around it (as round a turned card, or by a hurried hand).
// Each time the card turns back it moves with the wall for a few frames, and
// the wall's features in the margin fit it as well as its own: they must not
// become its support and pull it back with the wall.
TEST(RegionTracker, SwingingCardIsNotPulledBackByTheWallInItsBox) {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(24, 100, 80, 9, true);
  card.half_size = {50, 40};
  card.centre = [](int k) { return Eigen::Vector2d(330 + 60 * std::sin(2 * M_PI * k / 40), 250); };
  card.scale = [](int) { return 1.0; };
  w.objects.push_back(card);
  const int n = 120;  // three swings
  const auto md = w.motionData(n);
  const cv::Rect2d b = w.box(0, 0);
  const cv::Rect2d drawn(b.x - 0.3 * b.width, b.y - 0.3 * b.height, 1.6 * b.width, 1.6 * b.height);
  const Track tr = trackForward(md, drawn, 0);
  double sum = 0, worst = 0;
  for (int k = 1; k < n; ++k) {
    const cv::Rect2d& s = tr.states[k].extent();
    const cv::Rect2d t = w.box(0, k);
    const double e = std::hypot(s.x + s.width / 2 - (t.x + t.width / 2), s.y + s.height / 2 - (t.y + t.height / 2));
    EXPECT_EQ(tr.states[k].status, RegionStatus::kTracked) << "frame " << k;
    sum += e;
    worst = std::max(worst, e);
  }
  std::printf("swinging card, box drawn 1.6x: centre error mean %.2f px, worst %.2f px\n", sum / (n - 1), worst);
  // Measured 1.27 px mean (1.52 worst). Without the background memory the
  // wall took the box: 24.4 px mean, 127 px worst. 3 px leaves room for the
  // synthetic noise and the drawn box's own centre.
  EXPECT_LT(sum / (n - 1), 3.0);
}

// A card growing in front of the wall, moving little against it (as a
// card does where it turns back): its box's scale is the card's, not pulled
// toward the wall's by the wall's features in its search area (they fit the
// card's motion worse, are not its inliers, and the motion is fitted again
// to the inliers alone).
TEST(RegionTracker, GrowingCardTakesItsOwnScaleNotTheWalls) {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(12, 100, 80, 21, true);
  card.half_size = {50, 40};
  card.centre = [](int k) { return Eigen::Vector2d(320 + 0.5 * k, 240); };
  card.scale = [](int k) { return 1.0 + 0.008 * k; };  // grows 40% over 50 frames
  w.objects.push_back(card);
  const int n = 50;
  const auto md = w.motionData(n);
  const Track tr = trackForward(md, w.box(0, 0), 0);
  double sum = 0, worst = 0;
  for (int k = 1; k < n; ++k) {
    // The card's own width in the frame (the camera zooms and rolls: the
    // axis-aligned box around the card is wider than it by the roll).
    const Eigen::Matrix3d H = w.camera(k);
    const double zoom = std::sqrt(std::abs(H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0)));
    const double e = std::abs(tr.states[k].box.width / (2 * card.half_size.x() * card.scale(k) * zoom) - 1);
    EXPECT_EQ(tr.states[k].status, RegionStatus::kTracked) << "frame " << k;
    sum += e;
    worst = std::max(worst, e);
  }
  std::printf("growing card: box width off by %.2f%% mean, %.2f%% worst\n", 100 * sum / (n - 1), 100 * worst);
  // Measured 0.10% mean, 0.24% worst; 1.23% and 1.96% with the motion
  // fitted to every feature of its search area only (through their IRLS
  // weights). Bars at about four times the measured, half the other.
  EXPECT_LT(sum / (n - 1), 0.005);
  EXPECT_LT(worst, 0.01);
}

// Features whose LK windows straddle a card's trailing edge and the wall
// it uncovers lag the card (here they keep 60% of its motion against the
// wall) and match worse than its own (patch error 3 against 1): weighed by
// how well they matched, they do not stretch its box toward the wall. With
// the errors unknown (0) they do.
TEST(RegionTracker, EdgeFeaturesThatMatchWorseDoNotStretchTheBox) {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(24, 100, 80, 9, true);
  card.half_size = {50, 40};
  card.centre = [](int k) { return Eigen::Vector2d(200 + 3.0 * k, 250); };  // 3 px/frame against the wall
  card.scale = [](int) { return 1.0; };
  w.objects.push_back(card);
  const int n = 60;
  std::vector<MotionData> md = w.motionData(n);
  // Its own features match well; eight more along its left (trailing)
  // edge, 3 px inside it, lag it.
  for (int k = 0; k < n; ++k) {
    for (FeatureMotion& f : md[k].features) f.patch_error = 1.0f;
    for (int j = 0; j < 8; ++j) {
      const auto at = [&](int frame) {
        return applyH(w.camera(k), card.centre(frame) + Eigen::Vector2d(-card.half_size.x() + 3,
                                                                        -35 + 10 * j));
      };
      const Eigen::Vector2d p = at(k), lag = 0.6 * (p - at(k - 1));
      FeatureMotion f;
      f.id = 100000 + j;
      f.age = static_cast<uint16_t>(k);
      f.x = static_cast<float>(p.x());
      f.y = static_cast<float>(p.y());
      f.dx = k > 0 ? static_cast<float>(lag.x()) : 0.f;
      f.dy = k > 0 ? static_cast<float>(lag.y()) : 0.f;
      f.patch_error = 3.0f;
      md[k].features.push_back(f);
    }
  }
  std::vector<MotionData> unknown = md;
  for (MotionData& m : unknown)
    for (FeatureMotion& f : m.features) f.patch_error = 0;
  // The box's width against the card's (the camera zooms and rolls).
  const auto widthError = [&](const Track& tr) {
    double sum = 0;
    for (int k = 1; k < n; ++k) {
      const Eigen::Matrix3d H = w.camera(k);
      const double zoom = std::sqrt(std::abs(H(0, 0) * H(1, 1) - H(0, 1) * H(1, 0)));
      EXPECT_EQ(tr.states[k].status, RegionStatus::kTracked) << "frame " << k;
      sum += std::abs(tr.states[k].box.width / (2 * card.half_size.x() * zoom) - 1);
    }
    return sum / (n - 1);
  };
  const double weighed = widthError(trackForward(md, w.box(0, 0), 0));
  const double unweighed = widthError(trackForward(unknown, w.box(0, 0), 0));
  // Errors given by hand that are no errors (NaN, infinite, negative) read
  // as unknown: the track is the unweighed one, not a broken fit.
  std::vector<MotionData> bad = unknown;
  const float nonsense[] = {NAN, INFINITY, -1.0f};
  for (MotionData& m : bad)
    for (size_t i = 0; i < m.features.size(); ++i) m.features[i].patch_error = nonsense[i % 3];
  EXPECT_DOUBLE_EQ(widthError(trackForward(bad, w.box(0, 0), 0)), unweighed);
  std::printf("card with lagging edge features: box width off by %.2f%% mean, %.2f%% with their errors unknown\n",
              100 * weighed, 100 * unweighed);
  // Measured 2.02% weighed, 10.71% with the errors unknown (as every
  // feature was weighed before). The bar at twice the weighed figure, and
  // the weighing must remove at least half of what the lag does unweighed.
  EXPECT_LT(weighed, 0.04);
  EXPECT_LT(weighed, 0.5 * unweighed);
}

// A wall patch a textured card partly covers when the region is given, the
// card sliding off it (region_static_covered, seed 7): the wall's features
// stay on one side of the box, the card's move on the other, and a scale fit
// explains both within the inlier threshold as the patch growing ~4% a
// frame. The motion analysis tells the two classes apart (the card's
// features are foreground): the scale is seen only between them, not within
// either, and the region keeps to the wall. Without the classes (every
// feature background, as an older publisher's or a hand-made message's
// default) it has nothing to tell them by.
TEST(RegionTracker, CardSlidingOffAWallPatchDoesNotStretchIt) {
  // The features as the preset's frame 1 has them (a still camera): seven
  // on the wall in the patch's left two thirds, six on the card over its
  // right third; the rest of the wall's features are outside the patch.
  World w = makeWorld();
  w.camera = [](int) { return Eigen::Matrix3d(Eigen::Matrix3d::Identity()); };
  const cv::Rect2d patch(199, 242, 116, 93);
  std::vector<Eigen::Vector2d> wall;
  for (const Eigen::Vector2d& p : w.background)
    if (!patch.contains(cv::Point2d(p.x(), p.y()))) wall.push_back(p);
  for (const auto& p : {Eigen::Vector2d(203, 243), Eigen::Vector2d(215, 275), Eigen::Vector2d(225, 289),
                        Eigen::Vector2d(229, 315), Eigen::Vector2d(251, 289), Eigen::Vector2d(201, 333),
                        Eigen::Vector2d(235, 331)})
    wall.push_back(p);
  w.background = wall;
  Object card;
  card.half_size = {70, 55};
  const Eigen::Vector2d c0(345, 290);  // its left edge at x = 275
  for (const auto& p : {Eigen::Vector2d(277, 287), Eigen::Vector2d(287, 297), Eigen::Vector2d(297, 325),
                        Eigen::Vector2d(309, 255), Eigen::Vector2d(313, 293), Eigen::Vector2d(313, 309)})
    card.points.push_back(p - c0);
  for (const Eigen::Vector2d& p : randomPoints(30, 140, 110, 17, true))
    if (!patch.contains(cv::Point2d(c0.x() + p.x(), c0.y() + p.y()))) card.points.push_back(p);
  card.centre = [c0](int k) { return Eigen::Vector2d(c0.x() + 3.6 * k, c0.y() + 1.5 * k); };
  card.scale = [](int) { return 1.0; };
  w.objects.push_back(card);
  const int n = 40;
  std::vector<MotionData> md = w.motionData(n);
  for (int k = 0; k < n; ++k)
    for (FeatureMotion& f : md[k].features)
      if (w.box(0, k).contains(cv::Point2d(f.x, f.y))) f.bg_weight = 0;
  std::vector<MotionData> unknown = md;
  for (MotionData& m : unknown)
    for (FeatureMotion& f : m.features) f.bg_weight = 1;
  const auto meanIou = [&](const Track& tr, double* width) {
    double sum = 0;
    for (int k = 1; k < n; ++k) sum += iou(tr.states[k].extent(), patch);
    *width = tr.states.back().box.width / patch.width;
    return sum / (n - 1);
  };
  double width = 0, width_unknown = 0;
  const double classes = meanIou(trackForward(md, patch, 0), &width);
  const double without = meanIou(trackForward(unknown, patch, 0), &width_unknown);
  std::printf("card sliding off a wall patch: mean IoU %.3f (last width x%.2f), %.3f (x%.2f) without the classes\n",
              classes, width, without, width_unknown);
  // Measured 0.975 (its width x1.00 at the end); without the classes, and
  // with them before they were used, 0.834 (x1.10: the box grows toward the
  // card for the first frames). The bars sit between the two with room for
  // the synthetic noise, and the classes must make the difference (else the
  // scene no longer mixes the two motions and tests nothing).
  EXPECT_GT(classes, 0.93);
  EXPECT_NEAR(width, 1.0, 0.03);
  EXPECT_GT(classes - without, 0.05);
}

// Background weights given by hand that are no numbers (NaN, infinite: a
// malformed motion_data message) read as the motion analysis's "background"
// (1), the weight it gives when it has nothing to compare with, and others
// are clamped into 0..1: a wall patch seen by a zooming camera is tracked as
// with every weight 1, not thrown off by a zoom raised to an infinite power
// (its box was NaN before).
TEST(RegionTracker, NonsenseBackgroundWeightsReadAsBackground) {
  World w = makeWorld();
  const cv::Rect2d world_box(300, 150, 100, 80);
  // Fewer features than a scale needs (a translation fit): the patch takes
  // the camera's zoom as far as its inliers are background.
  std::vector<Eigen::Vector2d> sparse;
  int inside = 0;
  for (const Eigen::Vector2d& p : w.background)
    if (!world_box.contains(cv::Point2d(p.x(), p.y())) || inside++ < 4) sparse.push_back(p);
  w.background = sparse;
  const std::vector<MotionData> md = w.motionData(60);
  std::vector<MotionData> bad = md;
  // Each reads as 1 (7 clamped into 0..1; a negative one would read as 0).
  const float nonsense[] = {NAN, INFINITY, -INFINITY, 7.0f};
  for (MotionData& m : bad)
    for (size_t i = 0; i < m.features.size(); ++i) m.features[i].bg_weight = nonsense[i % 4];
  const Track good = trackForward(md, w.backgroundBox(world_box, 0), 0);
  const Track odd = trackForward(bad, w.backgroundBox(world_box, 0), 0);
  double sum = 0;
  for (int k = 1; k < 60; ++k) {
    const cv::Rect2d& g = good.states[k].box;
    const cv::Rect2d& o = odd.states[k].box;
    EXPECT_TRUE(std::isfinite(o.x) && std::isfinite(o.y) && std::isfinite(o.width) && std::isfinite(o.height))
        << "frame " << k;
    EXPECT_NEAR(o.x, g.x, 1e-6) << "frame " << k;
    EXPECT_NEAR(o.width, g.width, 1e-6) << "frame " << k;
    sum += iou(odd.states[k].extent(), w.backgroundBox(world_box, k));
  }
  std::printf("wall patch, nonsense background weights: mean IoU %.3f\n", sum / 59);
  // The same track as with every weight 1, which follows the patch: measured
  // 0.947 (the box stays axis-aligned while the patch rolls, as in
  // FeaturelessPatchMovesWithTheCamera).
  EXPECT_GT(sum / 59, 0.9);
}

// Frames dropped upstream (a loaded graph): the steps span 2 to 6 frames.
// The region follows a fast card through them, and its velocities stay per
// usual frame interval, so the frame after a gap is predicted right too.
TEST(RegionTracker, DroppedFramesKeepTheTrackAndThePerFrameVelocity) {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(60, 120, 90, 5, true);
  card.half_size = {60, 45};
  card.centre = [](int k) { return Eigen::Vector2d(150 + 8.0 * k, 200); };  // 8 px/frame
  card.scale = [](int) { return 1.0; };
  w.objects.push_back(card);
  std::vector<int> frames;
  for (int k = 0; k < 60; ++k)
    if (!(k >= 10 && k < 12) && !(k >= 25 && k < 29) && !(k >= 40 && k < 46)) frames.push_back(k);
  const auto md = w.motionData(frames);
  const Track tr = trackForward(md, w.box(0, 0), 0);
  double sum = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    EXPECT_EQ(tr.states[i].status, RegionStatus::kTracked) << "frame " << frames[i];
    sum += iou(tr.states[i].extent(), w.box(0, frames[i]));
    // The box centre's true motion per frame (camera pan and zoom + the
    // card's 8 px); without the interval scaling it reads 3x-7x that after
    // each gap. 0.5 px: the velocity is smoothed over frames (velocity_blend)
    // while the zoom makes the true one grow.
    const cv::Rect2d a = w.box(0, frames[i]), b = w.box(0, frames[i] - 1);
    const double truth_vx = (a.x + a.width / 2) - (b.x + b.width / 2);
    if (i > 5) {
      EXPECT_NEAR(tr.states[i].velocity.x(), truth_vx, 0.5) << "frame " << frames[i];
    }
  }
  // Same bar as without gaps (measured ~0.97).
  EXPECT_GT(sum / frames.size(), 0.9);
  EXPECT_GT(iou(tr.states.back().extent(), w.box(0, 59)), 0.85);
}

// A card that vanishes under a featureless occluder (no features at all
// in its box for a while) keeps moving on its own velocity instead of
// stopping dead with the background, and is picked up again behind it.
TEST(RegionTracker, CardWithNoFeaturesLeftCoastsOnItsOwnMotion) {
  World w = makeWorld();
  Object card, cover;
  card.points = randomPoints(60, 120, 90, 5, true);
  card.half_size = {60, 45};
  card.centre = [](int k) { return Eigen::Vector2d(150 + 5.0 * k, 240); };
  card.scale = [](int) { return 1.0; };
  cover.textured = false;  // e.g. a blank sheet, or motion blur: no features
  cover.half_size = {90, 80};
  // Drops onto the card's path at frame 20 for 8 frames, then is gone.
  cover.centre = [](int k) {
    return k >= 20 && k < 28 ? Eigen::Vector2d(150 + 5.0 * 24, 240) : Eigen::Vector2d(-5000, -5000);
  };
  cover.scale = [](int) { return 1.0; };
  w.objects = {card, cover};
  const auto md = w.motionData(50);
  const Track tr = trackForward(md, w.box(0, 0), 0);
  for (int k = 20; k < 28; ++k) {
    // Coasting: still "tracked" (the occlusion path), within a few px of the
    // truth (constant velocity, the decay only reaches the confidence).
    EXPECT_EQ(tr.states[k].status, RegionStatus::kTracked) << "frame " << k;
    EXPECT_GT(iou(tr.states[k].extent(), w.box(0, k)), 0.85) << "frame " << k;
  }
  double sum = 0;
  for (int k = 28; k < 50; ++k) sum += iou(tr.states[k].extent(), w.box(0, k));
  EXPECT_GT(sum / 22, 0.9) << "not picked up again behind the cover";
}

// A card the camera follows as it moves forward (a car followed by a car):
// the background grows by 2% a frame while the card keeps its size in the
// image. Covered by a featureless sheet for 8 frames, the card coasts: its
// size goes on as it was (its own scale rate), not as the background's.
TEST(RegionTracker, CoastingCardKeepsItsOwnSizeWhileTheBackgroundGrows) {
  World w = makeWorld();
  const double zoom = 1.02;
  w.camera = [zoom](int k) {
    const double s = std::pow(zoom, k);
    Eigen::Matrix3d H;  // zoom about the image centre
    H << s, 0, 320 * (1 - s), 0, s, 240 * (1 - s), 0, 0, 1;
    return H;
  };
  Object card, cover;
  card.points = randomPoints(60, 120, 90, 5, true);
  card.half_size = {60, 45};
  // Drifting slowly right in the image, at a constant image size.
  card.centre = [zoom](int k) {
    const double s = std::pow(zoom, k);
    return Eigen::Vector2d(320 + (-100 + 2.0 * k) / s, 240);
  };
  card.scale = [zoom](int k) { return 1.0 / std::pow(zoom, k); };
  cover.textured = false;
  cover.half_size = {90, 80};
  cover.centre = [zoom](int k) {
    return k >= 20 && k < 28 ? Eigen::Vector2d(320 + (-100 + 2.0 * 24) / std::pow(zoom, k), 240)
                             : Eigen::Vector2d(-5000, -5000);
  };
  cover.scale = [zoom](int k) { return 1.0 / std::pow(zoom, k); };
  w.objects = {card, cover};
  const auto md = w.motionData(40);
  const Track tr = trackForward(md, w.box(0, 0), 0);
  for (int k = 20; k < 28; ++k) {
    ASSERT_EQ(tr.states[k].status, RegionStatus::kTracked) << "frame " << k;
    // Within 3% of the card's width: by the background's zoom it would be
    // 1.02^8 = 17% too wide by the end.
    EXPECT_NEAR(tr.states[k].box.width / w.box(0, k).width, 1.0, 0.03) << "frame " << k;
  }
}

// A card that grew 2% a frame for the first 12 frames (coming closer) and
// then stopped, just as a featureless sheet covered it for 30 frames.
// Coasting, the region's size goes on at its last scale rate, but that rate
// fades: what was measured before the features went is no measure of the
// next second.
TEST(RegionTracker, CoastingCardsScaleRateFades) {
  World w = makeWorld();
  Object card, cover;
  card.points = randomPoints(60, 120, 90, 5, true);
  card.half_size = {60, 45};
  card.centre = [](int) { return Eigen::Vector2d(320, 240); };
  card.scale = [](int k) { return 0.8 * std::pow(1.02, std::min(k, 12)); };
  cover.textured = false;
  cover.half_size = {100, 80};
  cover.centre = [](int k) { return k >= 12 && k < 42 ? Eigen::Vector2d(320, 240) : Eigen::Vector2d(-5000, -5000); };
  cover.scale = [](int) { return 1.0; };
  w.objects = {card, cover};
  const auto md = w.motionData(42);
  const Track tr = trackForward(md, w.box(0, 0), 0);
  // Carried by its features while it grew: within 3% of its width then.
  EXPECT_NEAR(tr.states[11].box.width / w.box(0, 11).width, 1.0, 0.03);
  for (int k = 12; k < 42; ++k) ASSERT_EQ(tr.states[k].status, RegionStatus::kTracked) << "frame " << k;
  // After 30 frames unseen. Kept up, a rate of about 2% a frame would make
  // it 1.02^30 = 1.8 times as wide; fading by 0.9 a frame, at most
  // 0.02 / 0.1 = 20% more (measured: x1.108; x1.729 without the fade).
  const double ratio = tr.states[41].box.width / w.box(0, 41).width;
  std::printf("coasting card after 30 frames: width x%.3f the card's\n", ratio);
  EXPECT_LT(ratio, 1.25);
  EXPECT_GT(ratio, 0.97);
}

TEST(RegionTracker, OutOfViewAndBack) {
  World w;
  for (auto& p : randomPoints(4000, 2400, 1000, 12, false)) w.background.push_back(p - Eigen::Vector2d(800, 250));
  // Pan right by 8 px/frame for 40 frames, then back.
  w.camera = [](int k) {
    const double x = k < 40 ? 8.0 * k : 8.0 * (80 - k);
    Eigen::Matrix3d H = Eigen::Matrix3d::Identity();
    H(0, 2) = -x;
    return H;
  };
  const auto md = w.motionData(80);
  const cv::Rect2d world_box(60, 200, 80, 60);
  const Track tr = trackForward(md, w.backgroundBox(world_box, 0), 0);
  bool was_out = false;
  for (int k = 0; k < 80; ++k) {
    const cv::Rect2d gt = w.backgroundBox(world_box, k);
    if (gt.br().x < 0) {
      EXPECT_EQ(tr.states[k].status, RegionStatus::kOutOfView) << "frame " << k;
      was_out = true;
    }
    EXPECT_NE(tr.states[k].status, RegionStatus::kLost) << "frame " << k << " " << tr.states[k].reason;
    // Predicted even while out of view: within a few px of the truth.
    EXPECT_LT(std::abs(tr.states[k].box.x - gt.x), 3.0) << "frame " << k;
  }
  EXPECT_TRUE(was_out);
  EXPECT_EQ(tr.states.back().status, RegionStatus::kTracked);
  EXPECT_GT(iou(tr.states.back().extent(), w.backgroundBox(world_box, 79)), 0.9);
}

TEST(RegionTracker, InvalidCameraModelAndEmptyMotionDataDoNotBreakIt) {
  RegionTracker t(RegionTrackerOptions(), kImage);
  RegionState s = RegionState::start(3, cv::Rect2d(100, 100, 50, 50), 1.0);
  MotionData md;
  md.stamp = 2.0;
  md.camera.model = MotionModel::kInvalid;
  md.camera.H(0, 0) = NAN;
  s = t.step(s, md, Direction::kForward);
  EXPECT_EQ(s.status, RegionStatus::kFeatureless);
  EXPECT_NEAR(s.box.x, 100, 1e-9);
  EXPECT_DOUBLE_EQ(s.stamp, 2.0);
}

}  // namespace
}  // namespace imt

namespace imt {
namespace {

// Cropping by binary search over x-sorted features must not change results.
TEST(RegionTracker, SortedCropGivesTheSameTrackAsAFullScan) {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(60, 120, 90, 9, true);
  card.half_size = {60, 45};
  card.centre = [](int k) { return Eigen::Vector2d(300 - 4.0 * k, 220 + 2.0 * k); };
  card.scale = [](int) { return 1.0; };
  w.objects.push_back(card);
  auto md = w.motionData(40);
  const Track plain = trackForward(md, w.box(0, 0), 0);
  for (auto& m : md) m.sortByX();
  const Track sorted = trackForward(md, w.box(0, 0), 0);
  for (size_t k = 0; k < plain.states.size(); ++k) {
    EXPECT_NEAR(plain.states[k].box.x, sorted.states[k].box.x, 1e-6) << k;
    EXPECT_NEAR(plain.states[k].box.width, sorted.states[k].box.width, 1e-6) << k;
  }
}

}  // namespace
}  // namespace imt

namespace imt {
namespace {

// The inlier extent (3.3 sigma of the inliers) matches the card's size: a
// uniform spread over w has sigma w / sqrt(12), so 3.3 sigma ~ 0.95 w.
TEST(RegionTracker, InlierCentroidAndExtentDescribeTheSupport) {
  World w = makeWorld();
  Object card;
  card.points = randomPoints(150, 120, 90, 21, true);
  card.half_size = {60, 45};
  card.centre = [](int k) { return Eigen::Vector2d(320 + 2.0 * k, 240); };
  card.scale = [](int) { return 1.0; };
  w.objects.push_back(card);
  const auto md = w.motionData(10);
  const Track tr = trackForward(md, w.box(0, 0), 0);
  const RegionState& s = tr.states.back();
  const cv::Rect2d gt = w.box(0, 9);
  EXPECT_NEAR(s.inlier_centroid.x, gt.x + gt.width / 2, 6.0);  // random points: centroid within ~1 sigma/sqrt(n) * few
  EXPECT_NEAR(s.inlier_centroid.y, gt.y + gt.height / 2, 6.0);
  EXPECT_NEAR(s.inlier_extent.width, 0.95 * gt.width, 0.15 * gt.width);
  EXPECT_NEAR(s.inlier_extent.height, 0.95 * gt.height, 0.15 * gt.height);
}

}  // namespace
}  // namespace imt
