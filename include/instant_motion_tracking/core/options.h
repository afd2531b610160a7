// Options structs of the core modules: one struct per module, each field with
// its default, unit and effect. Every loader (YAML for track_bag, the ROS
// parameter server for the nodelets) walks them through visit(), taking every
// default from the struct itself, so defaults cannot drift. The YAML layout of
// config/default.yaml mirrors these structs (one mapping per struct).
//
// A visitor provides:
//   void operator()(const char* name, T& field, const char* doc);   // T: int, double, bool, std::string
//   template <class S> void section(const char* name, S& sub);       // nested struct
#pragma once

#include "instant_motion_tracking/core/anchor/anchor_manager.h"
#include "instant_motion_tracking/core/anchor/imu_orientation.h"
#include "instant_motion_tracking/core/planar/planar_target.h"
#include "instant_motion_tracking/core/region/region_tracker_options.h"

#include <string>

namespace imt {

// Motion analysis (paper 3.1): features, camera motion, foreground/background.
// Lengths marked "analysis px" are pixels of the downscaled analysis frame;
// "fraction of the diagonal" values scale with the full-resolution frame.
struct MotionAnalysisOptions {
  // --- features (FeatureTracker) ---
  // px; frames wider than this are downscaled to it for analysis (0 = full size)
  int analysis_width = 320;
  int max_features = 256;          // upper bound on tracked features
  int grid_cols = 8;               // feature grid cells across (features spread over the grid)
  int grid_rows = 6;               // feature grid cells down
  double min_distance = 7.0;       // analysis px; minimum corner spacing
  double quality_level = 0.02;     // corner quality relative to the best corner of its grid cell
  double min_eigenvalue = 2e-4;    // absolute floor on a corner's min. eigenvalue (3x3 blocks)
  int detect_interval = 4;         // frames between corner detections in under-filled cells
  double redetect_fraction = 0.6;  // detect at once below this fraction of max_features
  int lk_window = 11;              // analysis px; pyramidal Lucas-Kanade window side
  int lk_levels = 2;               // pyramid levels above the base
  int lk_iterations = 8;           // LK iterations per level
  double fb_max_error = 0.5;       // analysis px; forward-backward check threshold
  int fb_check_interval = 8;       // every track is tracked back at least every N frames (1 = all)
  // --- camera motion (CameraMotionEstimator) ---
  int ransac_hypotheses = 24;        // 2-point similarity hypotheses seeding the robust fit
  int irls_iterations = 10;          // IRLS rounds per camera model fit
  double inlier_threshold = 0.003;   // background inlier residual, fraction of the frame diagonal
  int min_inliers_translation = 3;   // inliers needed for a translation
  int min_inliers_similarity = 30;   // inliers needed for a similarity
  int min_inliers_homography = 60;   // inliers needed for a homography
  double min_inlier_fraction = 0.2;  // inliers / features needed for a similarity or homography
  double min_inlier_coverage = 0.3;  // fraction of grid cells the homography's inliers must cover
  double max_scale_change = 0.25;    // similarity/homography bound: |scale - 1| per frame
  double max_rotation = 0.25;        // similarity/homography bound: rad per frame
  double max_perspective = 0.16;     // homography bound on |h20|, |h21| times the frame diagonal
  double max_translation = 0.15;     // bound on the frame centre's motion, fraction of the diagonal
  double temporal_prior = 0.7;       // weight of last frame's background weights (0: none)
  // --- foreground / background ---
  // accumulated residual (fraction of the diagonal) at which a feature's background weight is 0.5
  double foreground_residual = 0.0012;
  double residual_decay = 0.85;       // per-frame decay of the accumulated residual (0: this frame)
  double foreground_threshold = 0.5;  // background weight below which a feature is foreground

