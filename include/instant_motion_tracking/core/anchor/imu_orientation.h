// IMU orientation for the calibration-free 6DoF anchors (paper 3.4, issue 6):
// the rotation of the camera in a gravity-aligned world frame, from the
// gyroscope (integrated) or from the IMU's own fused orientation.
//
// Usage:
//   imt::ImuOrientation imu(options);                 // options.validate() must be empty
//   imu.setRotationCamImu(q_cam_imu);                 // from /tf_static (default identity)
//   std::string why;
//   if (!imu.add(sample, &why)) log_throttled(why);   // samples in stamp order
//   Eigen::Matrix3d R;
//   if (imu.R_world_cam(image_stamp, &R)) ...         // any stamp inside the window
//
// Frames (docs/conventions.md): world z up (gravity -z); R_a_b maps b into a.
// Without fused orientation the world yaw is arbitrary: the first
// accelerometer reading (specific force, +g "up" at rest) is rotated onto
// world +z by the smallest rotation. Roll and pitch are then observable, yaw
// only relative to the start.
//
// Gyro integration: between consecutive samples the body rate is the mean of
// the two readings minus the bias (midpoint rule), applied with the exact
// rotation-vector exponential: R_k = R_{k-1} Exp(w_mid dt).
//
// Gyro bias: the fixed gyro_bias_{x,y,z}, replaced (estimate_gyro_bias) by
// the mean gyro of any stretch of >= still_seconds made of consecutive blocks
// (still_block_seconds) whose mean gyro is within still_gyro_max of the
// current bias and whose mean accelerometer reading is within
// still_accel_max of g (norm) and of the stretch's first block mean. (A slow
// rotation about gravity below still_gyro_max cannot be told from a bias:
// keep still_seconds long enough for the use case.) Once a bias is known the
// gyro bound is still_gyro_tight, and a later stretch replaces the estimate
// only after max(still_seconds, min(still_replace_seconds, duration of the
// stretch behind the estimate)); while it lasts it keeps refining it. When a stretch
// first qualifies, its samples are re-integrated with the new bias; if it is
// the stretch the stream began with, the initial level is re-taken from its
// mean accelerometer reading (less noisy than the first reading).
//
// While the camera moves, the video tracks the bias instead (video_bias):
// see setVideoGyroBias() and VideoGyroBias (video_gyro_bias.h); a still
// stretch's estimate, when there is one, is kept over it.
//
// The video's agreement (still_needs_video, the default): a slow smooth turn
// (under still_gyro_max, with the accelerometer steady) feels still to the
// IMU, and its rate would be taken for the bias. So the camera's turns seen
// in the frames are reported (addVideoTurn(), AnchorManager does it for each
// frame), and a stretch qualifies only once the video has covered
// still_seconds of it: every frame turning under 4 still_video_rate, their
// sum under still_video_rate on average, none unknown (no camera model, or a
// motion the turn does not explain). A frame that turns, or that the video
// cannot read, ends the stretch. The video lags the IMU: a stretch waits for
// it. The turn is read from the rays with a zoom apart (cameraTurn()), so a
// camera moving straight ahead without turning still counts; one moving
// sideways over a near scene does not (the video cannot tell its turn).
// With still_needs_video and no frames at all, no bias is learnt.
//
// Gaps: samples farther apart than max_gap_seconds are not integrated across
// (the rate in between is unknown). Queries inside a gap return false; the
// first sample after it takes the orientation before it, re-levelled onto its
// accelerometer reading by the smallest rotation (roll and pitch observed
// again, yaw carried over). gaps() counts them.
//
// Memory: orientations of the last window_seconds are kept (queries outside
// [oldest, newest] stamp return false).
//
// Never throws on input data; bad samples are dropped with a reason.
// Not thread-safe: one writer, queries from the same thread (or lock outside).
#pragma once

#include "instant_motion_tracking/core/types.h"
#include "instant_motion_tracking/core/anchor/imu_options.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstddef>
#include <deque>
#include <optional>
#include <string>

namespace imt {

class ImuOrientation {
 public:
  // Throws std::invalid_argument on invalid options (validate()).
  explicit ImuOrientation(const ImuOptions& options = ImuOptions());

