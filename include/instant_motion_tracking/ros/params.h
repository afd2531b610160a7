// The one place that loads ROS parameters into the options structs. Every
// default is taken from the struct itself (the value it holds when passed in),
// so defaults cannot drift between the code, config/default.yaml and the
// parameter server.
#pragma once

#include "instant_motion_tracking/io/config.h"

#include <ros/node_handle.h>

#include <string>

namespace imt {

// Reads `config` from `nh` (a nodelet's private handle), parameter names and
// nesting as in config/default.yaml, through the YAML loader (io/config.h),
// so it is exactly as strict: an unknown parameter, a wrong type or a value
// that fails validation gives false with a message naming the parameter, and
// `config` is unchanged.
bool loadConfigFromRos(const ros::NodeHandle& nh, Config* config, std::string* error);

}  // namespace imt
