#include "instant_motion_tracking/core/options.h"

#include "option_checker.h"

#include <cmath>
#include <sstream>

namespace imt {

std::string MotionAnalysisOptions::validate() const {
  OptionChecker c("motion_analysis");
  c.atLeast("analysis_width", analysis_width, 0);
  if (analysis_width > 0) c.atLeast("analysis_width", analysis_width, 32);
  c.inRange("max_features", max_features, 8, 10000);
  c.inRange("grid_cols", grid_cols, 1, 64);
  c.inRange("grid_rows", grid_rows, 1, 64);
  c.inRange("min_distance", min_distance, 1.0, 100.0);
  c.inRange("quality_level", quality_level, 0.0, 1.0);
  c.inRange("min_eigenvalue", min_eigenvalue, 0.0, 1.0);
  c.inRange("detect_interval", detect_interval, 1, 1000);
  c.inRange("redetect_fraction", redetect_fraction, 0.0, 1.0);
  c.inRange("lk_window", lk_window, 5, 101);
  c.inRange("lk_levels", lk_levels, 0, 8);
  c.inRange("lk_iterations", lk_iterations, 1, 100);
  c.inRange("fb_max_error", fb_max_error, 0.01, 100.0);
  c.inRange("fb_check_interval", fb_check_interval, 1, 1000);
  c.inRange("ransac_hypotheses", ransac_hypotheses, 0, 10000);
  c.inRange("irls_iterations", irls_iterations, 1, 100);
  c.inRange("inlier_threshold", inlier_threshold, 1e-5, 0.5);
  c.inRange("min_inliers_translation", min_inliers_translation, 1, 100000);
  c.inRange("min_inliers_similarity", min_inliers_similarity, 2, 100000);
  c.inRange("min_inliers_homography", min_inliers_homography, 4, 100000);
  c.inRange("min_inlier_fraction", min_inlier_fraction, 0.0, 1.0);
  c.inRange("min_inlier_coverage", min_inlier_coverage, 0.0, 1.0);
  c.inRange("max_scale_change", max_scale_change, 0.0, 1.0);
  c.inRange("max_rotation", max_rotation, 0.0, M_PI);
  c.inRange("max_perspective", max_perspective, 0.0, 10.0);
  c.inRange("max_translation", max_translation, 0.0, 1.0);
  c.inRange("temporal_prior", temporal_prior, 0.0, 1.0);
  c.inRange("foreground_residual", foreground_residual, 1e-5, 0.5);
  c.inRange("residual_decay", residual_decay, 0.0, 0.99);
  c.inRange("foreground_threshold", foreground_threshold, 0.0, 1.0);
  return c.error();
}

std::string PipelineOptions::validate() const {
  OptionChecker c("");
  c.inRange("cache_seconds", cache_seconds, 0.0, 600.0);
  c.inRange("default_hfov_deg", default_hfov_deg, 1.0, 179.0);
  c.check(time_jump_reset_seconds > 0 && time_jump_reset_seconds <= 3600, "time_jump_reset_seconds",
          "must be in (0, 3600]", time_jump_reset_seconds);
  std::string e = c.error();
  if (!e.empty()) return e;
  e = motion_analysis.validate();
  if (e.empty()) e = region_tracking.validate();
  if (e.empty()) e = planar_tracking.validate();
  if (e.empty()) e = imu.validate();
  return e.empty() ? anchors.validate() : e;
}

}  // namespace imt
