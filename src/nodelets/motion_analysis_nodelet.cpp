#include "instant_motion_tracking/ros/motion_analysis_nodelet.h"

#include "instant_motion_tracking/core/debug_draw.h"
#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/image_conversion.h"
#include "instant_motion_tracking/ros/params.h"

#include <cv_bridge/cv_bridge.h>
#include <image_transport/camera_common.h>
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
  // Queue: the frames that waited for the trackers may go out together.
  debug_pub_ = it_->advertise("debug_image", kMaxDebugFrames + 2,
                              image_transport::SubscriberStatusCallback(cb),
                              image_transport::SubscriberStatusCallback(cb));
  if (config_.ros.always_subscribe) subscribeImage();
  health_.start(nh, pnh, getName(),
                nh.resolveName("image") + (config_.ros.image_transport == "compressed" ? "/compressed" : ""),
                config_.ros.diagnostic_period);
  health_.setSubscribed(bool(image_sub_));
  // Publishes debug frames whose trackers stay silent (the last frame of a bag, a paused player).
  debug_timer_ = nh.createWallTimer(ros::WallDuration(kDebugWaitSeconds / 2),
                                    [this](const ros::WallTimerEvent&) {
                                      std::lock_guard<std::mutex> l(debug_mutex_);
                                      publishDebug(false);
                                    });
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
  updateOverlaySubscriptions();
}

void MotionAnalysisNodelet::updateOverlaySubscriptions() {
  ros::NodeHandle& nh = getNodeHandle();
  std::lock_guard<std::mutex> l(debug_mutex_);
  const bool wanted = debug_pub_.getNumSubscribers() > 0;
  if (wanted && !regions_sub_) {
    const uint32_t queue = 10 * config_.ros.queue_size;
    regions_sub_ = nh.subscribe("regions", queue, &MotionAnalysisNodelet::regionsCb, this);
    targets_sub_ = nh.subscribe("planar_targets", queue, &MotionAnalysisNodelet::targetsCb, this);
    anchors_sub_ = nh.subscribe("anchors", queue, &MotionAnalysisNodelet::anchorsCb, this);
    info_sub_ = nh.subscribe(image_transport::getCameraInfoTopic(nh.resolveName("image")), 1,
                             &MotionAnalysisNodelet::infoCb, this);
  } else if (!wanted && regions_sub_) {
    for (ros::Subscriber* s : {&regions_sub_, &targets_sub_, &anchors_sub_, &info_sub_})
      s->shutdown();
    debug_frames_.clear();
    overlays_.clear();
  }
}

void MotionAnalysisNodelet::regionsCb(
    const instant_motion_tracking::TrackedRegionArrayConstPtr& msg) {
  std::lock_guard<std::mutex> l(debug_mutex_);
  overlays_.addRegions(msg->header.stamp.toSec(), fromMsg(*msg));
  publishDebug(false);
}

void MotionAnalysisNodelet::targetsCb(
    const instant_motion_tracking::PlanarTargetArrayConstPtr& msg) {
  std::lock_guard<std::mutex> l(debug_mutex_);
  overlays_.addTargets(msg->header.stamp.toSec(), fromMsg(*msg));
  publishDebug(false);
}

void MotionAnalysisNodelet::anchorsCb(const instant_motion_tracking::AnchorArrayConstPtr& msg) {
  std::lock_guard<std::mutex> l(debug_mutex_);
  overlays_.addAnchors(msg->header.stamp.toSec(), fromMsg(*msg));
  publishDebug(false);
}

void MotionAnalysisNodelet::infoCb(const sensor_msgs::CameraInfoConstPtr& msg) {
  CameraModel k;
  std::string why;
  std::lock_guard<std::mutex> l(debug_mutex_);
  if (fromCameraInfo(*msg, &k, &why, config_.pipeline.image_rectified)) {
    intrinsics_ = k;
  } else {
    NODELET_WARN_THROTTLE(10.0, "ignoring camera_info: %s", why.c_str());
  }
}

void MotionAnalysisNodelet::publishDebug(bool all) {
  const ros::WallTime now = ros::WallTime::now();
  while (!debug_frames_.empty()) {
    DebugFrame& f = debug_frames_.front();
    const double stamp = f.header.stamp.toSec();
    const bool waited = (now - f.analysed).toSec() >= kDebugWaitSeconds;
    if (!all && !waited && debug_frames_.size() <= kMaxDebugFrames && !overlays_.complete(stamp))
      break;
    if (debug_pub_.getNumSubscribers() > 0) {
      cv::Mat bgr = drawMotionData(f.gray, f.md);
      DebugOverlay overlay = overlays_.select(stamp);
      overlay.intrinsics = intrinsics_;
      if (!overlay.intrinsics.valid || overlay.intrinsics.width != f.md.width)
        overlay.intrinsics = CameraModel::fromFieldOfView(f.md.width, f.md.height,
                                                               config_.pipeline.default_hfov_deg);
      drawOverlay(&bgr, overlay);
      debug_pub_.publish(cv_bridge::CvImage(f.header, "bgr8", bgr).toImageMsg());
    }
    debug_frames_.pop_front();
  }
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
    std::lock_guard<std::mutex> l(debug_mutex_);
    const double stamp = header.stamp.toSec();
    if (stamp < last_stamp_) {  // a looping bag: the trackers start over too
      publishDebug(true);
      overlays_.clear();
    }
    last_stamp_ = stamp;
    debug_frames_.push_back({gray, md, header, ros::WallTime::now()});
    publishDebug(false);
  }
  health_.noteFrame(header.stamp, started);
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::MotionAnalysisNodelet, nodelet::Nodelet)
