// ImageInput: a nodelet's image subscription, handing its callback 8-bit gray
// frames (ros/image_conversion.h).
//
//   transport "raw"         sensor_msgs/Image on `topic` (image_transport's raw
//                           topic, subscribed without loading its plugin)
//   transport "compressed"  sensor_msgs/CompressedImage on `topic`/compressed
//                           (the image_transport naming), decoded here: Debian
//                           ships no compressed_image_transport plugin.
//
// A message that cannot be converted goes to `on_error` with a one-line reason
// (the nodelet warns, throttled, and counts it); nothing throws.
//
// Usage:
//   input_.subscribe(nh, "image", config_.ros.image_transport, queue,
//                    [this](const std_msgs::Header& h, const cv::Mat& gray) { ... },
//                    [this](const std::string& why) { ... });
//   if (input_) ...;  input_.shutdown();
// Threading: the callbacks run on the node handle's callback queue.
#pragma once

#include <sensor_msgs/Image.h>
#include <opencv2/core.hpp>
#include <ros/ros.h>
#include <std_msgs/Header.h>

#include <functional>
#include <memory>
#include <string>

namespace imt {

class ImageInput {
 public:
  using FrameCallback = std::function<void(const std_msgs::Header&, const cv::Mat& gray)>;
  using ErrorCallback = std::function<void(const std::string& why)>;

  // Subscribes (replacing any earlier subscription). `transport` must be
  // "raw" or "compressed" (RosShellOptions::validate() checks it).
  void subscribe(ros::NodeHandle nh, const std::string& topic, const std::string& transport, int queue,
                 FrameCallback on_frame, ErrorCallback on_error);
  void shutdown();
  explicit operator bool() const { return bool(raw_) || bool(compressed_); }
  // The resolved topic subscribed to ("" when none).
  const std::string& topic() const { return topic_; }

 private:
  ros::Subscriber raw_, compressed_;
  std::string topic_;
};

}  // namespace imt
