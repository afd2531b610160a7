// Region tracker on synthetic motion data with exact ground truth: a textured
// background seen by a moving camera (a chain of homographies), objects with
// their own motion in front of it, features with persistent IDs that vanish
// when they leave the image or are covered. No pixels are involved: the
// tracker only ever sees motion data.
#include "instant_motion_tracking/core/region_tracker.h"

#include <gtest/gtest.h>

#include <functional>
#include <random>

namespace imt {
namespace {

const cv::Size kImage(640, 480);

double iou(const cv::Rect2d& a, const cv::Rect2d& b) {
  const double i = (a & b).area();
  const double u = a.area() + b.area() - i;
  return u > 0 ? i / u : 0;
}

Eigen::Vector2d applyH(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  return (H * p.homogeneous()).hnormalized();
}

// An object: points in its own coordinates (centred), placed in background
// ("world" = frame-0 pixel) coordinates by centre(k) and scale(k).
struct Object {
  std::vector<Eigen::Vector2d> points;
  Eigen::Vector2d half_size;
  std::function<Eigen::Vector2d(int)> centre;
  std::function<double(int)> scale;
  bool textured = true;
};

struct World {
  std::vector<Eigen::Vector2d> background;      // world points
  std::vector<Object> objects;                  // drawn in order: later ones in front
  std::function<Eigen::Matrix3d(int)> camera;   // world -> frame k pixels
  double noise = 0.1;                           // px, feature localisation noise

  // Axis-aligned box of object j in frame k (projection of its corners).
  cv::Rect2d box(size_t j, int k) const {
    const Object& o = objects[j];
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (int sx : {-1, 1})
      for (int sy : {-1, 1}) {
        const Eigen::Vector2d w =
            o.centre(k) + o.scale(k) * Eigen::Vector2d(sx * o.half_size.x(), sy * o.half_size.y());
        const Eigen::Vector2d p = applyH(camera(k), w);
        x0 = std::min(x0, p.x());
        y0 = std::min(y0, p.y());
        x1 = std::max(x1, p.x());
        y1 = std::max(y1, p.y());
      }
    return cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
  }
  cv::Rect2d backgroundBox(const cv::Rect2d& world_box, int k) const {
    double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
    for (double x : {world_box.x, world_box.br().x})
      for (double y : {world_box.y, world_box.br().y}) {
        const Eigen::Vector2d p = applyH(camera(k), {x, y});
        x0 = std::min(x0, p.x());
        y0 = std::min(y0, p.y());
        x1 = std::max(x1, p.x());
        y1 = std::max(y1, p.y());
      }
    return cv::Rect2d(x0, y0, x1 - x0, y1 - y0);
  }

