// MotionAnalysisNodelet (pluginlib: instant_motion_tracking/MotionAnalysisNodelet)
//
// Runs the core motion analysis (core/motion_analysis.h) on an image stream.
// Subscribes (ros/image_input.h):
//   image                     sensor_msgs/Image (~image_transport raw), or
//   image/compressed          sensor_msgs/CompressedImage (~image_transport compressed)
// Publishes (lazily: inputs are subscribed only while an output has a
// subscriber, unless ~always_subscribe):
//   motion_data               instant_motion_tracking/MotionData, stamped with the image stamp
//   debug_image               sensor_msgs/Image (bgr8): features, fg red / bg green, vectors
// Parameters (private namespace, documented in config/default.yaml):
//   ~motion_analysis/*        MotionAnalysisOptions
//   ~queue_size, ~always_subscribe, ~diagnostic_period, ~image_transport
// Diagnostics (/diagnostics, ros/nodelet_health.h): input rate, processing time and
// delay after the image stamp.
// Bad input (unsupported encoding, malformed image, size change, time going
// backwards) is logged once or throttled, and the nodelet lives on.
#pragma once

#include "instant_motion_tracking/core/motion_analysis.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/ros/image_input.h"
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
  void subscribeImage();  // connect_mutex_ held
  void imageCb(const std_msgs::Header& header, const cv::Mat& gray);

  Config config_;
  std::unique_ptr<MotionAnalyzer> analyzer_;
  std::unique_ptr<image_transport::ImageTransport> it_;
  ImageInput image_sub_;
  image_transport::Publisher debug_pub_;
  ros::Publisher motion_pub_;
  std::mutex connect_mutex_;
  uint64_t frames_ = 0;
  NodeletHealth health_;
};

}  // namespace imt
