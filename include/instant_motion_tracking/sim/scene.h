// Seeded synthetic scene generator: textured planes under a known 6DoF camera
// trajectory, with an IMU stream and exact per-frame ground truth.
//
// Usage:
//   auto opt = imt::SceneOptions::fromPreset("cards");   // std::nullopt for an unknown name
//   opt->seed = 7;                                       // any field may be overridden
//   std::string err;
//   auto scene = imt::SceneGenerator::create(*opt, &err);  // nullptr + err on bad options
//   for (int i = 0; i < scene->frameCount(); ++i) {
//     cv::Mat img = scene->renderFrame(i);          // CV_8UC1, width x height
//     imt::FrameTruth gt = scene->frameTruth(i);
//   }
//   std::vector<imt::ImuSample> imu = scene->imuSamples();
//
// A default-constructed SceneOptions is the `wall_pan` preset except that
// `planes` is empty; create() fills empty `planes` (and `anchors`) from the
// layout of `preset`, so `SceneOptions opt; opt.seed = 3;` is a valid scene.
// (`preset` names only the layout; validate() insists on the preset's own
// `trajectory` then. Use fromPreset() for a preset's full options.)
//
// Presets (fromPreset; all seeded: textures, sensor and IMU noise derive from
// `seed`, the trajectories are fixed curves). Walls are 10 x 7.5 m (14 x 9 m
// for poster_orbit and region_follow) and fill every frame; figures are at
// 640x480 (region_small: 1280x720), hfov 60.
//   wall_pan      textured wall 2.5 m ahead; camera pans, yaws, rolls and moves
//                 toward/away (zoom): 2-5 px/frame (mean 3.5). One background
//                 plane -> background_homography in every frame. 10 s.
//   cards         the wall + 3 independently moving textured cards covering up
//                 to ~28% of the frame: card 1 ("slide", 0.8 m in front of the
//                 wall) sweeps across the upper half and back every 5 s, in
//                 front of card 2 ("slide_rotate", 0.5 m) -> card 2 is
//                 occluded for 1.0-1.3 s per pass (occluded_fraction);
//                 card 3 ("approach") grows x1.3 in the lower half. On the wall:
//                 a static textured patch (id 4) and a featureless patch (id 5).
//                 Camera as wall_pan at 0.6 amplitude. 10 s.
//   poster_orbit  a 0.60 x 0.45 m poster (planar target id 1, own texture) on a
//                 textured wall; the camera orbits it: viewing angle up to
//                 51 deg, roll +-30 deg, distance 0.8..2.4 m (scale x3),
//                 brightness +-25%; the poster is always >= 94% in view.
//                 20 s (600 frames at 30 fps).
//   poster_handheld  issue 15's hard scene: an A4 page (0.297 x 0.21 m,
//                 planar target id 1) on a textured wall, a phone held
//                 0.43..0.67 m from it with the hand's tremor ("handheld"),
//                 motion blur of a 1/60 s exposure, and a textured card
//                 (id 2) 0.2 m in front of the page sweeping across it and
//                 back (from the left, +-0.25 m over 6 s). 10 s.
//   floor_walk    camera 1.2 m above a 12 x 20 m textured floor (extending
//                 10 m behind the start), walking forward at 0.15 m/s,
//                 pitching (-22 +- 10 deg) and rolling; anchor id 1 on the
//                 floor near the image centre, placed at t = 0; from t = 3 s
//                 the camera yaws 50 deg away and back (4.5 s), so the anchor
//                 is out of view for 2.1 s (up to 14 px/frame). At times the
//                 horizon is in view (above it: void_gray). The floor is one
//                 plane -> background_homography. 12 s.
//   planar        the wall only, general 6DoF motion with out-of-plane viewing
//                 angles to ~30 deg (clear perspective in the homography).
//   rotate        the wall only, pure camera rotation about its centre
//                 (background_homography = K R K^-1).
//   still         the wall only, camera at rest, no brightness change (frames
//                 differ by sensor noise; the IMU reads gravity only).
//   featureless_wall  a flat-coloured wall under the wall_pan trajectory (no
//                 texture anywhere: motion estimation must report failure).
// Region-tracking failure classes (issue 13; test_region_failure_classes.cpp):
// each isolates one way region tracking fails on real video, with the target
// as region id 1. Motion blur of a 1/60 s exposure (exposure, blur_samples).
//   region_small  1280x720: a 6.6 x 16 cm card (~35 x 85 px; ~9 x 21 px at a
//                 320 px analysis width) 0.4 m in front of the wall, sliding
//                 about at up to ~3 px/frame (of 1280) while the camera pans
//                 slowly (pan at 0.4). 8 s.
//   region_follow a 25 x 20 cm card 1 m ahead of the camera rides with it
//                 ("follow_camera": +-17 px and +-4.5% scale of shake in the
//                 image) while the camera dollies along a 14 x 9 m wall at
//                 0.75 m/s (the wall streams past at ~5.5 px/frame) with
//                 vehicle shake ("dolly"). 8 s.
//   region_static_covered  a static textured patch on the wall (1); card 2,
//                 0.5 m in front of the wall, covers 36% of it at t = 0 and
//                 has left it at 0.4 s (moving off at ~3.5 px/frame), not to
//                 come back. Pan at 0.4. 6 s.
//   region_midstart  a card 0.6 m in front of the wall sliding +-0.4 m,
//                 rolling +-15 and tilting +-10 deg ("slide_rotate"), under
//                 the cards pan (0.6): for a region given at the middle frame
//                 and tracked both ways. 8 s.
//   region_hidden a 30 x 24 cm card 0.4 m in front of the wall slides
//                 (~2 px/frame) behind an opaque textured panel (2, 1 m in
//                 front of the wall), is wholly hidden for 2.0 s (frames
//                 81-140, whatever the seed), and comes back out the way it
//                 went in. Pan at 0.4. 8 s.
//
// Rendering: each plane is inverse-mapped (texture pixel -> image pixel
// homography from K, T_cam_world(t), T_world_plane(t)) with warpPerspective
// from a mip-mapped texture, blending the two nearest levels (trilinear) by
// the projected texel footprint of each pixel (along the most compressed
// direction, so oblique planes blur rather than alias). Plane edges get their
// exact area coverage (anti-aliased and unbiased: rendered corners match the
// truth to 0.02 px). Pixels whose ray would meet a plane behind the camera are
// never drawn. Planes are painted back to front. Large planes repeat a
// periodic texture (texture_tile_m). With supersample = N the frame is
// rendered on an N x N finer canvas and area-averaged down (sharper texture at
// grazing angles, ~N^2 the cost). Then: motion blur (exposure > 0: the mean of
// blur_samples renders), brightness gain, Gaussian sensor noise seeded from
// (seed, frame index).
// Cost (CPU time, measured on a busy 2-core machine): 10-18 ms per 640x480
// frame at supersample 1 (60% in warpPerspective, 15% the noise), 37 ms at
// 2, 70-85 ms at 3; create() ~80 ms per new procedural texture (the most
// recently used ones are cached process-wide).
//
// Conventions (docs/conventions.md): world frame z up (gravity -z); camera
// optical frame z forward, x right, y down; pixel coordinates have their
// origin at the top-left corner of the top-left pixel (pixel (0,0) covers
// [0,1)x[0,1)). `T_a_b` maps points of frame b into frame a. The IMU sits at
// the camera centre (no lever arm), rotated by R_cam_imu = q_cam_imu.
//
// Threading: a SceneGenerator is immutable after create(); every const method
// (renderFrame(), frameTruth(), imuSamples(), ...) may be called from several
// threads at once.
#pragma once

