// Motion analysis (paper 3.1) options: features, camera motion, foreground/background. One struct, each field documented once in visit();
// config/default.yaml is generated from it.
#pragma once

#include <string>

namespace imt {

// Motion analysis (paper 3.1): features, camera motion, foreground/background.
// Lengths marked "analysis px" are pixels of the downscaled analysis frame;
// "fraction of the diagonal" values scale with the full-resolution frame.
struct MotionAnalysisOptions {
  // Each field is documented once, in visit() below (config/default.yaml is
  // generated from it: track_bag --print-default-config).
  // --- features (FeatureTracker) ---
  int analysis_width = 320;
  int max_features = 256;
  int grid_cols = 8;
  int grid_rows = 6;
  double min_distance = 7.0;
  double quality_level = 0.02;
  double min_eigenvalue = 2e-4;
  int detect_interval = 4;
  double redetect_fraction = 0.6;
  int lk_window = 11;
  int lk_levels = 2;
  int lk_iterations = 8;
  double fb_max_error = 0.5;
  int fb_check_interval = 8;
  // --- camera motion (CameraMotionEstimator) ---
  int ransac_hypotheses = 24;
  int irls_iterations = 10;
  double inlier_threshold = 0.003;
  int min_inliers_translation = 3;
  int min_inliers_similarity = 30;
  int min_inliers_homography = 60;
  double min_inlier_fraction = 0.2;
  double min_inlier_coverage = 0.3;
  double max_scale_change = 0.25;
  double max_rotation = 0.25;
  double max_perspective = 0.16;
  double max_translation = 0.15;
  double temporal_prior = 0.7;
  // --- foreground / background ---
  double foreground_residual = 0.0012;
  double residual_decay = 0.85;
  double foreground_threshold = 0.5;

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

}  // namespace imt
