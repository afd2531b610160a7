// The IMU-to-camera rotation found from the video (issue 14, calibration-free
// anchors without /tf_static).
//
// Between two frames the camera turns by one rotation, which the camera sees
// in the background's motion and the gyro measures in its own axes. Their
// rotation vectors are the same vector in two frames:
//   theta_cam = R_cam_imu theta_imu.
// Pairs over at least two rotation axes fix R_cam_imu: the rotation that best
// maps the gyro's vectors onto the camera's (orthogonal Procrustes: SVD of
// sum theta_cam theta_imu^T, as Eigen::umeyama does for points).
//
// A camera rotation comes from a frame's camera motion H (image pixels,
// previous -> current) by rotationFromHomography(): rays through a grid of
// pixels and through their images under H, aligned by a rotation and a
// zoom. H is explained so only when the camera turned more than it moved
// sideways (or the scene is far); cameraTurn() leaves out a frame whose rays
// the turn does not explain. The focal length comes from camera_info, or from default_hfov_deg
// without it: a focal length off by k% scales the visual rotation about x
// and y by about k% while the rotation about z stays, which tilts the
// estimate's axes by up to ~k/2% of a radian (under 3 deg for 10%).
//
// Usage (AnchorManager does this for each frame):
//   imt::CamImuRotationEstimator est;
//   Eigen::Vector3d theta_cam;
//   if (imt::cameraTurn(K, md.camera, &theta_cam)) est.add(theta_cam, imt::rotationVector(R_imu0_imu1));
//   if (auto q = est.estimate()) use(*q);
// Threading: not thread-safe.
#pragma once

#include "instant_motion_tracking/core/camera_model.h"
#include "instant_motion_tracking/core/types.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <deque>
#include <optional>

namespace imt {

// The rotation R (ideal rays at the previous frame -> rays at the current
// one) that best explains the camera motion H between image pixels, over a
// grid covering the middle 80% of the image, together with a zoom about the
// principal point (the camera moving along its axis, as a hand walking
// forward does: 2-5% per frame on the phone clip); `rms_px` is how far, in
// pixels, H's images of the grid are from the turn's and zoom's. False when
// H or the camera model is unusable, or the grid's rays fall behind the camera.
bool rotationFromHomography(const CameraModel& k, const Eigen::Matrix3d& H, Eigen::Matrix3d* R, double* rms_px);

// The rotation R (ideal rays at the previous frame -> rays at the current
// one) of a camera moving over a plane with the given normal (camera frame,
// either sign), from the plane's motion H between image pixels: H between
// ideal rays is lambda (R + t n^T) for a translation t (over the plane's
// distance), so on the plane's own directions it acts as the rotation alone,
// however the camera moved. The floor under a walking camera is such a
// plane, with the IMU's up as its normal: there a turn-and-zoom fit
// (rotationFromHomography) reads part of the walk as a turn. `rms_px` is how
// far the grid's images under H are from the plane model's (what decides
// whether the background was that plane). False as rotationFromHomography().
bool rotationFromPlaneHomography(const CameraModel& k, const Eigen::Matrix3d& H, const Eigen::Vector3d& normal,
                                 Eigen::Matrix3d* R, double* rms_px);

// The camera's turn over a frame interval as a rotation vector (the camera at
// the frame in the camera at the previous one), from the frame's camera
// motion; false when it has no model or the turn does not explain at least
// as much of it as it leaves: what the turn and zoom leave is over the turn's
// size in pixels (and over half a pixel), as when the camera moved sideways
// over a near scene or the background was not what moved. (A rolling shutter
// leaves 1-3 px of a 5 px turn on the phone clip: such frames stay in, and
// the estimator's residual test judges them together.)
// `rms_px` (optional): what the turn and zoom leave, as rotationFromHomography's.
bool cameraTurn(const CameraModel& k, const CameraMotion& camera, Eigen::Vector3d* theta, double* rms_px = nullptr);

class CamImuRotationEstimator {
 public:
  struct Options {
    double min_angle = 0.2 * M_PI / 180;  // rad; smaller turns between frames are mostly noise
    int min_pairs = 30;                   // pairs before an estimate is given
    // The turns must span two axes: the second-largest eigenvalue of
    // sum theta_imu theta_imu^T at least this fraction of the largest.
    double min_axis_ratio = 0.05;
    double max_residual = 0.25;  // rms of |theta_cam - R theta_imu| / |theta_imu| for an estimate
    size_t max_pairs = 2000;     // the most recent pairs kept
  };

  CamImuRotationEstimator() = default;
  explicit CamImuRotationEstimator(const Options& o) : options_(o) {}
  const Options& options() const { return options_; }

  // One frame interval's rotation vectors (rad): the camera's and the
  // gyro's. Ignored when non-finite or a turn under min_angle.
  void add(const Eigen::Vector3d& theta_cam, const Eigen::Vector3d& theta_imu);
  // R_cam_imu once min_pairs pairs over two axes agree on it (residual() at
  // most max_residual); none before.
  std::optional<Eigen::Quaterniond> estimate() const { return estimate_; }
  // The fit's residual: rms of |theta_cam - R theta_imu| / |theta_imu| (-1 before any fit).
  double residual() const { return residual_; }
  // The last fit, also when its residual refused it (for reports and tests).
  std::optional<Eigen::Quaterniond> bestFit() const { return best_fit_; }
  size_t pairs() const { return pairs_.size(); }
  void reset();

 private:
  void fit();

  struct Pair {
    Eigen::Vector3d cam, imu;
  };
  Options options_;
  std::deque<Pair> pairs_;
  std::optional<Eigen::Quaterniond> estimate_, best_fit_;
  double residual_ = -1;
};

}  // namespace imt
