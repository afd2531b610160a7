// Shared helpers of the scene-generator tests: a preset's options (failing
// the test for an unknown name), a generator (failing it on bad options), and
// the error figures they score with.
#pragma once

#include "instant_motion_tracking/sim/scene.h"

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace imt {
namespace test {

inline SceneOptions preset(const std::string& name) {
  std::optional<SceneOptions> o = SceneOptions::fromPreset(name);
  EXPECT_TRUE(o.has_value()) << name;
  return o ? *o : SceneOptions();
}

inline std::unique_ptr<SceneGenerator> make(const SceneOptions& o) {
  std::string err;
  auto scene = SceneGenerator::create(o, &err);
  EXPECT_TRUE(scene != nullptr) << err;
  return scene;
}

// The p-quantile (0..1) of `v` (the element at p (n - 1) when sorted).
inline double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(p * (v.size() - 1))];
}

// The median (upper middle element); NaN for none.
inline double median(std::vector<double> v) {
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The angle (deg) of the rotation between a and b.
inline double angleDeg(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return Eigen::AngleAxisd(a.transpose() * b).angle() * 180 / M_PI;
}

// The POT alignment error: RMS of the four corner distances.
inline double cornerRms(const std::array<cv::Point2d, 4>& a, const std::array<cv::Point2d, 4>& b) {
  double sq = 0;
  for (int c = 0; c < 4; ++c) sq += std::pow(cv::norm(a[c] - b[c]), 2);
  return std::sqrt(sq / 4);
}

}  // namespace test
}  // namespace imt
