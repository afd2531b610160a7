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

#include "instant_motion_tracking/core/planar/planar_target_options.h"
#include "instant_motion_tracking/core/types.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <array>
#include <map>
#include <memory>
#include <string>

namespace imt {

// kNotFound: an image target not found yet, or not found again since it was
// lost (no corners, no pose). kPredicted: in view, but its place rests on the
// camera motion's prediction: this frame neither its features nor its
// appearance placed it (too few features, or a pose that conflicts with the
// camera motion, and no alignment taken), or its look has not confirmed it
// since it was last carried so (the features that joined it meanwhile may be
// whatever lay in the predicted quad).
enum class TargetStatus : uint8_t { kTracked, kOutOfView, kLost, kNotFound, kPredicted };
// "tracked", "out_of_view", "lost", "not_found", "predicted"
const char* targetStatusName(TargetStatus s);

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
  // Corners and pose are meaningful (tracked, or predicted in or out of view).
  bool hasPose() const {
    return status == TargetStatus::kTracked || status == TargetStatus::kOutOfView ||
           status == TargetStatus::kPredicted;
  }
};

// Empty when the four corners form a usable convex quad (TL, TR, BR, BL in
// either winding), else why not.
std::string validateQuad(const std::array<cv::Point2d, 4>& corners);
// validateQuad() with the corners clockwise in the image (TL, TR, BR, BL of
// a target seen from its front, as INIT.yaml requires: a mirrored quad has
// no pose), plus a positive, finite physical size: empty when a target
// request is usable, else why not.
std::string validateTargetRequest(const std::array<cv::Point2d, 4>& corners, double width_m,
                                  double height_m);
// The physical size alone (positive, finite): empty when usable, else why not.
std::string validateTargetSize(double width_m, double height_m);

class PlanarTargetTracker {
 public:
  // Fails (nullptr + message) on a bad quad or size, or invalid intrinsics.
  // `gray` (optional, the frame of `md`) gives the target's appearance; without
  // it the appearance is taken from the first frame step() gets an image with.
  // `picture` (optional, CV_8UC1: an image target's front view, its corners
  // the target's) gives the appearance instead of the frame.
  static std::unique_ptr<PlanarTargetTracker> create(
      const PlanarTargetOptions& options, uint32_t id, const std::array<cv::Point2d, 4>& corners,
      double width_m, double height_m, const CameraModel& k, const MotionData& md,
      std::string* error, const cv::Mat& gray = cv::Mat(), const cv::Mat& picture = cv::Mat());

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
  // The target's look at placement, rectified (CV_8UC1, the template the
  // alignment uses): the picture a target given by its corners is found
  // again by. Empty without an appearance (refine off, model homography, no
  // image) or when the frame did not show the whole target then.
  cv::Mat lookAtPlacement() const;

 private:
  PlanarTargetTracker() = default;
  void projectCorners();
  bool poseFromCorners(const std::array<cv::Point2d, 4>& corners);
  Eigen::Vector2d project(const Eigen::Vector3d& p_target) const;
  bool backProject(const Eigen::Vector2d& px, Eigen::Vector2d* xy) const;
  void addNewPoints(const MotionData& md);
  // `predicted`: the last frame's corners moved by the camera motion (null
  // when it is not known).
  void stepPerspective(const MotionData& md, const std::array<cv::Point2d, 4>* predicted);
  void stepHomography(const MotionData& md);
  void predict(const std::array<cv::Point2d, 4>& predicted);  // corners as the camera motion moved them
  // Appearance (template) alignment, see planar_target.cpp.
  struct Appearance;
  Eigen::Matrix3d planeToImage() const;
  bool captureAppearance(const cv::Mat& gray, const cv::Mat& picture = cv::Mat());
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
  // px, smoothed distance of the confirmed poses' corners from the camera
  // motion's prediction: how well this target usually moves with it.
  double prediction_level_ = -1;  // < 0: not measured yet
  bool unconfirmed_ = false;  // carried by the camera motion since its look last confirmed it
  std::shared_ptr<const Appearance> appearance_;  // shared by copies (forward/backward)
};

}  // namespace imt
