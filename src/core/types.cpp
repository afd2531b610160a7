#include "instant_motion_tracking/core/types.h"

#include <algorithm>
#include <cmath>

namespace imt {

void MotionData::sortByX() {
  std::sort(features.begin(), features.end(),
            [](const FeatureMotion& a, const FeatureMotion& b) { return a.x < b.x; });
  const Eigen::Matrix3d H_inv = camera.H.inverse();
  float m = 0;
  for (const FeatureMotion& f : features) {
    if (f.age == 0) continue;
    const Eigen::Vector3d cur(f.x - f.dx, f.y - f.dy, 1.0);
    const Eigen::Vector3d prev = H_inv * cur;
    if (std::abs(prev.z()) < 1e-12) continue;
    m = std::max(m, static_cast<float>(std::abs(prev.x() / prev.z() - f.x)));
  }
  max_shift = m;
  sorted_by_x = true;
}

double boundedIntervalRatio(double ratio) {
  return std::isfinite(ratio) && ratio > 0 ? std::clamp(ratio, 0.1, 8.0) : 1.0;
}

const char* motionModelName(MotionModel m) {
  switch (m) {
    case MotionModel::kTranslation: return "translation";
    case MotionModel::kSimilarity: return "similarity";
    case MotionModel::kHomography: return "homography";
    case MotionModel::kInvalid: break;
  }
  return "invalid";
}

}  // namespace imt