#include "instant_motion_tracking/core/types.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace imt {

// A textured rectangle in the world (a wall, floor, card, poster or patch).
struct ScenePlane {
  // kBackground: a wall or floor (painted first; a scene with exactly one has
  //   background_homography ground truth). kCard: a textured region (moving or
  //   static). kFeatureless: a flat-coloured region. kTarget: a planar target
  //   (reported in FrameTruth::targets, not in regions).
  enum class Kind { kBackground, kCard, kFeatureless, kTarget };
  Kind kind = Kind::kBackground;
  uint32_t id = 0;        // region / target id in the ground truth (0 = not reported)
  double width_m = 1.0;   // extent along the plane's x axis
  double height_m = 1.0;  // extent along the plane's y axis
  // Pose of the plane at time t (s from the scene start): T_world_plane. The
  // plane's origin is its centre; x along the texture's rows (left -> right),
  // y along its columns (top -> bottom), z = x cross y (away from a viewer
  // who sees the textured front). Static planes keep `motion` empty.
  Eigen::Isometry3d T_world_plane = Eigen::Isometry3d::Identity();
  // Optional rigid motion in the plane's own frame: T_world_plane(t) =
  // T_world_plane * motion(t), with motion(t) smooth (C-infinity):
  //   "slide"         x: A sin(wt), y: 0.3 A sin(1.3 wt)
  //   "slide_rotate"  "slide" at half amplitude + in-plane rotation +-15 deg +
  //                   tilt about y +-10 deg
  //   "approach"      toward the viewer (-z) by A (1 - cos wt) / 2 (scale
  //                   change) + a small slide 0.2 A sin(wt) along y
  //   "follow_camera" rides rigidly with the camera, T_world_plane being its
  //                   pose at t = 0, and shakes: T_world_plane(t) =
  //                   T_world_cam(t) T_world_cam(0)^-1 T_world_plane shake(t),
  //                   shake: x A sin(wt), y 0.6 A sin(1.7 wt + 1),
  //                   z 1.5 A sin(0.45 wt + 2), in-plane rotation
  //                   2 deg sin(1.3 wt + 0.5) (a car followed by a car)
  // with A = motion_amplitude, w = 2 pi / motion_period.
  std::string motion;             // "" | "slide" | "slide_rotate" | "approach" | "follow_camera"
  double motion_amplitude = 0.3;  // m (slide/approach) scale of the motion
  double motion_period = 4.0;     // s
  double motion_phase = 0.0;      // rad, added to w t
  int texture_seed = 0;           // procedural texture seed (ignored when texture_file is set)
  std::string texture_file;       // image file used as texture (gray), empty = procedural
  int texture_size = 0;           // px along the longer side of a procedural texture; 0 = auto
                                  //   (tiled: 2048; else ~400 px/m, 512..3072)
  // > 0: the texture repeats every texture_tile_m metres (square tiles from the
  // plane's top-left corner; procedural textures are periodic, so no seams),
  // for large walls and floors. 0: one texture stretched over the whole plane.
  double texture_tile_m = 0;
  bool flat = false;       // true: flat colour flat_gray instead of a texture
  double flat_gray = 128;  // colour of a kFeatureless (or flat) plane (0..255)

