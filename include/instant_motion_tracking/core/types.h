// Plain data types shared by every module of the core library.
// No ROS in here: the core builds and is tested without catkin.
#pragma once

#include "instant_motion_tracking/core/camera_model.h"  // CameraModel, used with these types

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

namespace imt {

// One IMU sample in the IMU's own frame (sensor_msgs/Imu without ROS).
struct ImuSample {
  double stamp = 0;                                   // s
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();     // rad/s
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();    // m/s^2, specific force (reads +g "up" at rest)
  Eigen::Quaterniond orientation = Eigen::Quaterniond::Identity();  // R_world_imu, world z up
  bool has_orientation = false;
};

// Background (camera) motion model classes, lowest to highest.
enum class MotionModel : uint8_t { kInvalid = 0, kTranslation = 1, kSimilarity = 2, kHomography = 3 };

// "translation", "similarity", "homography" or "invalid" (the CSV spelling).
const char* motionModelName(MotionModel m);

// Camera motion between two consecutive frames.
struct CameraMotion {
  MotionModel model = MotionModel::kInvalid;
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity();  // previous -> current pixels, H(2,2) = 1
  int features = 0;  // features the fit saw
  int inliers = 0;   // of which background inliers
};

// One feature of the motion data. Positions are full-resolution pixels.
struct FeatureMotion {
  uint32_t id = 0;          // persistent feature-path ID
  float x = 0, y = 0;       // current position
  float dx = 0, dy = 0;     // motion previous -> current minus camera motion at that point
  float bg_weight = 1;      // 0 (foreground) .. 1 (background)
  bool foreground = false;
  uint16_t age = 0;         // frames tracked
  // LK's patch error of its last step: the mean absolute grey-level
  // difference over its window, at the resolution it was tracked at; 0 when
  // unknown. A window that straddles an object's edge and what moves behind
  // it matches worse than the object's own (region trackers weigh by it).
  float patch_error = 0;
};

// How a FeatureMotion's fields are read when they may come from anywhere
// (a message, motion data given by hand): the one rule for the message
// conversion and the trackers alike.
// A patch error if known (positive and finite), else 0 (unknown).
inline float knownPatchError(float e) { return std::isfinite(e) && e > 0 ? e : 0.f; }
// A background weight within 0..1; no number (NaN, infinite) reads as
// background (1), what the motion analysis gives when it has nothing to
// compare with.
inline float knownBackgroundWeight(float w) { return std::isfinite(w) ? std::clamp(w, 0.f, 1.f) : 1.f; }

// Compact per-frame motion data (paper 3.1): all the trackers ever see.
struct MotionData {
  double stamp = 0;  // s, the image header stamp
  int width = 0, height = 0;
  // Image px per px of the resolution the features were tracked at (4 at
  // analysis_width 320 of a 1280 px image; 1: full resolution): how far a
  // feature's position and motion may be off, as trackers weigh them.
  float analysis_scale = 1;
  CameraMotion camera;
  std::vector<FeatureMotion> features;
  // Set by sortByX(): features ordered by x, and the largest |current -
  // previous| displacement (px), so trackers crop a region's features by
  // binary search and per-region work stays proportional to them.
  bool sorted_by_x = false;
  float max_shift = 0;
  void sortByX();
};

// A step's length in usual frame intervals (2, 3, ... after frames were
// dropped upstream), as the trackers scale their constant-velocity
// predictions by it: bounded to [0.1, 8] (beyond 8 frames such a guess is
// worth little), 1 when not a positive finite number (unknown).
double boundedIntervalRatio(double ratio);

}  // namespace imt
