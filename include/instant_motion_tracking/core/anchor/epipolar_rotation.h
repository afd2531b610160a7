// The IMU-to-camera rotation from frames the camera also travelled between
// (issue 14): a phone filming from a car, a walking robot, a hand carried
// forward. There a frame's background moves with parallax, and the turn
// read from its homography (cameraTurn) takes part of the travel for a
// turn: on the phone clip filmed from a car driving forward that reading's
// best rotation is 11.7 deg from the clip's axis mapping, and its residual
// refuses it.
//
// This fit reads each feature's own motion instead. Between two frames a
// feature's rays r0 and r1 obey the epipolar constraint
//   r1 . (t x (R r0)) = 0,   R = R_cam_imu exp(theta_imu)^T R_cam_imu^T,
// where theta_imu is the gyro's turn over that feature's interval and t the
// frame's direction of travel, unknown. The fit finds R_cam_imu and every
// frame's t together, minimising robust (Cauchy) epipolar distances in
// pixels with Ceres. Features that move with the camera (a dashboard, a
// reflection in the windscreen) or with an object are outliers to it.
//
// The gyro's turn is the caller's to give for each pair's own interval, so
// a rolling shutter is modelled by the times the caller reads it at: a row
// read `readout * (y / height - 0.5)` after the middle row (rows read top
// to bottom). On the phone clip (readout 33.3 ms) that model brings the
// rotation from 4.2 to 2.7 deg of the clip's axis mapping.
//
// The fit starts from a rough rotation (CamImuRotationEstimator's best
// fit, even when refused) and needs turns about two axes. It states how
// sharp it is by fitting the even and the odd frames apart from the
// whole's answer: `sharp` when each half lands within max_spread_deg of
// the whole (about half the halves' own gap; not a bound on the error:
// on the phone clip the whole is 3.2 deg from the mapping with halves 1.4
// deg from it).
//
// Usage (see AnchorManager):
//   imt::EpipolarCamImuRotation est;
//   est.addFrame(pairs, focal_px);   // each frame interval's pairs, gyro turns read
//   if (auto fit = est.fit(rough); fit && fit->sharp) use(fit->R_cam_imu);
// Threading: not thread-safe.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <deque>
#include <optional>
#include <vector>

namespace imt {

// A feature seen in two frames: its ideal camera rays (K^-1 [u v 1]) and
// the gyro's turn (rotation vector, the IMU's axes) between the times its
// rows were read (the frames' stamps under a global shutter).
struct EpipolarPair {
  Eigen::Vector3d ray0, ray1;
  Eigen::Vector3d theta_imu = Eigen::Vector3d::Zero();
};

// The result of EpipolarCamImuRotation::fit().
struct EpipolarRotationFit {
  Eigen::Quaterniond R_cam_imu = Eigen::Quaterniond::Identity();
  double spread_deg = -1;      // the larger angle between the whole fit and either half's
  double inlier_fraction = 0;  // pairs within 2 loss scales of their frame's epipolar line
  int frames = 0, pairs = 0;
  bool sharp = false;          // spread_deg within max_spread_deg and enough inliers
};

// The IMU-to-camera rotation from feature pairs of travelling frames (see
// the file comment).
class EpipolarCamImuRotation {
 public:
  struct Options {
    int min_frames = 40;            // frame intervals before a fit
    int max_frames = 120;           // the most recent kept
    int max_pairs_per_frame = 60;   // a frame's pairs kept, evenly spread over its list
    double loss_px = 1.0;           // Cauchy scale of the epipolar distance, px
    double max_spread_deg = 1.5;    // the halves' agreement for a sharp fit
    double min_inlier_fraction = 0.5;
    // The turns must span two axes (as CamImuRotationEstimator's): else the
    // rotation about the one axis is free, and the halves agree on the start.
    double min_axis_ratio = 0.05;
    // Frames whose gyro turn reaches this (rad; as CamImuRotationEstimator's
    // min_angle) must be at least half of min_frames: smaller turns are
    // mostly noise, and turns of half a pixel gave a "sharp" fit 2.3 deg off.
    double min_angle = 0.2 * M_PI / 180;
  };
  EpipolarCamImuRotation() = default;
  explicit EpipolarCamImuRotation(const Options& o) : options_(o) {}
  const Options& options() const { return options_; }

  // One frame interval's feature pairs, with the camera's focal length in
  // pixels (the distances' unit); non-finite pairs are dropped, and a frame
  // with fewer than 8 pairs is not kept.
  void addFrame(const std::vector<EpipolarPair>& pairs, double focal_px);
  size_t frames() const { return frames_.size(); }
  void clear() { frames_.clear(); }

  // The fit from `start` (R_cam_imu), once min_frames frames are kept;
  // none before, when too few frames turn by min_angle, or when the turns
  // span one axis only. Not `sharp` without its halves when the whole's
  // inliers are too few.
  std::optional<EpipolarRotationFit> fit(const Eigen::Quaterniond& start) const;

 private:
  struct Frame {
    std::vector<EpipolarPair> pairs;
    double focal_px = 0;
  };
  Options options_;
  std::deque<Frame> frames_;
};

}  // namespace imt