  bool isFlat() const { return flat || kind == Kind::kFeatureless; }
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
  // Layout used when `planes` is empty; fromPreset() sets it to its name.
  std::string preset = "wall_pan";  // one of presetNames()
  double duration = 10.0;           // s; frames at i / fps for i < floor(duration * fps)
  double fps = 30.0;                // frames per second
  int width = 640;                  // px
  int height = 480;                 // px
  double hfov_deg = 60.0;           // horizontal field of view (sets fx = fy)
  // Lens distortion of the camera, as camera_info's distortion_model and D:
  // "none" | "plumb_bob" (k1 k2 p1 p2 k3) | "rational_polynomial" (k1 k2 p1
  // p2 k3 k4 k5 k6) | "equidistant" (fisheye: k1 k2 k3 k4); missing
  // coefficients are 0. With distortion the frames are what that lens sees
  // (the pinhole view rendered on a canvas covering the lens's field, then
  // remapped through the lens: bilinear, so edges soften by ~0.5 px), and
  // every pixel of the truth (target corners, anchor pixels, region boxes) is
  // an image pixel, where the lens shows the point; intrinsics() carries D.
  // The lens must be one-to-one over the image (validate() checks).
  std::string distortion_model = "none";
  std::vector<double> distortion;
  uint64_t seed = 1;                // every random choice derives from it
  double start_time = 1000.0;       // stamp of the first frame (s)
  // Anti-aliasing. 1: mip-mapped (trilinear) texture + exact edge coverage
  // (already anti-aliased); N > 1: also render N x N samples per pixel and
  // area-average (sharper at grazing angles, ~N^2 the cost: 70-85 ms at 3).
  int supersample = 1;
  double noise_sigma = 2.0;            // sensor noise, grey levels (0..255 scale)
  double brightness_amplitude = 0.15;  // relative gain change: gain = 1 + A sin(2 pi t / period)
  double brightness_period = 6.0;      // s
  double exposure = 0.0;       // s (<= 1/fps); > 0 enables motion blur (sub-frame averaging)
  int blur_samples = 5;        // sub-frames averaged over [t - exposure/2, t + exposure/2]
  double void_gray = 90;       // grey where no plane is seen (e.g. above the horizon)
  double imu_rate = 200.0;     // Hz
  double gyro_noise = 0.0005;  // rad/s per sample (white, std)
  double accel_noise = 0.01;   // m/s^2 per sample (white, std)
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();  // rad/s, constant, in the IMU frame
  // Rotation of the IMU frame relative to the camera optical frame (R_cam_imu).
  Eigen::Quaterniond q_cam_imu =
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()));
  std::vector<std::string> texture_files;  // if set, background/card planes without their own
                                           // texture_file use these images in turn

  // Filled by a preset (or by hand): the planes, anchors and the trajectory.
  std::vector<ScenePlane> planes;
  std::vector<SceneAnchor> anchors;
  // Camera trajectory (smooth, C2: sums of sinusoids and smootherstep ramps).
  // Wall scenes: the wall is the plane y = 2.5 m facing the camera, which
  // starts at the origin looking along +y.
  //   pan     translation +-0.5 m across, +-0.6 m toward/away (zoom), yaw +-6,
  //           pitch +-4, roll +-10 deg
  //   zoom    toward/away only (+-0.6 m)
  //   planar  general motion: translation +-0.8, +-0.5, +-0.4 m looking at a
  //           wandering point of the wall, roll +-15 deg
  //   rotate  pure rotation about the camera centre: yaw +-15, pitch +-10, roll +-12 deg
  //   still   no motion
  //   orbit   around the point (0, 2.5, 0): azimuth +-48, elevation +-20 deg,
  //           distance 0.8..2.4 m, roll +-30 deg (poster_orbit)
  //   walk    1.2 m above the floor z = 0 heading +y at 0.15 m/s, pitch -22 +- 10,
  //           roll +-5 deg, a 4.5 s yaw excursion to 50 deg from t = 3 s (floor_walk)
  //   dolly   sideways along the wall at 0.75 m/s (x = 0.75 (t - 4) m) with
  //           vehicle shake: +-2 cm bounce at 1.1 Hz, +-4 cm toward/away,
  //           yaw +-1.5, pitch +-1, roll +-1.5 deg (region_follow; a 14 m wide
  //           wall fills the view for t in [0, 11] s)
  //   handheld 0.43..0.67 m from the wall point (0, 2.5, 0), swaying around it
  //           (azimuth +-25, elevation +-12, roll +-10 deg) with a hand's tremor:
  //           yaw +-1.5, pitch +-1.2, roll +-0.6 deg at 2.2-5.3 Hz, +-3 mm
  //           (poster_handheld)
  std::string trajectory = "pan";
  double trajectory_amplitude = 1.0;  // scales the trajectory's motion (0 = still)

  // A preset's full options; unknown name -> std::nullopt.
  static std::optional<SceneOptions> fromPreset(const std::string& name);
  static std::vector<std::string> presetNames();
  static std::vector<std::string> trajectoryNames();
  // Empty when usable, else a message naming the bad field.
  std::string validate() const;
};

