#include "instant_motion_tracking/ros/motion_analysis_nodelet.h"

#include "instant_motion_tracking/core/debug_draw.h"
#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/image_conversion.h"
#include "instant_motion_tracking/ros/params.h"

#include <cv_bridge/cv_bridge.h>
#include <pluginlib/class_list_macros.hpp>

namespace imt {

void MotionAnalysisNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  ros::NodeHandle& pnh = getPrivateNodeHandle();
  std::string error;
  if (!loadConfigFromRos(pnh, &config_, &error)) {
    NODELET_ERROR("bad parameter, using the defaults instead: %s", error.c_str());
  }
  analyzer_ = std::make_unique<MotionAnalyzer>(config_.pipeline.motion_analysis);
  it_ = std::make_unique<image_transport::ImageTransport>(nh);

  // Lazy subscription: hold the lock so a connect callback cannot run before
  // the publishers exist.
  std::lock_guard<std::mutex> lock(connect_mutex_);
  auto cb = [this](const auto&) { connectCb(); };
  motion_pub_ = nh.advertise<instant_motion_tracking::MotionData>(
      "motion_data", 10, ros::SubscriberStatusCallback(cb), ros::SubscriberStatusCallback(cb));
  debug_pub_ = it_->advertise("debug_image", 1, image_transport::SubscriberStatusCallback(cb),
                              image_transport::SubscriberStatusCallback(cb));
  if (config_.ros.always_subscribe) subscribeImage();
  health_.start(nh, pnh, getName(),
                nh.resolveName("image") + (config_.ros.image_transport == "compressed" ? "/compressed" : ""),
                config_.ros.diagnostic_period);
  health_.setSubscribed(bool(image_sub_));
}

void MotionAnalysisNodelet::connectCb() {
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const bool wanted = config_.ros.always_subscribe || motion_pub_.getNumSubscribers() > 0 ||
                      debug_pub_.getNumSubscribers() > 0;
  if (wanted && !image_sub_) {
    subscribeImage();
    NODELET_DEBUG("subscribed to %s", image_sub_.topic().c_str());
  } else if (!wanted && image_sub_) {
    NODELET_DEBUG("no subscribers left: unsubscribing from the image");
    image_sub_.shutdown();
  }
  health_.setSubscribed(bool(image_sub_));
}

void MotionAnalysisNodelet::subscribeImage() {
  image_sub_.subscribe(
      getNodeHandle(), "image", config_.ros.image_transport, config_.ros.queue_size,
      [this](const std_msgs::Header& h, const cv::Mat& gray) { imageCb(h, gray); },
      [this](const std::string& why) {
        NODELET_WARN_THROTTLE(5.0, "dropping image: %s", why.c_str());
        health_.noteDropped(why);
      });
}

void MotionAnalysisNodelet::imageCb(const std_msgs::Header& header, const cv::Mat& gray) {
  const ros::WallTime started = ros::WallTime::now();
  const MotionData md = analyzer_->process(gray, header.stamp.toSec());
  if (!analyzer_->lastReset().empty() && health_.noteReset(analyzer_->lastReset())) {
    NODELET_WARN("motion analysis reset at stamp %.6f: %s", header.stamp.toSec(),
                 analyzer_->lastReset().c_str());
  }
  ++frames_;
  if (motion_pub_.getNumSubscribers() > 0) motion_pub_.publish(toMsg(md, header));
  if (debug_pub_.getNumSubscribers() > 0) {
    debug_pub_.publish(cv_bridge::CvImage(header, "bgr8", drawMotionData(gray, md)).toImageMsg());
  }
  health_.noteFrame(header.stamp, started);
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::MotionAnalysisNodelet, nodelet::Nodelet)
