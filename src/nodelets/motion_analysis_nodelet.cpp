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
  if (config_.ros.always_subscribe) {
    image_sub_ = it_->subscribe("image", config_.ros.queue_size, &MotionAnalysisNodelet::imageCb, this);
  }
  health_.start(nh, pnh, getName(), nh.resolveName("image"), config_.ros.diagnostic_period);
  health_.setSubscribed(bool(image_sub_));
}

void MotionAnalysisNodelet::connectCb() {
  std::lock_guard<std::mutex> lock(connect_mutex_);
  const bool wanted = config_.ros.always_subscribe || motion_pub_.getNumSubscribers() > 0 ||
                      debug_pub_.getNumSubscribers() > 0;
  if (wanted && !image_sub_) {
    NODELET_DEBUG("subscribing to %s", getNodeHandle().resolveName("image").c_str());
    image_sub_ = it_->subscribe("image", config_.ros.queue_size, &MotionAnalysisNodelet::imageCb, this);
  } else if (!wanted && image_sub_) {
    NODELET_DEBUG("no subscribers left: unsubscribing from the image");
    image_sub_.shutdown();
  }
  health_.setSubscribed(bool(image_sub_));
}

void MotionAnalysisNodelet::imageCb(const sensor_msgs::ImageConstPtr& msg) {
  const ros::WallTime started = ros::WallTime::now();
  cv::Mat gray;
  std::string error;
  if (!imageToGray(*msg, &gray, &error)) {
    NODELET_WARN_THROTTLE(5.0, "dropping image: %s", error.c_str());
    health_.noteDropped(error);
    return;
  }
  const MotionData md = analyzer_->process(gray, msg->header.stamp.toSec());
  if (!analyzer_->lastReset().empty() && health_.noteReset(analyzer_->lastReset())) {
    NODELET_WARN("motion analysis reset at stamp %.6f: %s", msg->header.stamp.toSec(),
                 analyzer_->lastReset().c_str());
  }
  ++frames_;
  if (motion_pub_.getNumSubscribers() > 0) motion_pub_.publish(toMsg(md, msg->header));
  if (debug_pub_.getNumSubscribers() > 0) {
    debug_pub_.publish(cv_bridge::CvImage(msg->header, "bgr8", drawMotionData(gray, md)).toImageMsg());
  }
  health_.noteFrame(msg->header.stamp, started);
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::MotionAnalysisNodelet, nodelet::Nodelet)
