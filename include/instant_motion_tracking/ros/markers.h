// rviz markers (0.5 s lifetime, so several nodelets can share the topic): each region's box drawn on a plane
// 1 m in front of the camera (back-projected through the camera model,
// distortion included), in the
// image's frame, with its id and status as text.
#pragma once

#include "instant_motion_tracking/core/anchor/anchor_manager.h"
#include "instant_motion_tracking/core/planar/planar_target.h"
#include "instant_motion_tracking/core/region/region_tracker.h"

#include <std_msgs/Header.h>
#include <visualization_msgs/MarkerArray.h>

#include <vector>

namespace imt {

visualization_msgs::MarkerArray regionMarkers(const std::vector<RegionState>& states,
                                              const std_msgs::Header& header,
                                              const CameraModel& k);

// Each planar target's outline in 3D (its pose and size), in the image's
// frame, with its id as text; lost targets are left out.
visualization_msgs::MarkerArray planarTargetMarkers(const std::vector<PlanarTargetState>& states,
                                                    const std_msgs::Header& header);

// Each anchor's axes (x red, y green, z blue, `axis_m` long) at its pose, in
// the image's frame, with its id and status as text; lost anchors are left out.
visualization_msgs::MarkerArray anchorMarkers(const std::vector<AnchorState>& states,
                                              const std_msgs::Header& header, double axis_m = 0.1);

}  // namespace imt
