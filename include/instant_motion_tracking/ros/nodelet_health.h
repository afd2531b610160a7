// NodeletHealth: what a nodelet reports about itself, kept out of the nodelets.
// Resets (time going backwards at a bag loop, an image size change, a bad
// frame) are counted and each is logged once, at most one log per wall-clock
// second: ROS time may be sim time that jumps back, which would confuse a
// ROS-time throttle, and a stream that resets on every frame must not flood.
//
// Usage (in a callback, under the nodelet's lock):
//   if (!reason.empty() && health_.noteReset(reason)) NODELET_WARN("%s", reason.c_str());
// Threading: not thread-safe; callers serialise.
#pragma once

#include <ros/time.h>

#include <cstdint>
#include <string>

namespace imt {

class NodeletHealth {
 public:
  // Counts a reset; true when it should be logged now.
  bool noteReset(const std::string& reason);
  uint64_t resets() const { return resets_; }
  const std::string& lastResetReason() const { return last_reset_reason_; }

 private:
  uint64_t resets_ = 0;
  std::string last_reset_reason_;
  ros::WallTime last_reset_log_;
};

}  // namespace imt
