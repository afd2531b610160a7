// Planar-target tracking (paper 3.3) options. One struct, each field documented once in visit();
// config/default.yaml is generated from it.
#pragma once

#include <string>

namespace imt {

struct PlanarTargetOptions {
  // Each field is documented once, in visit() below (config/default.yaml is
  // generated from it: track_bag --print-default-config).
  std::string model =
      "perspective";  // perspective (rigid 6DoF pose, LM) | homography (chained, for comparison)
  double loss_scale = 1.5;
  int max_iterations = 20;
  double outlier_error = 3.0;
  double join_error = 1.0;
  int min_points = 6;
  double confidence_points = 30;
  double prediction_gate =
      0.06;  // fraction of the target's size; a pose from fewer than 2 min_points points farther
  bool refine = true;
  int template_size = 192;
  double refine_min_correlation = 0.75;
  double refine_max_correction =
      0.15;  // fraction of the target's size on screen; larger corrections are not used
  double refine_max_step =
      0.06;  // the same for a target aligned on the last frame; grows by this per unaligned frame
  int refine_iterations = 10;
  double refine_epsilon = 1e-3;
  double refine_min_visible =
      0.35;  // fraction of the target (in view) that must be seen uncovered to align
  double refine_outlier_sigma =
      3.0;  // noise levels by which a covered (occluded) template pixel differs
  double refine_search_range = 0.4;
                                     // alignment fails or fits loosely (0: no search)
  double refine_search_below =
      0.95;  // ECC correlation below which the search is tried too and the better fit kept
  double refine_search_min_score = 0.6;
  double refine_search_margin =
      0.15;  // by which it must beat the best match elsewhere (no repeated-pattern confusion)
  double image_memory_mb = 512;
  int max_targets = 32;
  // Image targets (found from a reference picture).
  int detect_interval = 5;
  int detect_features = 6000;
  int detect_picture_size = 320;
  int detect_picture_features = 1000;
  double detect_ratio = 0.8;
  int detect_min_inliers = 8;
  double detect_min_correlation = 0.9;
  double detect_ransac_error = 3.0;

  template <class V>
  void visit(V& v) {
    v("model", model,
      "perspective (rigid 6DoF pose by Levenberg-Marquardt) | homography (chained, for "
      "comparison)");
    v("loss_scale", loss_scale, "px; Huber loss scale of the reprojection residuals");
    v("max_iterations", max_iterations, "Levenberg-Marquardt iterations per frame");
    v("outlier_error", outlier_error,
      "px; model points reprojecting worse than this and 3x the points' noise level are dropped "
      "(occluders, off-plane)");
    v("join_error", join_error,
      "px; a new point joins when its second observation agrees this well (or within 1.5x the "
      "points' noise level)");
    v("min_points", min_points,
      "fewer model points visible: the target is predicted by the camera motion");
    v("confidence_points", confidence_points, "model points at which the confidence reaches 1");
    v("prediction_gate", prediction_gate,
      "fraction of the target's size; a pose from fewer than 2 x min_points points farther than "
      "this (or than 4 x how far the target's confirmed poses usually are, at least 1 px) from "
      "the camera-motion prediction is not used (an occluder drags the last features)");
    v("refine", refine, "align the target's look at placement with each frame (ECC): no drift");
    v("template_size", template_size, "px; long side of the rectified template kept at placement");
    v("refine_min_correlation", refine_min_correlation,
      "ECC correlation below which an alignment is not used");
    v("refine_max_correction", refine_max_correction,
      "fraction of the target's size on screen; larger corrections are not used");
    v("refine_max_step", refine_max_step,
      "the same for a target aligned on the last frame; grows by this per frame without alignment");
    v("refine_iterations", refine_iterations, "ECC iterations per pyramid level at most");
    v("refine_epsilon", refine_epsilon, "ECC stops when the correlation changes less than this");
    v("refine_min_visible", refine_min_visible,
      "fraction of the target (in view) that must be seen uncovered (not occluded) to align");
    v("refine_outlier_sigma", refine_outlier_sigma,
      "noise levels by which a covered (occluded) template pixel differs from the template");
    v("refine_search_range", refine_search_range,
      "fraction of the target's size searched around it when the alignment fails or fits loosely "
      "(re-acquisition; 0: no search)");
    v("refine_search_below", refine_search_below,
      "ECC correlation below which the search is tried too (something covering the target may have "
      "dragged it) and the better fit kept");
    v("refine_search_min_score", refine_search_min_score,
      "normalised correlation a search's match must reach to be used");
    v("refine_search_margin", refine_search_margin,
      "by which that match must beat the best one elsewhere (no repeated-pattern confusion)");
    v("image_memory_mb", image_memory_mb,
      "MB of gray frames kept for the alignment and the regions' look (oldest dropped first; track_bag reads the rest again)");
    v("max_targets", max_targets,
      "planar targets tracked at most (each costs milliseconds per frame); add_planar_target and INIT.yaml "
      "are refused beyond");
    v("detect_interval", detect_interval,
      "frames after which a search for a target in doubt (an image target not found yet; any target "
      "predicted, out of view, lost, or not confirmed by its look for this many frames), run on a thread of "
      "its own, is answered (a find starts the tracker at the searched frame); the next search starts then");
    v("detect_features", detect_features, "ORB keypoints described in a frame for finding image targets");
    v("detect_picture_size", detect_picture_size,
      "px; an image target's picture is described at this long side (scaled down or up to it)");
    v("detect_picture_features", detect_picture_features,
      "ORB keypoints of an image target's picture (its strongest, shared equally by 8 scales 1.2 apart): a "
      "search costs these times detect_features matches");
    v("detect_ratio", detect_ratio,
      "a picture keypoint matches a frame's when its best match is closer than this fraction of the second "
      "best (Lowe's ratio test)");
    v("detect_min_inliers", detect_min_inliers,
      "matches consistent with one homography needed to take an image target as found");
    v("detect_min_correlation", detect_min_correlation,
      "ECC correlation the picture, aligned with the frame from the matches' homography, must reach to take an "
      "image target as found");
    v("detect_ransac_error", detect_ransac_error,
      "px; reprojection error within which a match is consistent with the homography (RANSAC)");
  }
  std::string validate() const;
  // Whether the appearance alignment runs, so frames' images are wanted.
  bool usesImages() const { return refine && model == "perspective" && image_memory_mb > 0; }
};

}  // namespace imt
