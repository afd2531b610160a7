// AnchorNodelet (pluginlib: instant_motion_tracking/AnchorNodelet)
//
// Calibration-free 6DoF anchors (core/anchor_manager.h), as a view of the
// manager's TrackingSession (ros/session_nodelet.h): a region around the
// tapped pixel tracked on motion data (translation and scale, predicted while
// out of view) + the camera rotation from the IMU, z up from gravity.
// Frames come from a MotionAnalysisNodelet in the same manager, else it subscribes:
//   motion_data     instant_motion_tracking/MotionData (from MotionAnalysisNodelet)
//   camera_info     sensor_msgs/CameraInfo (the camera model; the image feeder's otherwise)
// Subscribes:
//   imu             sensor_msgs/Imu, into the session (gyro integrated, or its orientation with
//                   ~imu/use_fused_orientation); NaN and out-of-order samples are
//                   dropped with a throttled warning; a jump back restarts it
// Reads tf2: the rotation of the IMU message's frame in the image frame
//   (/tf_static), unless ~anchors/rotation_cam_imu fixes it; identity until found.
// Publishes, stamped with the image stamp (each frame once the IMU has passed
// its stamp, at most ~anchors/imu_wait_seconds later: the session holds the
// frame's trackers back until then, so that the IMU rotation can stand in for
// a frame without a camera model):
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
// imu is subscribed while the session wants frames (an output has a
// subscriber, an item exists, add_anchor was just refused for want of frames,
// or ~always_subscribe is set). Without IMU the anchors are translation-only
// (status no_imu, throttled warning). Time going back clears the anchors and
// the tf buffer. Bad requests get success=false and a message.
#pragma once

#include "instant_motion_tracking/AddAnchor.h"
#include "instant_motion_tracking/RemoveRegion.h"
#include "instant_motion_tracking/ros/session_nodelet.h"

#include <sensor_msgs/Imu.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <memory>

namespace imt {

class AnchorNodelet : public SessionNodelet {
 public:
  // Leaves the session first: no frame result may reach a half-destroyed nodelet.
  ~AnchorNodelet() override { leaveSession(); }
  void onInit() override;

 private:
  bool wantsFrames() override;
  void onResult(const FrameResult& result, const std_msgs::Header& header, const ros::WallTime& received) override;
  bool inputsWanted() override;
  void subscribeInputs(bool wanted) override;
  void imuCb(const sensor_msgs::ImuConstPtr& msg);
  // The IMU -> camera rotation from tf, until known (session lock held).
  void lookupRotation(TrackingSession& s, const std::string& imu_frame);
  static std::string rotationReport(const TrackingSession& s);
  static std::string biasReport(const TrackingSession& s);
  bool addCb(instant_motion_tracking::AddAnchor::Request& req, instant_motion_tracking::AddAnchor::Response& res);
  bool removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                instant_motion_tracking::RemoveRegion::Response& res);

  std::unique_ptr<tf2_ros::Buffer> tf_buffer_;
  std::unique_ptr<tf2_ros::TransformListener> tf_listener_;
  std::unique_ptr<tf2_ros::TransformBroadcaster> tf_;
  ros::Subscriber imu_sub_;
  ros::Publisher anchors_pub_, markers_pub_;
  ros::ServiceServer add_srv_, remove_srv_;
  // Under the hub's lock: the frames named by tf, and whether an IMU sample came.
  std::string camera_frame_, imu_frame_;
  bool imu_seen_ = false;
};

}  // namespace imt
