#!/usr/bin/env bash
# The core library must stay ROS-free (it builds and is tested without catkin).
# Debian installs ROS headers in /usr/include, so a stray include would still
# compile: this check rejects it by name.
set -u
root=${1:-$(dirname "$0")/..}
hits=$(grep -rnE '#include *[<"](ros/|rosbag/|nodelet/|pluginlib/|image_transport/|cv_bridge/|tf2_ros/|tf2_eigen/|tf2_geometry_msgs/|[a-z_]+_msgs/|instant_motion_tracking/(ros|io)/)' \
  "$root/include/instant_motion_tracking/core" "$root/src/core" 2>/dev/null)
if [ -n "$hits" ]; then
  echo "ROS (or non-core) includes in the core library:"
  echo "$hits"
  exit 1
fi
echo "core library: no ROS includes"