  // Appends one sample. false (and *why, if given) when it is dropped: a NaN or
  // infinite value, a stamp not after the previous accepted one, an unusable
  // fused orientation, or no accelerometer reading to level the first sample.
  bool add(const ImuSample& sample, std::string* why = nullptr);

  // Rotation of the IMU in the camera optical frame (R_cam_imu); a
  // non-finite or zero quaternion is ignored (returns false).
  bool setRotationCamImu(const Eigen::Quaterniond& R_cam_imu);
  // The rotation given by setRotationCamImu(); none until then, when the IMU
  // axes are taken for the camera's (identity). reset() keeps it: it belongs
  // to the rig, not to the stream.
  const std::optional<Eigen::Quaterniond>& rotationCamImu() const { return q_cam_imu_; }

  // The camera-IMU time offset: an image stamped t was taken when the IMU's
  // clock read t + offset (time_offset.h). The queries below take image
  // stamps and read the IMU at t + offset; the samples keep their own stamps
  // (oldestStamp(), newestStamp()). reset() keeps it: it belongs to the rig.
  // False (ignored) when not finite or over 1 s.
  bool setTimeOffset(double seconds);
  double timeOffset() const { return offset_; }

  // Orientation at image stamp t (slerp between the bracketing samples);
  // false when t + timeOffset() is outside [oldestStamp(), newestStamp()] or
  // no sample was accepted.
  bool R_world_imu(double t, Eigen::Matrix3d* R) const { return atImuStamp(t + offset_, R); }
  // The same at an IMU stamp.
  bool atImuStamp(double imu_stamp, Eigen::Matrix3d* R) const;
  bool R_world_cam(double t, Eigen::Matrix3d* R) const;
  // Camera rotation between two stamps: maps camera-at-t2 vectors into the
  // camera at t1 (R_world_cam(t1)^T R_world_cam(t2)). Yaw-free and bias-light:
  // only the gyro between t1 and t2 matters. False across a gap.
  bool R_cam1_cam2(double t1, double t2, Eigen::Matrix3d* R) const;
  // The IMU's turn between two IMU stamps (the IMU at s1 in the IMU at s0),
  // as the gyro measured it: without what setVideoGyroBias() took out in
  // between (that is a correction of the orientation, not a motion).
  // R_cam1_cam2() is read the same way. False outside the window.
  bool turnAtImuStamps(double s0, double s1, Eigen::Matrix3d* R) const;
  // A gap in the IMU stream between image stamps t1 and t2 (either order):
  // the rotation across it is unknown.
  bool acrossGap(double t1, double t2) const;
  // Rotation-only homography mapping pixels at t1 to pixels at t2:
  // H = K R_cam2_cam1 K^-1, H(2,2) = 1 (pure rotation or distant scene).
  bool rotationHomography(const Eigen::Matrix3d& K, double t1, double t2, Eigen::Matrix3d* H) const;
  // The same between *image* pixels of camera `k`: K R K^-1 holds between
  // ideal pinhole pixels only; through a distorting lens the motion is
  // distort(K R K^-1 undistort(p)), which no homography expresses, so this is
  // the homography that fits it best over the image
  // (CameraModel::imageHomography). Without distortion exactly the K overload.
  bool rotationHomography(const CameraModel& k, double t1, double t2, Eigen::Matrix3d* H) const;
  // The camera's turn between the frames at t0 and t1 as the video saw it
  // (rotation vector, rad, camera frame; image stamps); `known` false when the video could
  // not tell (no camera model, or not a turn). Stillness needs it (see the top).
  void addVideoTurn(double t0, double t1, const Eigen::Vector3d& theta, bool known);
  // World +z (up) in the camera frame at t (unit); zero vector when unknown.
  Eigen::Vector3d upInCamera(double t) const;

