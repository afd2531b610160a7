// MotionAnalysisNodelet (pluginlib: instant_motion_tracking/MotionAnalysisNodelet)
//
// Runs the core motion analysis (core/motion_analysis.h) on an image stream.
// Subscribes (through image_transport, so `_image_transport:=compressed` works):
//   image                     sensor_msgs/Image
// Publishes (lazily: inputs are subscribed only while an output has a
// subscriber, unless ~always_subscribe):
//   motion_data               instant_motion_tracking/MotionData, stamped with the image stamp
//   debug_image               sensor_msgs/Image (bgr8): features, fg red / bg green, vectors
// Parameters (private namespace, documented in config/default.yaml):
//   ~motion_analysis/*        MotionAnalysisOptions
//   ~queue_size, ~always_subscribe, ~diagnostic_period
// Diagnostics (/diagnostics, ros/nodelet_health.h): input rate, processing time and
// delay after the image stamp.
// Bad input (unsupported encoding, malformed image, size change, time going
// backwards) is logged once or throttled, and the nodelet lives on.
#pragma once

#include "instant_motion_tracking/core/motion_analysis.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/ros/nodelet_health.h"

#include <image_transport/image_transport.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>

#include <memory>
#include <mutex>

namespace imt {

class MotionAnalysisNodelet : public nodelet::Nodelet {
 public:
  void onInit() override;

 private:
  void connectCb();
  void imageCb(const sensor_msgs::ImageConstPtr& msg);

  Config config_;
  std::unique_ptr<MotionAnalyzer> analyzer_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  image_transport::Subscriber image_sub_;
  image_transport::Publisher debug_pub_;
  ros::Publisher motion_pub_;
  std::mutex connect_mutex_;
  uint64_t frames_ = 0;
  NodeletHealth health_;
};

}  // namespace imt
