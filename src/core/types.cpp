#include "instant_motion_tracking/core/types.h"

#include <cmath>

namespace imt {

CameraIntrinsics CameraIntrinsics::fromFieldOfView(int w, int h, double hfov_deg) {
  CameraIntrinsics k;
  k.width = w;
  k.height = h;
  k.fx = k.fy = 0.5 * w / std::tan(0.5 * hfov_deg * M_PI / 180.0);
  k.cx = 0.5 * w;
  k.cy = 0.5 * h;
  k.valid = w > 0 && h > 0 && hfov_deg > 0 && hfov_deg < 180;
  return k;
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
