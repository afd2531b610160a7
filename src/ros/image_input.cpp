#include "instant_motion_tracking/ros/image_input.h"

#include "instant_motion_tracking/ros/image_conversion.h"

namespace imt {

void ImageInput::subscribe(ros::NodeHandle nh, const std::string& topic, const std::string& transport, int queue,
                           FrameCallback on_frame, ErrorCallback on_error) {
  shutdown();
  if (transport == "compressed") {
    topic_ = nh.resolveName(topic) + "/compressed";
    compressed_ = nh.subscribe<sensor_msgs::CompressedImage>(
        topic_, queue, [on_frame, on_error](const sensor_msgs::CompressedImageConstPtr& msg) {
          cv::Mat gray;
          std::string why;
          if (compressedImageToGray(*msg, &gray, &why)) {
            on_frame(msg->header, gray);
          } else {
            on_error(why);
          }
        });
    return;
  }
  // Raw frames are subscribed directly (the topic image_transport's raw
  // transport would read): no plugin is loaded, so a subscription made while
  // other nodelets of the manager load their libraries cannot hit
  // class_loader's race between concurrent library loads (it once killed the
  // manager with a TransportLoadException for 'raw').
  topic_ = nh.resolveName(topic);
  raw_ = nh.subscribe<sensor_msgs::Image>(topic_, queue, [on_frame, on_error](const sensor_msgs::ImageConstPtr& msg) {
    cv::Mat gray;
    std::string why;
    if (imageToGray(*msg, &gray, &why)) {
      on_frame(msg->header, gray);
    } else {
      on_error(why);
    }
  });
}

void ImageInput::shutdown() {
  raw_.shutdown();
  compressed_.shutdown();
  topic_.clear();
}

}  // namespace imt