// Ground truth for one frame. Pixel quantities use the convention above.
struct FrameTruth {
  int index = 0;
  double stamp = 0;  // s
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  double brightness_gain = 1;  // gain applied to the frame
  // Background homography previous -> current frame (H(2,2) = 1); set when
  // the background is a single plane, this is not the first frame and the
  // lens has no distortion (through one, image motion is no homography).
  std::optional<Eigen::Matrix3d> background_homography;
  struct Region {
    uint32_t id = 0;
    cv::Rect2d box;                // bounding box of the projected plane, clipped to the image
                                   //   (through a distorting lens: of its sampled edges)
    cv::Rect2d box_unclipped;      // the same before clipping (may lie outside)
    double visible_fraction = 0;   // of the unclipped box area inside the image
    double occluded_fraction = 0;  // of the plane's in-image area hidden by nearer planes
                                   //   (on the pinhole projection, also with distortion)
    bool featureless = false;
  };
  std::vector<Region> regions;  // one per plane with id != 0 and kind != kTarget
  struct Target {
    uint32_t id = 0;
    std::array<cv::Point2d, 4> corners;  // TL, TR, BR, BL projections
    // spec pose: origin centre, x TL->TR, y TL->BL
    Eigen::Isometry3d T_cam_target = Eigen::Isometry3d::Identity();
    double width_m = 0, height_m = 0;
    double visible_fraction = 0;   // of the projected target's area inside the image
    double occluded_fraction = 0;  // of its in-image area hidden by nearer planes
  };
  std::vector<Target> targets;
  struct Anchor {
    uint32_t id = 0;
    cv::Point2d pixel;               // projection (also when outside the image;
                                     //   meaningless when behind the camera)
    bool in_view = false;            // in front of the camera and inside the image
    bool placed = false;             // stamp >= placement time
    // spec anchor frame in the camera optical frame
    Eigen::Isometry3d T_cam_anchor = Eigen::Isometry3d::Identity();
  };
  std::vector<Anchor> anchors;
};

