// PlanarTargetNodelet (pluginlib: instant_motion_tracking/PlanarTargetNodelet)
//
// Tracks planar targets of known size (core/planar_target_manager.h) as a view
// of the manager's TrackingSession (ros/session_nodelet.h): a rigid 6DoF pose
// per frame, so the four corners do not drift.
// Frames come from a MotionAnalysisNodelet in the same manager (with their
// images, for the appearance alignment, ~planar_tracking/refine); without one
// it subscribes:
//   motion_data          instant_motion_tracking/MotionData, joined by stamp
//   image                sensor_msgs/Image (raw; for the alignment) with message_filters;
//                        a frame whose image does not come is tracked on features alone
// and then also (the image feeder subscribes it otherwise):
//   camera_info          sensor_msgs/CameraInfo (the camera model; without it, ~default_hfov_deg)
// Publishes, stamped with the image stamp of the motion data:
//   planar_targets       instant_motion_tracking/PlanarTargetArray
//   markers              visualization_msgs/MarkerArray (each target's outline, in 3D)
//   tf2                  <frame_prefix>planar_target_<id>, child of the image frame (~publish_tf)
// Services:
//   add_planar_target    AddPlanarTarget: corners TL, TR, BR, BL at a cached stamp (0 = latest) + size
//   add_image_target     AddImageTarget: a picture (file or sensor_msgs/Image) + size, searched for
//                        from the latest frame on while not tracked (on threads of their own,
//                        answered ~planar_tracking/detect_interval frames later)
//   remove_planar_target RemoveRegion
// Parameters (private namespace; config/default.yaml): cache_seconds, default_hfov_deg,
//   planar_tracking/*, publish_tf, frame_prefix, queue_size, always_subscribe, diagnostic_period.
// Diagnostics (/diagnostics, ros/nodelet_health.h): input rate, processing time and
// delay after the image stamp, planar targets by status.
// Frames are wanted while an output has a subscriber, a target exists, or
// ~always_subscribe is set. Bad requests get success=false and a message;
// the nodelet lives on.
#pragma once

#include "instant_motion_tracking/AddImageTarget.h"
#include "instant_motion_tracking/AddPlanarTarget.h"
#include "instant_motion_tracking/RemoveRegion.h"
#include "instant_motion_tracking/ros/session_nodelet.h"

#include <tf2_ros/transform_broadcaster.h>

#include <memory>

namespace imt {

class PlanarTargetNodelet : public SessionNodelet {
 public:
  // Leaves the session first: no frame result may reach a half-destroyed nodelet.
  ~PlanarTargetNodelet() override { leaveSession(); }
  void onInit() override;

 private:
  bool wantsFrames() override;
  bool wantsImages() const override;
  void onResult(const FrameResult& result, const std_msgs::Header& header, const ros::WallTime& received) override;
  bool addCb(instant_motion_tracking::AddPlanarTarget::Request& req,
             instant_motion_tracking::AddPlanarTarget::Response& res);
  bool addImageCb(instant_motion_tracking::AddImageTarget::Request& req,
                  instant_motion_tracking::AddImageTarget::Response& res);
  bool removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                instant_motion_tracking::RemoveRegion::Response& res);

  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  ros::Publisher targets_pub_, markers_pub_;
  ros::ServiceServer add_srv_, add_image_srv_, remove_srv_;
};

}  // namespace imt
