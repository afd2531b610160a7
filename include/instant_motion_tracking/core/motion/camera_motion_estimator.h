// Camera (background) motion between two frames from feature correspondences
// (part of the motion analysis, paper 3.1).
//
// A translation (2DoF), a similarity (4DoF) and a homography (8DoF) are each
// fitted by iteratively reweighted least squares (Tukey weights, annealed
// scale), seeded by the best of a few 2-point similarity hypotheses and last
// frame's model. Per-correspondence prior weights carry the temporal
// coherence (features that were background last frame are favoured). The
// highest model whose inlier count, inlier fraction, inlier spread over the
// grid (homography) and parameters (scale, rotation, perspective, translation)
// pass their bounds is chosen; otherwise the next lower one; `kInvalid` with
// the identity when none holds. Every model's verdict is reported.
//
// Usage:
//   imt::CameraMotionEstimator estimator(options);
//   imt::CameraMotionEstimate e = estimator.estimate(prev, cur, prior, frame_size, &last_H);
//   if (e.motion.model != imt::MotionModel::kInvalid) use(e.motion.H);
// Positions are full-resolution pixels; H maps prev to cur, H(2,2) = 1.
// Threading: estimate() is const and may run concurrently on one estimator.
#pragma once

#include "instant_motion_tracking/core/options.h"
#include "instant_motion_tracking/core/types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <array>
#include <vector>

namespace imt {

// Verdict of one model class.
enum class ModelCheck : uint8_t {
  kOk = 0,
  kNotFitted,          // too few correspondences to try
  kDegenerate,         // the least-squares system was singular
  kTooFewInliers,      // below min_inliers_<model>
  kLowInlierFraction,  // below min_inlier_fraction
  kLowCoverage,        // homography inliers cover too few grid cells
  kScale,              // |scale - 1| > max_scale_change (or a reflection)
  kRotation,           // |rotation| > max_rotation
  kPerspective,        // |h20| or |h21| > max_perspective
  kTranslation,        // frame centre moved more than max_translation
};
const char* modelCheckName(ModelCheck c);

struct CameraMotionEstimate {
  CameraMotion motion;  // the chosen model (kInvalid, identity when none holds)
  struct Fit {
    Eigen::Matrix3d H = Eigen::Matrix3d::Identity();  // full-resolution px, H(2,2) = 1
    int inliers = 0;
    double coverage = 0;  // fraction of grid cells holding an inlier
    ModelCheck check = ModelCheck::kNotFitted;
  };
  // Indexed by MotionModel (1 translation, 2 similarity, 3 homography; 0 unused).
  std::array<Fit, 4> fits;
};

class CameraMotionEstimator {
 public:
  explicit CameraMotionEstimator(const MotionAnalysisOptions& options);

  // prev[i] -> cur[i] in full-resolution px; prior[i] in (0, 1] (empty = all
  // 1); frame: full-resolution size (sets the thresholds, the normalisation
  // and the coverage grid); previous_H: last frame's model as a seed (may be
  // null).
  CameraMotionEstimate estimate(const std::vector<cv::Point2f>& prev,
                                const std::vector<cv::Point2f>& cur,
                                const std::vector<float>& prior, const cv::Size& frame,
                                const Eigen::Matrix3d* previous_H = nullptr) const;

 private:
  MotionAnalysisOptions options_;
};

}  // namespace imt