  // The bias currently subtracted (fixed or estimated), rad/s, IMU frame.
  const Eigen::Vector3d& gyroBias() const { return bias_; }
  // Where it came from: the options, a still stretch, or the video.
  enum class BiasSource { kFixed, kStill, kVideo };
  static const char* biasSourceName(BiasSource s);
  BiasSource biasSource() const { return bias_source_; }
  bool biasEstimated() const { return bias_source_ == BiasSource::kStill; }  // from a still stretch
  // A bias the video found while the camera moved (VideoGyroBias;
  // AnchorManager gives it) replaces the one in use from IMU stamp `at` on.
  // What the old bias put into the orientation between `from` and `at` is
  // taken out at `at`: the orientation at the last sample at or before `at`
  // becomes the one integrated with the new bias from the first sample at or
  // after `from`, and the samples after it follow. The orientations before
  // `at` stay as they were: a frame answered live reads the same later
  // (offline), and an anchor placed in that stretch keeps its orientation
  // at placement (it then carries the correction of the stretch before its
  // placement). Without samples to do so (a gap, fused orientation) nothing
  // is taken out. Refused (false) when a still stretch gave the bias (the
  // gyro's own mean is more precise), when estimate_gyro_bias is off, or
  // when not finite or over max_gyro.
  bool setVideoGyroBias(const Eigen::Vector3d& bias, double from, double at);
  bool empty() const { return window_.empty(); }
  size_t size() const { return window_.size(); }
  size_t gaps() const { return gaps_; }  // gaps met since construction or reset()
  double lastGapSeconds() const { return last_gap_; }
  double oldestStamp() const { return window_.empty() ? 0 : window_.front().stamp; }
  double newestStamp() const { return window_.empty() ? 0 : window_.back().stamp; }
  const ImuOptions& options() const { return options_; }
  void reset();  // forget every sample and the estimated bias

 private:
  struct Entry {
    double stamp = 0;
    Eigen::Quaterniond q_world_imu = Eigen::Quaterniond::Identity();
    Eigen::Vector3d gyro = Eigen::Vector3d::Zero();  // raw reading
    bool fused = false;                              // q taken from the sample's orientation
    bool after_gap = false;                          // not integrated from the previous entry
  };
  Eigen::Quaterniond integrate(const Entry& prev, const Eigen::Vector3d& gyro, double stamp) const;
  void updateStill(const ImuSample& s);
  void reintegrateFrom(double stamp);
  Eigen::Quaterniond levelFromAccel(const Eigen::Vector3d& accel) const;
  // What the video says of the current stretch's first `needed` seconds.
  enum class Video { kWait, kStill, kTurned };
  Video videoOnStretch(double needed) const;
  void endStretch();
  void prune();

  ImuOptions options_;
  std::optional<Eigen::Quaterniond> q_cam_imu_;
  double offset_ = 0;  // s, setTimeOffset()
  Eigen::Vector3d bias_ = Eigen::Vector3d::Zero();
  BiasSource bias_source_ = BiasSource::kFixed;
  double estimate_seconds_ = 0;  // duration of the still stretch behind the estimate
  std::deque<Entry> window_;
  std::deque<double> gap_stamps_;  // stamps of the entries after a gap, within the window
  // What setVideoGyroBias() took out: at the entry stamped `first`, the
  // orientations from it on were turned by `second` (world frame, on the left).
  std::deque<std::pair<double, Eigen::Quaterniond>> jumps_;
  size_t gaps_ = 0;
  double last_gap_ = 0;
  bool initial_stretch_ = false;  // the current still stretch began with the stream's first sample
  // Current block of samples (still detection).
  size_t block_count_ = 0;
  double block_start_ = 0;
  Eigen::Vector3d block_gyro_sum_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d block_accel_sum_ = Eigen::Vector3d::Zero();
  // Current still stretch (whole quiet blocks).
  size_t still_count_ = 0;
  double still_start_ = 0;
  bool still_confirmed_ = false;
  Eigen::Vector3d still_gyro_sum_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d still_accel_sum_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d still_accel_first_ = Eigen::Vector3d::Zero();
  // The video's frames (still_needs_video), in the order reported.
  struct VideoTurn {
    double t0 = 0, t1 = 0;
    Eigen::Vector3d theta = Eigen::Vector3d::Zero();
    bool turned = false;  // over 4 still_video_rate, or unknown
  };
  std::deque<VideoTurn> video_;
};

// Exp of a rotation vector (exact, stable near zero).
Eigen::Quaterniond quaternionExp(const Eigen::Vector3d& rotation_vector);
// Its inverse: the rotation vector (axis times angle, rad) of R.
Eigen::Vector3d rotationVector(const Eigen::Matrix3d& R);

}  // namespace imt
