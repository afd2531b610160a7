#include "instant_motion_tracking/ros/nodelet_health.h"

namespace imt {

bool NodeletHealth::noteReset(const std::string& reason) {
  ++resets_;
  last_reset_reason_ = reason;
  const ros::WallTime now = ros::WallTime::now();
  if (!last_reset_log_.isZero() && now - last_reset_log_ < ros::WallDuration(1.0)) return false;
  last_reset_log_ = now;
  return true;
}

}  // namespace imt
