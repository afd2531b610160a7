// Planar target tracking (paper 3.3): the four corners of a target of known
// physical size, from a rigid 6DoF pose solved every frame with
// Levenberg-Marquardt (Ceres, robust loss, autodiff Jacobians), warm-started
// from the previous pose. Features inside the target's quad live on its plane
// as 3D points (target coordinates), keyed by feature ID, so the model gathers
// evidence over time instead of being rebuilt; features that enter the quad
// later join through the current pose once a second frame confirms them, and
// points whose reprojection disagrees (occluders, off-plane) are dropped. The
// corners are the projections of the target's corners, so there is no skew
// drift as with chained homographies (which remain available, model
// "homography", for comparison).
//
// Target frame (interface spec): origin at the target's centre, x along
// TL->TR, y along TL->BL, z = x cross y. Pixels as in docs/conventions.md.
//
// Lens distortion (the CameraModel given to create()): corners in and out
// are image pixels; the pose is fitted to undistorted feature positions
// (ideal pinhole pixels), the corners are projected through the lens, and
// the appearance alignment samples the frame through the lens (the template
// lives on the undistorted plane, so its homography stays exact).
//
// Usage:
//   std::string err;
//   auto t = imt::PlanarTargetTracker::create(opt, 1, corners, 0.6, 0.45, K, md_at_init, &err);
//   for each next frame (either direction):  t->step(md, H_last_to_this, H_valid);
//   t->state();
// Threading: one tracker per thread; copyable (a copy continues independently).
#pragma once

#include "instant_motion_tracking/core/types.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <array>
#include <map>
#include <memory>
#include <string>

namespace imt {

struct PlanarTargetOptions {
  std::string model =
      "perspective";  // perspective (rigid 6DoF pose, LM) | homography (chained, for comparison)
  double loss_scale = 1.5;     // px; Huber loss scale of the reprojection residuals
  int max_iterations = 20;     // LM iterations per frame
  double outlier_error = 3.0;  // px; model points reprojecting worse than this (and 3x the points'
                               // noise level) are dropped
  double join_error = 1.0;     // px; a new point joins when its second observation agrees this well
                               // (or within 1.5x the points' noise level)
  int min_points = 6;          // fewer model points visible: predicted by the camera motion
  double confidence_points = 30;  // model points at which confidence reaches 1
  double prediction_gate =
      0.06;  // fraction of the target's size; a pose from fewer than 2 min_points points farther
             // than this from the camera-motion prediction is not used (dragged by an occluder)
  bool refine = true;       // align the target's look at placement with each frame (ECC)
  int template_size = 256;  // px; long side of the rectified template kept at placement
  double refine_min_correlation = 0.75;  // ECC correlation below which an alignment is not used
  double refine_max_correction =
      0.15;  // fraction of the target's size on screen; larger corrections are not used
  double refine_max_step =
      0.06;  // the same for a target aligned on the last frame; grows by this per unaligned frame
  int refine_iterations = 10;    // ECC iterations per pyramid level at most
  double refine_epsilon = 1e-3;  // ECC stops when the correlation changes less than this
  double refine_min_visible =
      0.35;  // fraction of the target (in view) that must be seen uncovered to align
  double refine_outlier_sigma =
      3.0;  // noise levels by which a covered (occluded) template pixel differs
  double refine_search_range = 0.4;  // fraction of the target's size searched around it when the
                                     // alignment fails or fits loosely (0: no search)
  double refine_search_below =
      0.95;  // ECC correlation below which the search is tried too and the better fit kept
  double refine_search_min_score = 0.6;  // normalised correlation a search's match must reach
  double refine_search_margin =
      0.15;  // by which it must beat the best match elsewhere (no repeated-pattern confusion)
  double image_memory_mb = 512;  // MB of gray frames kept for the alignment (oldest dropped first)

