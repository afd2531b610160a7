// Private pieces of the scene generator shared by src/sim/scene*.cpp.
// Not installed; nothing outside the scene generator includes it.
#pragma once

#include "instant_motion_tracking/sim/scene.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace imt {
namespace scene_detail {

// ---- seeds -------------------------------------------------------------------
// SplitMix64 finaliser: a well-mixed 64-bit value from (a, b).
uint64_t mixSeed(uint64_t a, uint64_t b);

// ---- trajectories and plane motion (scene_presets.cpp) -----------------------
constexpr double kWallDistance = 2.5;  // m: wall scenes' wall is the plane y = 2.5
constexpr double kWalkHeight = 1.2;    // m: floor_walk camera height over z = 0

bool knownTrajectory(const std::string& name);
bool knownPlaneMotion(const std::string& name);
// T_world_cam(t) of a named trajectory (unknown name -> identity).
Eigen::Isometry3d trajectoryPose(const std::string& name, double amplitude, double t);
// motion(t) of ScenePlane::motion in the plane's own frame.
Eigen::Isometry3d planeMotion(const ScenePlane& plane, double t);
// Planes and anchors of a preset's layout (false for an unknown name).
bool presetLayout(const std::string& name, SceneOptions* options);

// ---- textures (scene_texture.cpp) --------------------------------------------
// A mip pyramid: level 0 is the texture, each next level half the size (area
// average). Every level carries a `pad`-texel border (wrapped for periodic
// textures, else replicated) so bilinear lookups near the texture's edges and
// tile seams stay in warpPerspective's fast path. Immutable once built.
struct MipTexture {
  std::vector<cv::Mat> levels;  // CV_8UC1, padded
  int pad = 0;
  int width() const { return levels.empty() ? 0 : levels[0].cols - 2 * pad; }  // unpadded level 0
  int height() const { return levels.empty() ? 0 : levels[0].rows - 2 * pad; }
};
MipTexture buildMips(const cv::Mat& texture, bool periodic);
// Procedural texture of any size (the public proceduralTexture is square);
// periodic in both axes when both sides are even multiples of 16.
cv::Mat proceduralTexture(cv::Size size, uint64_t seed);
// Mip pyramid of proceduralTexture(size, seed), shared through a small
// process-wide cache of the most recently used ones (thread-safe).
std::shared_ptr<const MipTexture> proceduralMips(cv::Size size, uint64_t seed, bool periodic);

// ---- rasterisation (scene_render.cpp) ----------------------------------------
// f(u, v) = a u + b v + c; a point is inside when f >= 0.
struct HalfPlane {
  double a = 0, b = 0, c = 0;
  double eval(double u, double v) const { return a * u + b * v + c; }
};
using Polygon = std::vector<Eigen::Vector2d>;

Polygon clipPolygon(const Polygon& poly, const HalfPlane& h);
double polygonArea(const Polygon& poly);
Polygon rectPolygon(double x0, double y0, double x1, double y1);

// A plane as seen by one camera, in the pixel coordinates of some canvas
// (corner convention, scaled by the supersampling factor).
struct PlaneView {
  // Plane metres (X, Y, 1) -> canvas (u z, v z, z), z the depth: G = K [r1 r2 t].
  Eigen::Matrix3d G = Eigen::Matrix3d::Identity();
  // Its inverse: canvas (u, v, 1) -> (X, Y, 1) / z; third component 1 / depth.
  Eigen::Matrix3d Ginv = Eigen::Matrix3d::Identity();
  // In front of the camera and inside the plane's rectangle (<= 5 half-planes).
  std::vector<HalfPlane> bounds;
  double distance = 0;  // m, from the camera centre to the plane
  bool empty = false;   // some bound excludes the whole canvas plane
  Polygon visible;      // canvas rectangle clipped by `bounds` (convex; may be empty)
};
// K: intrinsics already scaled to the canvas; T_cam_plane: the plane's pose.
PlaneView makePlaneView(const Eigen::Matrix3d& K, const Eigen::Isometry3d& T_cam_plane,
                        double width_m, double height_m, int canvas_w, int canvas_h);

// How a plane looks: a mip-mapped texture (null: flat colour), spread over
// the whole plane or repeated every tile_w_m metres along x (and
// tile_w_m * texture height / width along y), from the plane's top-left corner.
struct PlaneLook {
  const MipTexture* texture = nullptr;
  double width_m = 1, height_m = 1;
  double tile_w_m = 0;  // 0: no tiling
  double flat_gray = 128;
};

// Paints one plane into `canvas` (CV_32FC1) with exact edge coverage and a
// trilinear mip lookup of its texture.
void paintPlane(const PlaneView& view, const PlaneLook& look, cv::Mat* canvas);

constexpr double kGravity = 9.81;  // m/s^2

// Painter's order of the planes (backgrounds first, then far to near, fixed
// up where one plane's centre lies on the camera's side of another).
std::vector<size_t> drawOrder(const std::vector<ScenePlane>& planes, const std::vector<Eigen::Isometry3d>& T_cam_plane);

// Where the lens of `k` shows ideal pixel `p` (`field`: the ideal pixels of
// the image's own field, where the lens is one-to-one); see scene.cpp.
cv::Point2d showThroughLens(const CameraModel& k, const cv::Rect& field, const cv::Point2d& p);

}  // namespace scene_detail

// The generator's state (scene.h); shared by scene.cpp and scene_truth.cpp.
struct SceneGenerator::Impl {
  CameraModel K;  // with the lens distortion
  // With distortion: the pinhole view is rendered on `canvas` (ideal pixels,
  // ours, covering the lens's field) and remapped through the lens: image
  // pixel (OpenCV) -> canvas pixel (OpenCV).
  cv::Rect canvas;
  cv::Mat lens_map_x, lens_map_y;  // CV_32FC1, image size
  std::vector<std::shared_ptr<const scene_detail::MipTexture>> textures;  // per plane; null = flat
  int background = -1;  // the single background plane, -1 if none or several
  std::vector<Eigen::Matrix3d> R_world_anchor;  // per anchor, fixed at placement
};

}  // namespace imt
