#!/usr/bin/env bash
# The core library and the scene generator (sim) must stay ROS-free (they build
# and are tested without catkin). Debian installs ROS headers in /usr/include,
# so a stray include would still compile: this check rejects it by name.
set -u
root=${1:-$(dirname "$0")/..}
hits=$(grep -rnE '#include *[<"](ros/|rosbag/|nodelet/|pluginlib/|image_transport/|cv_bridge/|tf2_ros/|tf2_eigen/|tf2_geometry_msgs/|[a-z_]+_msgs/|instant_motion_tracking/(ros|io)/)' \
  "$root/include/instant_motion_tracking/core" "$root/src/core" \
  "$root/include/instant_motion_tracking/sim" "$root/src/sim" 2>/dev/null)
if [ -n "$hits" ]; then
  echo "ROS (or non-core) includes in the core or sim library:"
  echo "$hits"
  exit 1
fi
# The core must not depend on the scene generator either.
hits=$(grep -rnE '#include *[<"]instant_motion_tracking/sim/' \
  "$root/include/instant_motion_tracking/core" "$root/src/core" 2>/dev/null)
if [ -n "$hits" ]; then
  echo "scene generator (sim) includes in the core library:"
  echo "$hits"
  exit 1
fi
echo "core and sim libraries: no ROS includes; core does not include sim"
