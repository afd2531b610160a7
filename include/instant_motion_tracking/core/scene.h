// Seeded synthetic scene generator: textured planes under a known 6DoF camera
// trajectory, with an IMU stream and exact per-frame ground truth.
//
// Usage:
//   imt::SceneOptions opt;             // or imt::SceneOptions::preset("cards")
//   opt.seed = 7;
//   std::string err;
//   auto scene = imt::SceneGenerator::create(opt, &err);   // nullptr + err on bad options
//   for (int i = 0; i < scene->frameCount(); ++i) {
//     cv::Mat img = scene->renderFrame(i);          // CV_8UC1, width x height
//     imt::FrameTruth gt = scene->frameTruth(i);
//   }
//   std::vector<imt::ImuSample> imu = scene->imuSamples();
//
// Conventions (docs/conventions.md): world frame z up (gravity -z); camera
// optical frame z forward, x right, y down; pixel coordinates have their
// origin at the top-left corner of the top-left pixel (pixel (0,0) covers
// [0,1)x[0,1)). `T_a_b` maps points of frame b into frame a.
//
// Threading: a SceneGenerator is immutable after create(); renderFrame() and
// frameTruth() are const and may be called from several threads.
#pragma once

#include "instant_motion_tracking/core/types.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <array>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace imt {

// A textured rectangle in the world (a wall, floor, card, poster or patch).
struct ScenePlane {
  enum class Kind { kBackground, kCard, kFeatureless, kTarget };
  Kind kind = Kind::kBackground;
  uint32_t id = 0;             // region / target id in the ground truth (0 = not reported)
  double width_m = 1.0;        // extent along the plane's x axis
  double height_m = 1.0;       // extent along the plane's y axis
  // Pose of the plane at time t (s from the scene start): T_world_plane. The
  // plane's origin is its centre; x along the texture's rows (left -> right),
  // y along its columns (top -> bottom), z = x cross y (away from a viewer
  // who sees the textured front). Static planes keep `motion` empty.
  Eigen::Isometry3d T_world_plane = Eigen::Isometry3d::Identity();
  // Optional rigid motion: T_world_plane(t) = T_world_plane * motion(t).
  std::string motion;          // "" | "slide" | "slide_rotate" | "approach" (card presets)
  double motion_amplitude = 0.3;  // m (slide/approach) scale of the motion
  double motion_period = 4.0;     // s
  int texture_seed = 0;        // procedural texture seed (ignored when texture_file is set)
  std::string texture_file;    // image file used as texture (gray), empty = procedural
  double flat_gray = 128;      // colour of a kFeatureless plane (0..255)
};

// A point the ground truth reports as an anchor (paper 3.4).
struct SceneAnchor {
  uint32_t id = 1;
  Eigen::Vector3d p_world = Eigen::Vector3d::Zero();  // anchor point (m)
  double placed_at = 0.0;                             // s from the scene start
};

// Everything that defines a scene. Presets fill these; every field can be
// overridden afterwards (duration, resolution, seed, noise, ...).
struct SceneOptions {
  std::string preset = "wall_pan";  // wall_pan | poster_orbit | cards | floor_walk | featureless_wall
  double duration = 10.0;           // s
  double fps = 30.0;                // frames per second
  int width = 640;                  // px
  int height = 480;                 // px
  double hfov_deg = 60.0;           // horizontal field of view (sets fx = fy)
  uint64_t seed = 1;                // every random choice derives from it
  double start_time = 1000.0;       // stamp of the first frame (s)
  int supersample = 3;              // anti-aliasing: render at N x N samples per pixel
  double noise_sigma = 2.0;         // sensor noise, grey levels (0..255 scale)
  double brightness_amplitude = 0.15;  // relative gain change (sinusoid over the scene)
  double brightness_period = 6.0;      // s
  double exposure = 0.0;            // s; > 0 enables motion blur (sub-frame averaging)
  int blur_samples = 5;             // sub-frames averaged when exposure > 0
  double imu_rate = 200.0;          // Hz
  double gyro_noise = 0.0005;       // rad/s per sample (white, std)
  double accel_noise = 0.01;        // m/s^2 per sample (white, std)
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();  // rad/s, constant
  // Rotation of the IMU frame relative to the camera optical frame (R_cam_imu).
  Eigen::Quaterniond q_cam_imu = Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  std::vector<std::string> texture_files;  // if set, backgrounds/cards use these images in turn

  // Filled by a preset (or by hand): the planes, anchors and the trajectory.
  std::vector<ScenePlane> planes;
  std::vector<SceneAnchor> anchors;
  std::string trajectory = "pan";   // pan | orbit | walk | still | rotate | zoom (see scene.cpp)
  double trajectory_amplitude = 1.0;  // scales the trajectory's motion

  // A preset's full options; unknown name -> std::nullopt.
  static std::optional<SceneOptions> fromPreset(const std::string& name);
  static std::vector<std::string> presetNames();
  // Empty when usable, else a message naming the bad field.
  std::string validate() const;
};

// Ground truth for one frame. Pixel quantities use the convention above.
struct FrameTruth {
  int index = 0;
  double stamp = 0;                     // s
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  // Background homography previous -> current frame (H(2,2) = 1); set when
  // the background is a single plane and this is not the first frame.
  std::optional<Eigen::Matrix3d> background_homography;
  struct Region {
    uint32_t id = 0;
    cv::Rect2d box;                     // bounding box of the projected plane, clipped to the image
    cv::Rect2d box_unclipped;           // the same before clipping (may lie outside)
    double visible_fraction = 0;        // of the unclipped box area inside the image
    bool featureless = false;
  };
  std::vector<Region> regions;          // one per plane with id != 0 and kind != kTarget
  struct Target {
    uint32_t id = 0;
    std::array<cv::Point2d, 4> corners; // TL, TR, BR, BL projections
    Eigen::Isometry3d T_cam_target;     // spec pose: origin centre, x TL->TR, y TL->BL
    double width_m = 0, height_m = 0;
  };
  std::vector<Target> targets;
  struct Anchor {
    uint32_t id = 0;
    cv::Point2d pixel;                  // projection (also when outside the image)
    bool in_view = false;               // in front of the camera and inside the image
    bool placed = false;                // stamp >= placement time
    Eigen::Isometry3d T_cam_anchor;     // spec anchor frame in the camera optical frame
  };
  std::vector<Anchor> anchors;
};

// Renders a scene and produces its IMU stream and ground truth.
class SceneGenerator {
 public:
  static std::unique_ptr<SceneGenerator> create(const SceneOptions& options, std::string* error);

  const SceneOptions& options() const { return options_; }
  int frameCount() const;
  double frameStamp(int i) const;
  CameraIntrinsics intrinsics() const;
  Eigen::Isometry3d T_world_cam(double t) const;  // t: s from the scene start

  cv::Mat renderFrame(int i) const;           // CV_8UC1
  FrameTruth frameTruth(int i) const;
  std::vector<ImuSample> imuSamples() const;  // imu_rate samples covering the whole scene, in imu frame

 private:
  explicit SceneGenerator(const SceneOptions& options);
  SceneOptions options_;
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

// Procedural texture with detail at all scales (octaves of smoothed noise plus
// random strokes for corners), deterministic in `seed`. CV_8UC1, size x size.
cv::Mat proceduralTexture(int size, uint64_t seed);

}  // namespace imt
