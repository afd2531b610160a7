// MotionAnalysisNodelet (pluginlib: instant_motion_tracking/MotionAnalysisNodelet)
//
// Feeds the images of a camera stream to the manager's TrackingSession
// (ros/session_nodelet.h): each image is decoded once and analysed (core
// motion analysis, paper 3.1); the tracker nodelets of the same manager
// publish from the same session.
// Subscribes (ros/image_input.h):
//   image                     sensor_msgs/Image (~image_transport raw), or
//   image/compressed          sensor_msgs/CompressedImage (~image_transport compressed)
//   camera_info, sibling of image   the camera model (without it, ~default_hfov_deg)
// Publishes (lazily: the image is subscribed only while an output has a
// subscriber, a tracker of the session wants frames, or ~always_subscribe):
//   motion_data               instant_motion_tracking/MotionData, stamped with the image stamp
//   debug_image               sensor_msgs/Image (bgr8): features, fg red / bg green, vectors,
//                             and the session's tracker outputs of the same frame
//                             (core/debug_draw.h): region boxes, planar-target quads,
//                             anchors, with ids and statuses
// Parameters (private namespace, documented in config/default.yaml):
//   ~motion_analysis/*        MotionAnalysisOptions, and the trackers' (the session's)
//   ~queue_size, ~always_subscribe, ~diagnostic_period, ~image_transport, ~default_hfov_deg
// Diagnostics (/diagnostics, ros/nodelet_health.h): input rate, processing time and
// delay after the image stamp.
// Bad input (unsupported encoding, malformed image, size change, time going
// backwards) is logged once or throttled, and the nodelet lives on.
#pragma once

#include "instant_motion_tracking/ros/image_input.h"
#include "instant_motion_tracking/ros/session_nodelet.h"

#include <sensor_msgs/Image.h>

namespace imt {

class MotionAnalysisNodelet : public SessionNodelet {
 public:
  // Leaves the session first: no frame result may reach a half-destroyed nodelet.
  ~MotionAnalysisNodelet() override { leaveSession(); }
  void onInit() override;

 private:
  bool wantsFrames() override;
  void onResult(const FrameResult& result, const std_msgs::Header& header, const ros::WallTime& received) override;
  bool inputsWanted() override;
  void subscribeInputs(bool wanted) override;
  void imageCb(const std_msgs::Header& header, const cv::Mat& gray);

  ImageInput image_sub_;
  ros::Publisher debug_pub_, motion_pub_;
};

}  // namespace imt