// Renders a scene and produces its IMU stream and ground truth.
class SceneGenerator {
 public:
  // Validates the options, fills an empty plane list from the preset, makes
  // (or loads) every texture once. nullptr + *error on failure.
  static std::unique_ptr<SceneGenerator> create(const SceneOptions& options, std::string* error);

  // The options in use (planes/anchors filled in from the preset if they were empty).
  const SceneOptions& options() const { return options_; }
  int frameCount() const;
  double frameStamp(int i) const;  // start_time + i / fps
  CameraModel intrinsics() const;  // the pinhole of hfov_deg plus the lens distortion
  Eigen::Isometry3d T_world_cam(double t) const;                  // t: s from the scene start
  Eigen::Isometry3d T_world_plane(size_t plane, double t) const;  // options().planes[plane]
  double brightnessGain(double t) const;

  cv::Mat renderFrame(int i) const;  // CV_8UC1
  cv::Mat renderAt(double t) const;  // CV_8UC1 at any time t (s from the scene start);
                                     //   noise seeded from (seed, round(t * fps))
  // (Truth is exact for frame times; at other times use T_world_cam(t),
  // T_world_plane(k, t) and project().)
  FrameTruth frameTruth(int i) const;
  std::vector<ImuSample> imuSamples()
      const;  // imu_rate samples covering the whole scene, in imu frame

  // Homography of the background plane from frame `from` to frame `to`
  // (H(2,2) = 1); nullopt unless the scene has exactly one background plane
  // and no lens distortion.
  std::optional<Eigen::Matrix3d> backgroundHomography(int from, int to) const;
  // Image pixel of a world point at time t (through the lens); nullopt when
  // it is not in front of the camera.
  std::optional<cv::Point2d> project(const Eigen::Vector3d& p_world, double t) const;

  ~SceneGenerator();

 private:
  explicit SceneGenerator(const SceneOptions& options);
  SceneOptions options_;
  struct Impl;
  std::shared_ptr<const Impl> impl_;
};

// Procedural texture with detail at all scales (octaves of smoothed noise plus
// random strokes, rectangles and blobs for corners), deterministic in `seed`.
// CV_8UC1, size x size, grey levels within ~[25, 230].
cv::Mat proceduralTexture(int size, uint64_t seed);

}  // namespace imt