  template <class V>
  void visit(V& v) {
    v("model", model, "perspective (rigid 6DoF pose, LM) | homography (chained, for comparison)");
    v("loss_scale", loss_scale, "px; Huber loss scale of the reprojection residuals");
    v("max_iterations", max_iterations, "LM iterations per frame");
    v("outlier_error", outlier_error,
      "px; model points reprojecting worse (and 3x the points' noise level) are dropped");
    v("join_error", join_error,
      "px; a new point joins when its second observation agrees this well (or within 1.5x the "
      "points' noise level)");
    v("min_points", min_points, "fewer model points visible: predicted by the camera motion");
    v("confidence_points", confidence_points, "model points at which confidence reaches 1");
    v("prediction_gate", prediction_gate,
      "fraction of the target's size; a pose from fewer than 2 min_points points farther than this "
      "from the camera-motion prediction is not used (dragged by an occluder)");
    v("refine", refine, "align the target's look at placement with each frame (ECC): no drift");
    v("template_size", template_size, "px; long side of the rectified template kept at placement");
    v("refine_min_correlation", refine_min_correlation,
      "ECC correlation below which an alignment is not used");
    v("refine_max_correction", refine_max_correction,
      "fraction of the target's size on screen; larger corrections are not used");
    v("refine_max_step", refine_max_step,
      "the same for a target aligned on the last frame; grows by this per unaligned frame");
    v("refine_iterations", refine_iterations, "ECC iterations per pyramid level at most");
    v("refine_epsilon", refine_epsilon, "ECC stops when the correlation changes less than this");
    v("refine_min_visible", refine_min_visible,
      "fraction of the target (in view) that must be seen uncovered to align");
    v("refine_outlier_sigma", refine_outlier_sigma,
      "noise levels by which a covered (occluded) template pixel differs");
    v("refine_search_range", refine_search_range,
      "fraction of the target's size searched around it when the alignment fails or fits loosely "
      "(0: no search)");
    v("refine_search_below", refine_search_below,
      "ECC correlation below which the search is tried too and the better fit kept");
    v("refine_search_min_score", refine_search_min_score,
      "normalised correlation a search's match must reach");
    v("refine_search_margin", refine_search_margin,
      "by which it must beat the best match elsewhere (no repeated-pattern confusion)");
    v("image_memory_mb", image_memory_mb,
      "MB of gray frames kept for the alignment (oldest dropped first)");
  }
  std::string validate() const;
};

enum class TargetStatus : uint8_t { kTracked, kOutOfView, kLost };
const char* targetStatusName(TargetStatus s);  // "tracked", "out_of_view", "lost"

struct PlanarTargetState {
  uint32_t id = 0;
  double stamp = 0;
  std::array<cv::Point2d, 4> corners;  // TL, TR, BR, BL projections (px)
  Eigen::Isometry3d T_cam_target = Eigen::Isometry3d::Identity();
  double width_m = 0, height_m = 0;
  TargetStatus status = TargetStatus::kTracked;
  double confidence = 0;
  int points = 0;        // model points that supported this frame's pose
  double rms_error = 0;  // px, reprojection RMS of those points
  double correlation =
      0;  // ECC correlation of the appearance alignment (0: not aligned this frame)
  double visible =
      0;  // fraction of the target in view that the alignment saw uncovered (0: not aligned)
  std::string reason;  // why lost
};

// Empty when the four corners form a usable convex quad (TL, TR, BR, BL in
// either winding), else why not.
std::string validateQuad(const std::array<cv::Point2d, 4>& corners);
// validateQuad() plus a positive, finite physical size: empty when a target
// request is usable, else why not.
std::string validateTargetRequest(const std::array<cv::Point2d, 4>& corners, double width_m,
                                  double height_m);

class PlanarTargetTracker {
 public:
  // Fails (nullptr + message) on a bad quad or size, or invalid intrinsics.
  // `gray` (optional, the frame of `md`) gives the target's appearance; without
  // it the appearance is taken from the first frame step() gets an image with.
  static std::unique_ptr<PlanarTargetTracker> create(
      const PlanarTargetOptions& options, uint32_t id, const std::array<cv::Point2d, 4>& corners,
      double width_m, double height_m, const CameraModel& k, const MotionData& md,
      std::string* error, const cv::Mat& gray = cv::Mat());

  // Moves the target to the frame of `md` (the next frame in either time
  // direction). `H_last_to_this` is the background motion from the last
  // frame to this one; used (when valid) to predict a target with too few
  // visible points, or whose few points disagree with it (prediction_gate:
  // dragged by an occluder). With `gray` (the frame's image, CV_8UC1) and
  // `refine`, the pose is then aligned with the target's appearance at
  // placement, so errors of long feature tracks do not accumulate; what
  // covers part of the target is masked out, and a target the alignment lost
  // (or that drifted while covered) is searched for around the pose and
  // re-acquired (refine_search_*).
  const PlanarTargetState& step(const MotionData& md, const Eigen::Matrix3d& H_last_to_this,
                                bool H_valid, const cv::Mat& gray = cv::Mat());
  const PlanarTargetState& state() const { return state_; }

 private:
  PlanarTargetTracker() = default;
  void projectCorners();
  bool poseFromCorners(const std::array<cv::Point2d, 4>& corners);
  Eigen::Vector2d project(const Eigen::Vector3d& p_target) const;
  bool backProject(const Eigen::Vector2d& px, Eigen::Vector2d* xy) const;
  void addNewPoints(const MotionData& md);
  void stepPerspective(const MotionData& md, const Eigen::Matrix3d* H_last_to_this);
  void stepHomography(const MotionData& md);
  void predict(const Eigen::Matrix3d& H);
  // Appearance (template) alignment, see planar_target.cpp.
  struct Appearance;
  Eigen::Matrix3d planeToImage() const;
  bool captureAppearance(const cv::Mat& gray);
  bool align(const cv::Mat& gray, Eigen::Matrix3d* G, double* cc, double* visible,
             const cv::Mat& seen = cv::Mat()) const;
  bool search(const cv::Mat& gray, Eigen::Matrix3d* G, cv::Mat* seen) const;
  bool refine(const cv::Mat& gray);
  void dropDisagreeingPoints(const MotionData& md, bool reanchor);

  PlanarTargetOptions options_;
  CameraModel k_;
  PlanarTargetState state_;
  std::map<uint32_t, Eigen::Vector2d> model_;       // feature id -> (X, Y) on the target plane (m)
  std::map<uint32_t, Eigen::Vector2d> candidates_;  // first observation, awaiting confirmation
  std::map<uint32_t, bool> rejected_;               // ids that must not join again
  std::map<uint32_t, Eigen::Vector2d> last_px_;     // last frame's positions (homography model)
  double residual_level_ = 0;  // px, smoothed noise level of the model points' residuals
  int frames_unaligned_ = 0;   // frames since the appearance alignment was last used
  std::shared_ptr<const Appearance> appearance_;  // shared by copies (forward/backward)
};

}  // namespace imt
