// MotionAnalysisNodelet (pluginlib: instant_motion_tracking/MotionAnalysisNodelet)
//
// Runs the core motion analysis (core/motion_analysis.h) on an image stream.
// Subscribes (ros/image_input.h):
//   image                     sensor_msgs/Image (~image_transport raw), or
//   image/compressed          sensor_msgs/CompressedImage (~image_transport compressed)
// Publishes (lazily: inputs are subscribed only while an output has a
// subscriber, unless ~always_subscribe):
//   motion_data               instant_motion_tracking/MotionData, stamped with the image stamp
//   debug_image               sensor_msgs/Image (bgr8): features, fg red / bg green, vectors,
//                             and the trackers' outputs of the same frame (core/debug_draw.h):
//                             region boxes, planar-target quads, anchors, with ids and statuses
// Subscribes for debug_image only (while it has a subscriber):
//   regions, planar_targets, anchors   the trackers' outputs; a frame's debug image waits
//                             for the states of its stamp from every tracker heard in the
//                             last 0.5 s, at most kDebugWaitSeconds (0.25 s) of wall time (else
//                             it is drawn with the latest states, not older than 0.5 s)
//   camera_info, sibling of image   intrinsics for the 3D axes (without it, ~default_hfov_deg)
// Parameters (private namespace, documented in config/default.yaml):
//   ~motion_analysis/*        MotionAnalysisOptions
//   ~queue_size, ~always_subscribe, ~diagnostic_period, ~image_transport, ~default_hfov_deg
// Diagnostics (/diagnostics, ros/nodelet_health.h): input rate, processing time and
// delay after the image stamp.
// Bad input (unsupported encoding, malformed image, size change, time going
// backwards) is logged once or throttled, and the nodelet lives on.
#pragma once

#include "instant_motion_tracking/AnchorArray.h"
#include "instant_motion_tracking/PlanarTargetArray.h"
#include "instant_motion_tracking/TrackedRegionArray.h"
#include "instant_motion_tracking/core/debug_draw.h"
#include "instant_motion_tracking/core/motion_analysis.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/ros/image_input.h"
#include "instant_motion_tracking/ros/nodelet_health.h"

#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>

#include <deque>
#include <memory>
#include <mutex>

namespace imt {

class MotionAnalysisNodelet : public nodelet::Nodelet {
 public:
  void onInit() override;

 private:
  void connectCb();
  void subscribeImage();  // connect_mutex_ held
  void imageCb(const std_msgs::Header& header, const cv::Mat& gray);
  // debug_image: overlay inputs, and publishing the frames waiting for them.
  void updateOverlaySubscriptions();
  void regionsCb(const instant_motion_tracking::TrackedRegionArrayConstPtr& msg);
  void targetsCb(const instant_motion_tracking::PlanarTargetArrayConstPtr& msg);
  void anchorsCb(const instant_motion_tracking::AnchorArrayConstPtr& msg);
  void infoCb(const sensor_msgs::CameraInfoConstPtr& msg);
  // Publishes the waiting frames in order while the first is complete, has
  // waited kDebugWaitSeconds, more than kMaxDebugFrames wait, or `all`.
  void publishDebug(bool all);

  // A frame analysed for debug_image, waiting for the trackers' states.
  struct DebugFrame {
    cv::Mat gray;
    MotionData md;
    std_msgs::Header header;
    ros::WallTime analysed;
  };
  static constexpr double kDebugWaitSeconds = 0.25;
  static constexpr size_t kMaxDebugFrames = 8;

  Config config_;
  std::unique_ptr<MotionAnalyzer> analyzer_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  ImageInput image_sub_;
  image_transport::Publisher debug_pub_;
  ros::Publisher motion_pub_;
  std::mutex connect_mutex_;
  std::mutex debug_mutex_;  // guards the members below
  ros::Subscriber regions_sub_, targets_sub_, anchors_sub_, info_sub_;
  ros::WallTimer debug_timer_;
  std::deque<DebugFrame> debug_frames_;
  OverlayHistory overlays_;
  CameraModel intrinsics_;
  double last_stamp_ = -1;
  uint64_t frames_ = 0;
  NodeletHealth health_;
};

}  // namespace imt
