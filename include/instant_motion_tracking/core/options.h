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

#include <string>

namespace imt {

// Motion analysis (paper 3.1): features, camera motion, foreground/background.
struct MotionAnalysisOptions {
  int analysis_width = 320;          // px; frames are downscaled to this width for analysis (0 = full size)
  int max_features = 400;            // upper bound on tracked features
  int grid_cols = 8;                 // feature grid cells across (features are spread over the grid)
  int grid_rows = 6;                 // feature grid cells down
  double min_distance = 7.0;         // px at analysis resolution; minimum corner spacing
  double quality_level = 0.01;       // corner quality relative to the best corner in the frame
  int lk_window = 15;                // px; pyramidal Lucas-Kanade window side at analysis resolution
  int lk_levels = 3;                 // pyramid levels above the base
  int lk_iterations = 10;            // LK iterations per level
  double fb_max_error = 1.0;         // px at analysis resolution; forward-backward check threshold
  int irls_iterations = 10;          // IRLS rounds per camera model fit
  double inlier_threshold = 0.004;   // residual threshold for a background inlier, fraction of the frame diagonal
  int min_inliers_similarity = 30;   // inliers needed for a similarity
  int min_inliers_homography = 60;   // inliers needed for a homography
  double min_inlier_coverage = 0.3;  // fraction of grid cells the homography's inliers must cover
  double max_scale_change = 0.25;    // similarity/homography stability bound: |scale - 1| per frame
  double max_rotation = 0.25;        // rad per frame
  double max_perspective = 4e-4;     // homography stability bound on |h20|, |h21| (1/px at analysis resolution)
  double max_translation = 0.15;     // translation stability bound, fraction of the frame diagonal
  double temporal_prior = 0.7;       // weight of last frame's background inliers in the next fit (0 = none)
  double foreground_threshold = 0.5; // background weight below which a feature is flagged foreground

  template <class V>
  void visit(V& v) {
    v("analysis_width", analysis_width, "px; frames are downscaled to this width for analysis (0 = full size)");
    v("max_features", max_features, "upper bound on tracked features");
    v("grid_cols", grid_cols, "feature grid cells across");
    v("grid_rows", grid_rows, "feature grid cells down");
    v("min_distance", min_distance, "px at analysis resolution; minimum corner spacing");
    v("quality_level", quality_level, "corner quality relative to the best corner");
    v("lk_window", lk_window, "px; Lucas-Kanade window side at analysis resolution");
    v("lk_levels", lk_levels, "pyramid levels above the base");
    v("lk_iterations", lk_iterations, "LK iterations per level");
    v("fb_max_error", fb_max_error, "px; forward-backward check threshold");
    v("irls_iterations", irls_iterations, "IRLS rounds per camera model fit");
    v("inlier_threshold", inlier_threshold, "background inlier residual, fraction of the frame diagonal");
    v("min_inliers_similarity", min_inliers_similarity, "inliers needed for a similarity");
    v("min_inliers_homography", min_inliers_homography, "inliers needed for a homography");
    v("min_inlier_coverage", min_inlier_coverage, "fraction of grid cells homography inliers must cover");
    v("max_scale_change", max_scale_change, "stability bound |scale - 1| per frame");
    v("max_rotation", max_rotation, "stability bound, rad per frame");
    v("max_perspective", max_perspective, "stability bound on |h20|, |h21|");
    v("max_translation", max_translation, "stability bound, fraction of the frame diagonal");
    v("temporal_prior", temporal_prior, "weight of last frame's background inliers (0 = none)");
    v("foreground_threshold", foreground_threshold, "background weight below which a feature is foreground");
  }
  // Empty when usable, else a message naming the bad field.
  std::string validate() const;
};

// The whole pipeline: shared by the nodelets and track_bag.
struct PipelineOptions {
  double cache_seconds = 10.0;   // s of motion data kept for adding regions in the past and seeking
  double default_hfov_deg = 60.0;  // horizontal field of view assumed without camera_info (deg)
  MotionAnalysisOptions motion_analysis;

  template <class V>
  void visit(V& v) {
    v("cache_seconds", cache_seconds, "s of motion data kept for past regions and seeking");
    v("default_hfov_deg", default_hfov_deg, "horizontal field of view without camera_info (deg)");
    v.section("motion_analysis", motion_analysis);
  }
  std::string validate() const;
};

}  // namespace imt
