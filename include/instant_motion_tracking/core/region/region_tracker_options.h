// Options of the region tracker (paper 3.2). See options.h for the visit()
// protocol; config/default.yaml mirrors this struct under `region_tracking:`.
#pragma once

#include <string>

namespace imt {

struct RegionTrackerOptions {
  // Each field is documented once, in visit() below (config/default.yaml is
  // generated from it: track_bag --print-default-config).
  double min_dilation = 0.03;
  double velocity_dilation =
      2.0;                   // search area grows by this many times the region's speed (px/frame)
  int irls_iterations = 5;
  double error_floor = 0.5;
  double inlier_error =
      1.5;  // px; residual below which a feature supports the region (plus 10% of its motion)
  double inlier_boost = 10.0;
  double outlier_cut = 0.05;
  int min_features = 3;
  int min_inliers_scale = 6;
  int min_inliers_similarity = 12;
  double max_scale_change = 0.05;
  double max_rotation = 0.1;
  double velocity_blend = 0.7;
  double occlusion_ratio =
      0.15;  // continued-inlier fraction below which a conflicting fit is an occluder
  double max_coast_frames =
      45;  // frames a region coasts on its velocity (occluded) before it is lost
  double out_of_view_fraction =
      0.25;  // box fraction inside the image below which it is out_of_view
  double lost_distance =
      3.0;  // out of view farther than this many box sizes outside the image: lost
  double confidence_inliers = 20;
  int fallback_min_features = 10;
  int region_features = 6;
  int region_feature_px = 96;
  bool appearance = true;
  bool appearance_filter = true;
  int appearance_size = 40;
  double appearance_margin = 0.35;
  double appearance_accept = 0.6;
  double appearance_gain = 0.5;
  double appearance_gap = 0.1;
  double appearance_update = 0.1;
  double appearance_lost_score = 0.3;
  int appearance_lost_frames = 20;
  double reacquire_score = 0.75;
  int reacquire_interval = 5;
  int appearance_budget = 8;
  int max_regions = 1000;

  template <class V>
  void visit(V& v) {
    v("min_dilation", min_dilation,
      "search-area dilation floor, fraction of the longer image side");
    v("velocity_dilation", velocity_dilation,
      "the search area grows by this many times the region's speed (px/frame)");
    v("irls_iterations", irls_iterations, "IRLS rounds per frame, weights w_i = prior_i / error_i");
    v("error_floor", error_floor, "px; smallest error in the IRLS weights (keeps 1/e bounded)");
    v("inlier_error", inlier_error,
      "px; residual below which a feature supports the region (plus 10% of its motion)");
    v("inlier_boost", inlier_boost, "prior multiplier for features that were inliers last frame");
    v("outlier_cut", outlier_cut,
      "prior multiplier for features that were outliers last frame, or that the region saw moving with the camera "
      "while it moved on its own");
    v("min_features", min_features,
      "fewer usable features: the region moves with the camera (featureless)");
    v("min_inliers_scale", min_inliers_scale, "inliers needed to estimate a scale change");
    v("min_inliers_similarity", min_inliers_similarity,
      "inliers needed to estimate a rotation as well");
    v("max_scale_change", max_scale_change,
      "|scale - 1| per frame above which the scale is not trusted");
    v("max_rotation", max_rotation, "rad per frame above which the rotation is not trusted");
    v("velocity_blend", velocity_blend, "weight of the previous velocity in the smoothed velocity");
    v("occlusion_ratio", occlusion_ratio,
      "continued-inlier fraction below which a conflicting fit is taken for an occluder");
    v("max_coast_frames", max_coast_frames,
      "frames a region coasts on its predicted motion (occluded) before it is lost");
    v("out_of_view_fraction", out_of_view_fraction,
      "box fraction inside the image below which the region is out_of_view");
    v("lost_distance", lost_distance,
      "out of view farther than this many box sizes outside the image: lost");
    v("confidence_inliers", confidence_inliers, "inliers at which the confidence reaches 1");
    v("fallback_min_features", fallback_min_features,
      "frames without a camera model move by the IMU rotation (anchors); with this many features, "
      "plus their median residual (the translation)");
    v("region_features", region_features,
      "features each region is given at least inside its box: corners of its own tracked besides the motion "
      "analysis's, as many as the motion analysis falls short of this (0 = none; 6 = enough to measure its scale)");
    v("region_feature_px", region_feature_px,
      "px; its own features are tracked at full resolution in boxes up to this size, larger boxes downscaled to it");
    v("appearance", appearance,
      "check each region's look (a template) against the frames: corrects drift, re-acquires lost regions");
    v("appearance_filter", appearance_filter,
      "with appearance: each region also keeps a correlation filter that tells it from its surround "
      "(region_filter.h), which places it as far as the look moves it");
    v("appearance_size", appearance_size, "px; the template's longer side (smaller boxes keep their own pixels)");
    v("appearance_margin", appearance_margin,
      "search reach around the motion's box, fraction of its sides (doubled when the motion step had no support)");
    v("appearance_accept", appearance_accept,
      "normalised cross-correlation above which a better-matching box nearby corrects the region");
    v("appearance_gain", appearance_gain,
      "fraction of that correction applied per frame, times (1 - the motion fit's confidence); all of it when "
      "the motion step had no support");
    v("appearance_gap", appearance_gap,
      "the better box must beat the motion's box by this much correlation (the features are more precise)");
    v("appearance_update", appearance_update,
      "weight of the current look blended into the template on confident frames (and, while many features carry "
      "the region, on frames its look still scores appearance_lost_score)");
    v("appearance_lost_score", appearance_lost_score,
      "correlation below which the region does not look like itself");
    v("appearance_lost_frames", appearance_lost_frames,
      "consecutive such frames after which the region is lost (0 = never)");
    v("reacquire_score", reacquire_score,
      "correlation at which a lost region is found again, and a tracked one's look may correct its turn and aspect");
    v("reacquire_interval", reacquire_interval,
      "frames between a lost region's whole-frame searches (around its last place: every frame for the first 2 intervals, then with them); after 30 intervals, 4 times as many (0 = around its last place on every frame only)");
    v("appearance_budget", appearance_budget,
      "regions whose look is checked per frame, so the cost stays bounded with many regions: with more regions, "
      "each is checked on its turn, every ceil(regions / budget) frames, whether the features carry it or it is in "
      "doubt (appearance_lost_frames then rounded up to whole checks); a lost one's searches around its "
      "last place also come on its turns, its whole-frame searches as reacquire_interval says (0 = every region "
      "on every frame)");
    v("max_regions", max_regions, "regions tracked at most; add_region and INIT.yaml are refused beyond");
  }
  std::string validate() const;
  // The tracker reads the frames' images (own features or appearance).
  bool usesImages() const { return region_features > 0 || appearance; }
};

}  // namespace imt
