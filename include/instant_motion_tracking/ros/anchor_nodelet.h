// AnchorNodelet (pluginlib: instant_motion_tracking/AnchorNodelet)
//
// Calibration-free 6DoF anchors (core/anchor_manager.h): a region around the
// tapped pixel tracked on motion data (translation and scale, predicted while
// out of view) + the camera rotation from the IMU, z up from gravity.
// Subscribes:
//   motion_data     instant_motion_tracking/MotionData (from MotionAnalysisNodelet)
//   camera_info     sensor_msgs/CameraInfo (intrinsics; without it, ~default_hfov_deg)
//   imu             sensor_msgs/Imu (gyro integrated, or its orientation with
//                   ~imu/use_fused_orientation); NaN and out-of-order samples are
//                   dropped with a throttled warning; a jump back restarts it
// Reads tf2: the rotation of the IMU message's frame in the image frame
//   (/tf_static), unless ~anchors/rotation_cam_imu fixes it; identity until found.
// Publishes, stamped with the image stamp of the motion data (each frame once
// the IMU has passed its stamp, at most ~anchors/imu_wait_seconds later; only
// then does the frame reach the region tracking, so that the IMU rotation can
// stand in for a frame without a camera model):
//   anchors         instant_motion_tracking/AnchorArray
//   markers         visualization_msgs/MarkerArray (each anchor's axes)
//   tf2             <frame_prefix>anchor_<id>, child of the image frame (~publish_tf)
// Services:
//   add_anchor      AddAnchor: the tapped pixel at a cached stamp (0 = latest), depth (0 = default)
//   remove_anchor   RemoveRegion
// Parameters (private namespace; config/default.yaml): cache_seconds,
//   default_hfov_deg, region_tracking/*, imu/*, anchors/*, publish_tf,
//   frame_prefix, queue_size, always_subscribe, diagnostic_period.
// Diagnostics (/diagnostics, ros/nodelet_health.h): input rate, processing
//   time (including the wait for the IMU), anchors by status; resets logged once.
// motion_data and imu are subscribed while an output has a subscriber, an
// anchor exists, add_anchor was just refused for want of frames, or
// ~always_subscribe is set (unsubscribing forgets the frames and the IMU). Without IMU the anchors
// are translation-only (status no_imu, throttled warning). Motion data going back in time clears
// the anchors and the tf buffer. Bad requests get success=false and a message.
#pragma once

#include "instant_motion_tracking/AddAnchor.h"
#include "instant_motion_tracking/MotionData.h"
#include "instant_motion_tracking/RemoveRegion.h"
#include "instant_motion_tracking/core/anchor_manager.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/ros/nodelet_health.h"

#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Imu.h>
#include <std_msgs/Header.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <deque>
#include <memory>
#include <mutex>

namespace imt {

class AnchorNodelet : public nodelet::Nodelet {
 public:
  void onInit() override;

 private:
  // Frames waiting for the IMU to pass their stamp before they reach the
  // region manager (so the IMU rotation can stand in for a missing camera model).
  struct Pending {
    std_msgs::Header header;
    MotionData md;
    ros::WallTime started;  // when its callback began
  };
  void updateSubscription();  // call with mutex_ held
  void motionCb(const instant_motion_tracking::MotionDataConstPtr& msg);
  void infoCb(const sensor_msgs::CameraInfoConstPtr& msg);
  void imuCb(const sensor_msgs::ImuConstPtr& msg);
  bool addCb(instant_motion_tracking::AddAnchor::Request& req,
             instant_motion_tracking::AddAnchor::Response& res);
  bool removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                instant_motion_tracking::RemoveRegion::Response& res);
  void lookupRotation(const std::string& imu_frame);  // R_cam_imu from tf2, once found
  void flush(bool all);  // tracks and publishes the frames that are ready (all: every one)
  void track(const Pending& frame);

  Config config_;
  std::unique_ptr<RegionManager> regions_;
  std::unique_ptr<AnchorManager> anchors_;
  std::deque<Pending> pending_;
  NodeletHealth health_;
  std::string camera_frame_, imu_frame_;
  bool rotation_known_ = false, imu_seen_ = false;
  bool awaiting_frames_ = false;  // an add_anchor was refused for want of frames: stay subscribed
  ros::Subscriber motion_sub_, info_sub_, imu_sub_;
  ros::Publisher anchors_pub_, markers_pub_;
  ros::ServiceServer add_srv_, remove_srv_;
  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  std::mutex mutex_;
};

}  // namespace imt