  template <class V>
  void visit(V& v) {
    v("analysis_width", analysis_width,
      "px; frames wider than this are downscaled to it for analysis (0 = full size)");
    v("max_features", max_features, "upper bound on tracked features");
    v("grid_cols", grid_cols, "feature grid cells across");
    v("grid_rows", grid_rows, "feature grid cells down");
    v("min_distance", min_distance, "analysis px; minimum corner spacing");
    v("quality_level", quality_level,
      "corner quality relative to the best corner of its grid cell");
    v("min_eigenvalue", min_eigenvalue, "absolute floor on a corner's minimum eigenvalue");
    v("detect_interval", detect_interval, "frames between corner detections in under-filled cells");
    v("redetect_fraction", redetect_fraction, "detect at once below this fraction of max_features");
    v("lk_window", lk_window, "analysis px; Lucas-Kanade window side");
    v("lk_levels", lk_levels, "pyramid levels above the base");
    v("lk_iterations", lk_iterations, "LK iterations per level");
    v("fb_max_error", fb_max_error, "analysis px; forward-backward check threshold");
    v("fb_check_interval", fb_check_interval,
      "every track is forward-backward checked at least every N frames");
    v("ransac_hypotheses", ransac_hypotheses,
      "2-point similarity hypotheses seeding the robust fit");
    v("irls_iterations", irls_iterations, "IRLS rounds per camera model fit");
    v("inlier_threshold", inlier_threshold,
      "background inlier residual, fraction of the frame diagonal");
    v("min_inliers_translation", min_inliers_translation, "inliers needed for a translation");
    v("min_inliers_similarity", min_inliers_similarity, "inliers needed for a similarity");
    v("min_inliers_homography", min_inliers_homography, "inliers needed for a homography");
    v("min_inlier_fraction", min_inlier_fraction,
      "inliers / features needed for a similarity or homography");
    v("min_inlier_coverage", min_inlier_coverage,
      "fraction of grid cells homography inliers must cover");
    v("max_scale_change", max_scale_change, "stability bound |scale - 1| per frame");
    v("max_rotation", max_rotation, "stability bound, rad per frame");
    v("max_perspective", max_perspective,
      "stability bound on |h20|, |h21| times the frame diagonal");
    v("max_translation", max_translation, "stability bound, fraction of the frame diagonal");
    v("temporal_prior", temporal_prior,
      "weight of last frame's background classification (0 = none)");
    v("foreground_residual", foreground_residual,
      "accumulated residual (fraction of the diagonal) giving background weight 0.5");
    v("residual_decay", residual_decay, "per-frame decay of a feature's accumulated residual");
    v("foreground_threshold", foreground_threshold,
      "background weight below which a feature is foreground");
  }
  // Empty when usable, else a message naming the bad field.
  std::string validate() const;
};

// The whole pipeline: shared by the nodelets and track_bag.
struct PipelineOptions {
  double cache_seconds = 10.0;   // s of motion data kept for adding regions in the past and seeking
  double default_hfov_deg = 60.0;  // horizontal field of view assumed without camera_info (deg)
  // true: the images are already rectified (image_rect): camera_info's P gives
  // fx, fy, cx, cy and its D is ignored; false: K and D (distortion honoured)
  bool image_rectified = false;
  MotionAnalysisOptions motion_analysis;
  RegionTrackerOptions region_tracking;
  PlanarTargetOptions planar_tracking;
  ImuOptions imu;
  AnchorOptions anchors;

  template <class V>
  void visit(V& v) {
    v("cache_seconds", cache_seconds, "s of motion data kept for past regions and seeking");
    v("default_hfov_deg", default_hfov_deg, "horizontal field of view without camera_info (deg)");
    v("image_rectified", image_rectified,
      "true: images already rectified (image_rect): camera_info's P is used, D ignored; false: K and D");
    v.section("motion_analysis", motion_analysis);
    v.section("region_tracking", region_tracking);
    v.section("planar_tracking", planar_tracking);
    v.section("imu", imu);
    v.section("anchors", anchors);
  }
  std::string validate() const;
};

}  // namespace imt
