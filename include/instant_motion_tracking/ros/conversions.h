// Conversions between the core's plain types and ROS messages. The pixel
// convention differs at this boundary only: CameraInfo uses OpenCV's (pixel
// centres at integers), the core ours (docs/conventions.md).
#pragma once

#include "instant_motion_tracking/AnchorArray.h"
#include "instant_motion_tracking/MotionData.h"
#include "instant_motion_tracking/PlanarTargetArray.h"
#include "instant_motion_tracking/TrackedRegionArray.h"
#include "instant_motion_tracking/core/anchor/anchor_manager.h"
#include "instant_motion_tracking/core/planar/planar_target.h"
#include "instant_motion_tracking/core/region/region_tracker.h"
#include "instant_motion_tracking/core/types.h"

#include <geometry_msgs/Pose.h>
#include <geometry_msgs/TransformStamped.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Imu.h>
#include <std_msgs/Header.h>

#include <string>

namespace imt {

instant_motion_tracking::MotionData toMsg(const MotionData& md, const std_msgs::Header& header);
MotionData fromMsg(const instant_motion_tracking::MotionData& msg);

// camera_info -> camera model (pixels: ours, cx = K[2] + 0.5). Raw images
// (`image_rectified` false): fx, fy, cx, cy from K, distortion from
// distortion_model and D (plumb_bob, rational_polynomial, equidistant; an
// all-zero or empty D is no distortion under any name). Rectified images
// (`image_rectified` true, parameter image_rectified): from P, D ignored.
// False (with the reason) when K (or P) is not a usable pinhole (a NaN or
// infinite entry, a zero or negative focal length, K's last row not 0 0 1, a
// focal length outside 0.001 .. 1000 image sizes, the principal point over
// an image size outside the image), there is no size or one over 65536 px,
// or D is non-zero with an unknown distortion_model, too many coefficients
// or a NaN; the caller then warns and falls back to the field-of-view
// default (CameraModel::forFrame).
bool fromCameraInfo(const sensor_msgs::CameraInfo& info, CameraModel* k, std::string* why,
                    bool image_rectified);
// The one check of a camera_info as it comes, live (the nodelet that feeds
// the session) and in track_bag: fromCameraInfo(), and a size that is the
// frames' (`frames`: the session's image size, 0 x 0 before the first
// frame). False with the reason for a refused one: the caller warns
// (throttled, or once per cause offline), counts it, and keeps the camera
// model it had.
bool cameraInfoForFrames(const sensor_msgs::CameraInfo& info, bool image_rectified, const cv::Size& frames,
                         CameraModel* k, std::string* why);
// Camera model -> camera_info (K, D with its model name, P = K; plumb_bob with
// a zero D without distortion).
sensor_msgs::CameraInfo toCameraInfo(const CameraModel& k, const std_msgs::Header& header);

// False (with the reason) for NaN/Inf values; orientation_covariance[0] == -1
// means the message carries no orientation.
bool fromImuMsg(const sensor_msgs::Imu& msg, ImuSample* sample, std::string* why);
sensor_msgs::Imu toImuMsg(const ImuSample& s, const std_msgs::Header& header);

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& T);

// A lost region's box is reported as NaN (no estimate).
instant_motion_tracking::TrackedRegion toMsg(const RegionState& s);
instant_motion_tracking::TrackedRegionArray toMsg(const std::vector<RegionState>& states,
                                                  const std_msgs::Header& header);

instant_motion_tracking::PlanarTarget toMsg(const PlanarTargetState& s);
instant_motion_tracking::PlanarTargetArray toMsg(const std::vector<PlanarTargetState>& states,
                                                 const std_msgs::Header& header);
// tf2 transforms `<prefix>planar_target_<id>` (children of header.frame_id),
// one per target that is not lost.
std::vector<geometry_msgs::TransformStamped> planarTargetTransforms(
    const std::vector<PlanarTargetState>& states, const std_msgs::Header& header,
    const std::string& frame_prefix);

// A lost anchor's pixel and pose are reported as NaN (no estimate).
instant_motion_tracking::Anchor toMsg(const AnchorState& s);
instant_motion_tracking::AnchorArray toMsg(const std::vector<AnchorState>& states, const std_msgs::Header& header);
// tf2 transforms `<prefix>anchor_<id>` (children of header.frame_id), one per
// anchor that is not lost (out_of_view and no_imu included: they have a pose).
std::vector<geometry_msgs::TransformStamped> anchorTransforms(const std::vector<AnchorState>& states,
                                                              const std_msgs::Header& header,
                                                              const std::string& frame_prefix);

// Tracker outputs back to the core states (for drawing them: debug_image).
// What a message does not carry (inliers' centroid, support, reasons) is left
// at its default; an unknown status reads as lost, a pose with a non-finite
// or zero quaternion as NaN (no 3D estimate).
Eigen::Isometry3d fromPoseMsg(const geometry_msgs::Pose& p);
RegionState fromMsg(const instant_motion_tracking::TrackedRegion& m, double stamp);
std::vector<RegionState> fromMsg(const instant_motion_tracking::TrackedRegionArray& m);
PlanarTargetState fromMsg(const instant_motion_tracking::PlanarTarget& m, double stamp);
std::vector<PlanarTargetState> fromMsg(const instant_motion_tracking::PlanarTargetArray& m);
AnchorState fromMsg(const instant_motion_tracking::Anchor& m, double stamp);
std::vector<AnchorState> fromMsg(const instant_motion_tracking::AnchorArray& m);

}  // namespace imt
