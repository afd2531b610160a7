// IMU orientation options (anchors, paper 3.4). One struct, each field documented once in visit();
// config/default.yaml is generated from it.
#pragma once

#include <Eigen/Geometry>

#include <string>

namespace imt {

// config/default.yaml would mirror this under `imu:`.
struct ImuOptions {
  // Each field is documented once, in visit() below (config/default.yaml is
  // generated from it: track_bag --print-default-config).
  bool use_fused_orientation =
      false;               // samples carrying orientation: use it instead of integrating the gyro
  double gyro_bias_x = 0;
  double gyro_bias_y = 0;
  double gyro_bias_z = 0;
  bool estimate_gyro_bias = true;
  double still_seconds = 1.0;
  double still_block_seconds =
      0.1;  // s; stillness is judged on means over blocks this long (vibration averages out)
  double still_gyro_max =
      0.15;  // rad/s; block-mean |gyro - bias| above this: not still (must exceed the raw bias)
  double still_gyro_tight = 0.03;
  double still_replace_seconds = 3.0;
  double still_accel_max = 0.3;
  bool still_needs_video = true;
  bool video_bias = true;
  double video_bias_seconds = 30.0;
  double still_video_rate = 0.005;
  double gravity = 9.81;
  double max_gyro = 35.0;
  double max_accel = 160.0;
  double window_seconds = 10.0;
  double max_gap_seconds = 0.1;

  template <class V>
  void visit(V& v) {
    v("use_fused_orientation", use_fused_orientation,
      "samples carrying orientation: use it instead of integrating the gyro");
    v("gyro_bias_x", gyro_bias_x, "rad/s, fixed gyro bias in the IMU frame (subtracted)");
    v("gyro_bias_y", gyro_bias_y, "rad/s, fixed gyro bias in the IMU frame (subtracted)");
    v("gyro_bias_z", gyro_bias_z, "rad/s, fixed gyro bias in the IMU frame (subtracted)");
    v("estimate_gyro_bias", estimate_gyro_bias, "a still stretch's mean gyro replaces the bias");
    v("still_seconds", still_seconds, "s a still stretch must last before its mean gyro is used");
    v("still_block_seconds", still_block_seconds,
      "s; stillness is judged on means over blocks this long (vibration averages out)");
    v("still_gyro_max", still_gyro_max,
      "rad/s; block-mean |gyro - bias| above this: not still (must exceed the raw bias)");
    v("still_gyro_tight", still_gyro_tight, "rad/s; the same once a bias has been estimated");
    v("still_replace_seconds", still_replace_seconds,
      "s a later still stretch must last to replace an estimate (less if the estimate's was "
      "shorter)");
    v("still_accel_max", still_accel_max,
      "m/s^2; block-mean accel farther than this from g or the stretch's first block: not still");
    v("still_needs_video", still_needs_video,
      "a still stretch counts only once the video saw the camera not turning over it (a slow smooth turn "
      "feels still to the IMU); false: the IMU alone judges (no camera)");
    v("still_video_rate", still_video_rate,
      "rad/s; the video's mean turn rate over a still stretch must stay under this, and each frame's under "
      "4 times it");
    v("video_bias", video_bias,
      "while the camera moves, the bias is tracked from the video (the gyro's turn between frames against the "
      "camera's turn seen in the background) and used until a still stretch gives one (needs estimate_gyro_bias)");
    v("video_bias_seconds", video_bias_seconds, "s of frames the video's bias estimate averages over");
    v("gravity", gravity, "m/s^2, local gravity magnitude");
    v("max_gyro", max_gyro,
      "rad/s; a sample whose gyro magnitude is over this is dropped as broken (2000 deg/s, the widest MEMS range)");
    v("max_accel", max_accel,
      "m/s^2; a sample whose accelerometer magnitude is over this is dropped as broken (16 g, the widest common "
      "range)");
    v("window_seconds", window_seconds, "s of integrated orientations kept for queries");
    v("max_gap_seconds", max_gap_seconds,
      "s between IMU samples above which the stream is interrupted: no orientation inside the gap, "
      "roll/pitch re-levelled after it, yaw carried over");
  }
  // Empty when usable, else "imu.<field>: must be ... (got ...)".
  std::string validate() const;

  Eigen::Vector3d gyroBias() const {
    return Eigen::Vector3d(gyro_bias_x, gyro_bias_y, gyro_bias_z);
  }
};

}  // namespace imt
