// Options of the region tracker (paper 3.2). See options.h for the visit()
// protocol; config/default.yaml mirrors this struct under `region_tracking:`.
#pragma once

#include <string>

namespace imt {

struct RegionTrackerOptions {
  double min_dilation = 0.03;      // search-area dilation floor, fraction of the longer image side
  double velocity_dilation = 2.0;  // search area grows by this many times the region's speed (px/frame)
  int irls_iterations = 5;         // IRLS rounds per frame: w_i = prior_i / error_i
  double error_floor = 0.5;        // px; smallest error in the weights (keeps 1/e bounded)
  double inlier_error = 1.5;       // px; residual below which a feature supports the region (plus 10% of its motion)
  double inlier_boost = 10.0;      // prior multiplier for features that were inliers last frame
  double outlier_cut = 0.05;       // prior multiplier for features that were outliers last frame
  int min_features = 3;            // fewer usable features: the region moves with the camera (featureless)
  int min_inliers_scale = 6;       // inliers needed to estimate a scale change
  int min_inliers_similarity = 20; // inliers needed to estimate a rotation as well
  double max_scale_change = 0.05;  // |scale - 1| per frame above which scale is not trusted
  double max_rotation = 0.1;       // rad per frame above which rotation is not trusted
  double velocity_blend = 0.7;     // weight of the previous velocity in the smoothed velocity
  double occlusion_ratio = 0.15;   // continued-inlier fraction below which a conflicting fit is an occluder
  double max_coast_frames = 45;    // frames a region coasts on its velocity (occluded) before it is lost
  double out_of_view_fraction = 0.25;  // box fraction inside the image below which it is out_of_view
  double lost_distance = 3.0;      // out of view farther than this many box sizes outside the image: lost
  double confidence_inliers = 20;  // inliers at which confidence reaches 1
  // features whose median residual adds a translation to the camera fallback (IMU rotation)
  int fallback_min_features = 10;

  template <class V>
  void visit(V& v) {
    v("min_dilation", min_dilation, "search-area dilation floor, fraction of the longer image side");
    v("velocity_dilation", velocity_dilation, "search area grows by this many times the speed");
    v("irls_iterations", irls_iterations, "IRLS rounds per frame");
    v("error_floor", error_floor, "px; smallest error in the IRLS weights");
    v("inlier_error", inlier_error, "px; residual below which a feature supports the region");
    v("inlier_boost", inlier_boost, "prior multiplier for last frame's inliers");
    v("outlier_cut", outlier_cut, "prior multiplier for last frame's outliers");
    v("min_features", min_features, "fewer usable features: the region moves with the camera");
    v("min_inliers_scale", min_inliers_scale, "inliers needed to estimate a scale change");
    v("min_inliers_similarity", min_inliers_similarity, "inliers needed to estimate rotation");
    v("max_scale_change", max_scale_change, "|scale - 1| per frame above which scale is not trusted");
    v("max_rotation", max_rotation, "rad per frame above which rotation is not trusted");
    v("velocity_blend", velocity_blend, "weight of the previous velocity in the smoothed velocity");
    v("occlusion_ratio", occlusion_ratio, "continued-inlier fraction below which a conflicting fit is an occluder");
    v("max_coast_frames", max_coast_frames, "frames a region coasts on its velocity before it is lost");
    v("out_of_view_fraction", out_of_view_fraction, "box fraction inside the image below which it is out_of_view");
    v("lost_distance", lost_distance, "out of view farther than this many box sizes: lost");
    v("confidence_inliers", confidence_inliers, "inliers at which confidence reaches 1");
    v("fallback_min_features", fallback_min_features,
      "features whose median residual adds a translation to the camera fallback (IMU rotation)");
  }
  std::string validate() const;
};

}  // namespace imt
