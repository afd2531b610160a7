// Synthetic motion data with exact ground truth for region-tracking tests: a
// textured background seen by a moving camera (a chain of homographies),
// objects with their own motion in front of it, features with persistent IDs
// that vanish when they leave the image or are covered.
#pragma once

#include "instant_motion_tracking/core/types.h"
#include "../box_metrics.h"

#include <opencv2/core.hpp>

#include <functional>
#include <random>
#include <vector>

namespace imt {
namespace synthetic {

const cv::Size kImage(640, 480);

using test::iou;

inline Eigen::Vector2d applyH(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
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
    std::vector<int> frames(n);
    for (int k = 0; k < n; ++k) frames[k] = k;
    return motionData(frames, seed);
  }
  // Motion data of the given frames only (increasing): the others are
  // dropped, each motion describes the step from the previous frame given.
  std::vector<MotionData> motionData(const std::vector<int>& frames, uint32_t seed = 1) const {
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
    for (size_t i_frame = 0; i_frame < frames.size(); ++i_frame) {
      const int k = frames[i_frame];
      const Eigen::Matrix3d H = camera(k);
      const Eigen::Matrix3d H_step = i_frame == 0 ? Eigen::Matrix3d(Eigen::Matrix3d::Identity())
                                                  : Eigen::Matrix3d(H * camera(frames[i_frame - 1]).inverse());
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

inline std::vector<Eigen::Vector2d> randomPoints(int n, double w, double h, uint32_t seed, bool centred) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> ux(centred ? -w / 2 : 0, centred ? w / 2 : w);
  std::uniform_real_distribution<double> uy(centred ? -h / 2 : 0, centred ? h / 2 : h);
  std::vector<Eigen::Vector2d> p(n);
  for (auto& q : p) q = {ux(rng), uy(rng)};
  return p;
}

// A pan with a slow zoom and roll: a few px per frame.
inline Eigen::Matrix3d panCamera(int k) {
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

inline World makeWorld() {
  World w;
  // Background texture wider than the view so panning keeps it covered.
  for (auto& p : randomPoints(2500, 1600, 1000, 11, false)) w.background.push_back(p - Eigen::Vector2d(400, 250));
  w.camera = panCamera;
  return w;
}

}  // namespace synthetic
}  // namespace imt