  // Motion data of frames 0..n-1. A point keeps its ID while it stays
  // visible; it gets a new one when it reappears (as a real tracker would).
  std::vector<MotionData> motionData(int n, uint32_t seed = 1) const {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise_d(0, noise);
    // Every point: (owner, index); owner -1 = background.
    std::vector<std::pair<int, int>> pts;
    for (size_t i = 0; i < background.size(); ++i) pts.emplace_back(-1, i);
    for (size_t j = 0; j < objects.size(); ++j)
      if (objects[j].textured)
        for (size_t i = 0; i < objects[j].points.size(); ++i) pts.emplace_back(j, i);
    std::vector<uint32_t> ids(pts.size(), 0);
    std::vector<uint16_t> age(pts.size(), 0);
    std::vector<Eigen::Vector2d> last(pts.size());
    uint32_t next_id = 1;
    std::vector<MotionData> out;
    for (int k = 0; k < n; ++k) {
      const Eigen::Matrix3d H = camera(k);
      const Eigen::Matrix3d H_step = k == 0 ? Eigen::Matrix3d(Eigen::Matrix3d::Identity()) : Eigen::Matrix3d(H * camera(k - 1).inverse());
      MotionData md;
      md.stamp = 1000.0 + k / 30.0;
      md.width = kImage.width;
      md.height = kImage.height;
      md.camera.model = MotionModel::kHomography;
      md.camera.H = H_step / H_step(2, 2);
      for (size_t i = 0; i < pts.size(); ++i) {
        const auto [owner, idx] = pts[i];
        Eigen::Vector2d w = owner < 0 ? background[idx]
                                      : objects[owner].centre(k) + objects[owner].scale(k) * objects[owner].points[idx];
        Eigen::Vector2d p = applyH(H, w);
        bool visible = p.x() >= 0 && p.y() >= 0 && p.x() < kImage.width && p.y() < kImage.height;
        // Covered by an object in front of it?
        for (size_t j = owner < 0 ? 0 : owner + 1; visible && j < objects.size(); ++j)
          visible = !box(j, k).contains(cv::Point2d(p.x(), p.y()));
        if (!visible) {
          ids[i] = 0;
          continue;
        }
        p += Eigen::Vector2d(noise_d(rng), noise_d(rng));
        FeatureMotion f;
        if (ids[i] == 0) {
          ids[i] = next_id++;
          age[i] = 0;
        } else {
          ++age[i];
          const Eigen::Vector2d d = p - applyH(md.camera.H, last[i]);
          f.dx = d.x();
          f.dy = d.y();
        }
        last[i] = p;
        f.id = ids[i];
        f.age = age[i];
        f.x = p.x();
        f.y = p.y();
        md.features.push_back(f);
      }
      out.push_back(md);
    }
    return out;
  }
};

std::vector<Eigen::Vector2d> randomPoints(int n, double w, double h, uint32_t seed, bool centred) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(centred ? -w / 2 : 0, centred ? w / 2 : w);
  std::uniform_real_distribution<double> uy(centred ? -h / 2 : 0, centred ? h / 2 : h);
  std::vector<Eigen::Vector2d> p(n);
  for (auto& q : p) q = {ux(rng), uy(rng)};
  return p;
}

// A pan with a slow zoom and roll: a few px per frame.
Eigen::Matrix3d panCamera(int k) {
  const double s = 1.0 + 0.002 * k, a = 0.001 * k;
  Eigen::Matrix3d H;
  H << s * std::cos(a), -s * std::sin(a), -2.0 * k, s * std::sin(a), s * std::cos(a), 0.5 * k, 0, 0, 1;
  // about the image centre
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity(), Ti = Eigen::Matrix3d::Identity();
  T(0, 2) = 320;
  T(1, 2) = 240;
  Ti(0, 2) = -320;
  Ti(1, 2) = -240;
  return T * H * Ti;
}

World makeWorld() {
  World w;
  // Background texture wider than the view so panning keeps it covered.
  for (auto& p : randomPoints(2500, 1600, 1000, 11, false)) w.background.push_back(p - Eigen::Vector2d(400, 250));
  w.camera = panCamera;
  return w;
}

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
    sum += iou(tr.states[k].box, w.box(0, k));
  }
  // Measured ~0.97; 0.9 leaves room for the synthetic 0.1 px noise and the
  // axis-aligned box of a slightly rotating card.
  EXPECT_GT(sum / 60, 0.9);
  EXPECT_GT(iou(tr.states.back().box, w.box(0, 59)), 0.85) << "drifted by the end";
  EXPECT_GT(tr.states.back().confidence, 0.9);
}

TEST(RegionTracker, StaticWallPatchFollowsTheCamera) {
  World w = makeWorld();
  const auto md = w.motionData(60);
  const cv::Rect2d world_box(300, 150, 100, 80);
  const Track tr = trackForward(md, w.backgroundBox(world_box, 0), 0);
  double sum = 0;
  for (int k = 0; k < 60; ++k) {
    sum += iou(tr.states[k].box, w.backgroundBox(world_box, k));
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
    sum += iou(tr.states[k].box, w.backgroundBox(world_box, k));
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
    sum += iou(s.box, w.box(0, k - 1));
  }
  EXPECT_GT(sum / 59, 0.9);
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
  double sum = 0;
  for (int k = 0; k < 75; ++k) {
    sum += iou(tr.states[k].box, w.box(0, k));
  }
  EXPECT_GT(sum / 75, 0.8);
  EXPECT_GT(iou(tr.states.back().box, w.box(0, 74)), 0.75) << "not recovered after the occluder passed";
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
  EXPECT_GT(iou(tr.states.back().box, w.backgroundBox(world_box, 79)), 0.9);
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
