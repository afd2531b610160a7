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
  topic_ = nh.resolveName(topic);
  if (!it_) it_ = std::make_unique<image_transport::ImageTransport>(nh);
  // Explicit hints: the default ones would read ~image_transport of the
  // nodelet manager, not of this nodelet.
  raw_ = it_->subscribe(
      topic, queue,
      [on_frame, on_error](const sensor_msgs::ImageConstPtr& msg) {
        cv::Mat gray;
        std::string why;
        if (imageToGray(*msg, &gray, &why)) {
          on_frame(msg->header, gray);
        } else {
          on_error(why);
        }
      },
      ros::VoidPtr(), image_transport::TransportHints("raw"));
}

void ImageInput::shutdown() {
  raw_.shutdown();
  compressed_.shutdown();
  raw_ = image_transport::Subscriber();
  topic_.clear();
}

}  // namespace imt
