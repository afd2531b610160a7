// PlanarTargetNodelet (pluginlib: instant_motion_tracking/PlanarTargetNodelet)
//
// Tracks planar targets of known size from motion data (core/planar_target_manager.h):
// a rigid 6DoF pose per frame, so the four corners do not drift.
// Subscribes:
//   motion_data          instant_motion_tracking/MotionData (from MotionAnalysisNodelet)
//   image                sensor_msgs/Image (or image/compressed, ~image_transport), for the
//                        appearance alignment (~planar_tracking/refine); each motion_data
//                        waits for its image (at most two further frames) and is
//                        tracked on features alone when it does not come
//   camera_info          sensor_msgs/CameraInfo (intrinsics; without it, ~default_hfov_deg)
// Publishes, stamped with the image stamp of the motion data:
//   planar_targets       instant_motion_tracking/PlanarTargetArray
//   markers              visualization_msgs/MarkerArray (each target's outline, in 3D)
//   tf2                  <frame_prefix>planar_target_<id>, child of the image frame (~publish_tf)
// Services:
//   add_planar_target    AddPlanarTarget: corners TL, TR, BR, BL at a cached stamp (0 = latest) + size
//   remove_planar_target RemoveRegion
// Parameters (private namespace; config/default.yaml): cache_seconds, default_hfov_deg,
//   planar_tracking/*, publish_tf, frame_prefix, queue_size, always_subscribe, diagnostic_period, image_transport.
// Diagnostics (/diagnostics, ros/nodelet_health.h): input rate, processing time and
// delay after the image stamp, planar targets by status.
// motion_data (and image) are subscribed while an output has a subscriber, a
// target exists, or ~always_subscribe is set. Bad requests get success=false and a message;
// the nodelet lives on.
#pragma once

#include "instant_motion_tracking/AddPlanarTarget.h"
#include "instant_motion_tracking/MotionData.h"
#include "instant_motion_tracking/RemoveRegion.h"
#include "instant_motion_tracking/core/planar_target_manager.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/ros/image_input.h"
#include "instant_motion_tracking/ros/nodelet_health.h"

#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <tf2_ros/transform_broadcaster.h>

#include <deque>
#include <map>
#include <memory>
#include <mutex>

namespace imt {

class PlanarTargetNodelet : public nodelet::Nodelet {
 public:
  void onInit() override;

 private:
  void updateSubscription();  // call with mutex_ held
  void motionCb(const instant_motion_tracking::MotionDataConstPtr& msg);
  void imageCb(const std_msgs::Header& header, const cv::Mat& gray);
  void flush(bool all);  // tracks the motion data whose image came or will not; mutex_ held
  void track(const instant_motion_tracking::MotionData& msg, const ros::WallTime& started);
  bool wantImages() const;
  void infoCb(const sensor_msgs::CameraInfoConstPtr& msg);
  bool addCb(instant_motion_tracking::AddPlanarTarget::Request& req,
             instant_motion_tracking::AddPlanarTarget::Response& res);
  bool removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                instant_motion_tracking::RemoveRegion::Response& res);
  CameraModel intrinsics() const;  // camera_info's, else the field-of-view default

  Config config_;
  std::unique_ptr<MotionCache> cache_;
  std::unique_ptr<PlanarTargetManager> targets_;
  CameraModel info_;
  ros::Subscriber motion_sub_, info_sub_;
  ImageInput image_sub_;
  std::map<double, cv::Mat> images_;  // gray frames by stamp, waiting for their motion data
  struct Pending {
    instant_motion_tracking::MotionDataConstPtr msg;
    ros::WallTime started;
  };
  std::deque<Pending> pending_;  // motion data waiting for its image
  ros::WallTime last_image_;
  ros::Publisher targets_pub_, markers_pub_;
  ros::ServiceServer add_srv_, remove_srv_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  std::mutex mutex_;
  NodeletHealth health_;
};

}  // namespace imt
