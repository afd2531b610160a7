#include "instant_motion_tracking/ros/motion_analysis_nodelet.h"

#include "instant_motion_tracking/core/debug_draw.h"
#include "instant_motion_tracking/ros/conversions.h"

#include <cv_bridge/cv_bridge.h>
#include <image_transport/camera_common.h>
#include <pluginlib/class_list_macros.hpp>

namespace imt {

void MotionAnalysisNodelet::onInit() {
  joinSession();
  ros::NodeHandle& nh = getNodeHandle();
  auto cb = [this](const auto&) { updateSubscription(); };
  motion_pub_ = nh.advertise<instant_motion_tracking::MotionData>(
      "motion_data", 10, ros::SubscriberStatusCallback(cb), ros::SubscriberStatusCallback(cb));
  // A plain publisher (what image_transport's raw one is): no plugin loads
  // while the manager's other nodelets load theirs.
  debug_pub_ = nh.advertise<sensor_msgs::Image>("debug_image", 2, ros::SubscriberStatusCallback(cb),
                                                ros::SubscriberStatusCallback(cb));
  startSession(image_transport::getCameraInfoTopic(nh.resolveName("image")),
               nh.resolveName("image") + (config_.ros.image_transport == "compressed" ? "/compressed" : ""), "", {},
               /*feeds_images=*/true);
}

bool MotionAnalysisNodelet::wantsFrames() {
  return motion_pub_.getNumSubscribers() > 0 || debug_pub_.getNumSubscribers() > 0;
}

bool MotionAnalysisNodelet::inputsWanted() { return hub_->framesWanted(); }

void MotionAnalysisNodelet::subscribeInputs(bool wanted) {
  if (wanted && !image_sub_) {
    image_sub_.subscribe(
        getNodeHandle(), "image", config_.ros.image_transport, config_.ros.queue_size,
        [this](const std_msgs::Header& h, const cv::Mat& gray) { imageCb(h, gray); },
        [this](const std::string& why) {
          NODELET_WARN_THROTTLE(5.0, "dropping image: %s", why.c_str());
          health_.noteDropped(why);
        });
    NODELET_DEBUG("subscribed to %s", image_sub_.topic().c_str());
  } else if (!wanted && image_sub_) {
    NODELET_DEBUG("nothing wants frames: unsubscribing from the image");
    image_sub_.shutdown();
  }
  subscribeCameraInfo(wanted);
  health_.setSubscribed(bool(image_sub_));
}

void MotionAnalysisNodelet::imageCb(const std_msgs::Header& header, const cv::Mat& gray) {
  const ros::WallTime received = ros::WallTime::now();
  hub_->noteHeader(header, received);
  session([&](TrackingSession& s) {
    const MotionData& md = s.analyze(gray, header.stamp.toSec());
    if (!s.lastDrop().empty()) {
      // A repeated stamp, or one slightly behind: dropped, tracks kept.
      NODELET_WARN_THROTTLE(5.0, "%s", s.lastDrop().c_str());
      health_.noteDropped(s.lastDrop());
      return;
    }
    if (!s.lastGap().empty()) {
      NODELET_WARN_THROTTLE(5.0, "%s", s.lastGap().c_str());
      health_.noteGap(s.lastGap());
    }
    if (!s.lastAnalysisReset().empty() && health_.noteReset(s.lastAnalysisReset()))
      NODELET_WARN("motion analysis reset at stamp %.6f: %s", header.stamp.toSec(), s.lastAnalysisReset().c_str());
    if (motion_pub_.getNumSubscribers() > 0) motion_pub_.publish(toMsg(md, header));
  });
  health_.noteFrame(header.stamp, received);
}

// debug_image: the frame with its motion data and every tracker's states.
void MotionAnalysisNodelet::onResult(const FrameResult& r, const std_msgs::Header& header, const ros::WallTime&) {
  if (debug_pub_.getNumSubscribers() == 0 || r.gray.empty()) return;
  cv::Mat bgr = drawMotionData(r.gray, r.motion);
  DebugOverlay overlay;
  overlay.regions = r.regions;
  overlay.targets = r.targets;
  overlay.anchors = r.anchors;
  overlay.intrinsics = r.camera;
  drawOverlay(&bgr, overlay);
  debug_pub_.publish(cv_bridge::CvImage(header, "bgr8", bgr).toImageMsg());
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::MotionAnalysisNodelet, nodelet::Nodelet)
