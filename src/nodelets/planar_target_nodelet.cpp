#include "instant_motion_tracking/ros/planar_target_nodelet.h"

#include "instant_motion_tracking/core/planar/image_target_detector.h"

#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/image_conversion.h"
#include "instant_motion_tracking/ros/markers.h"

#include <pluginlib/class_list_macros.hpp>

namespace imt {

void PlanarTargetNodelet::onInit() {
  joinSession();
  ros::NodeHandle& nh = getNodeHandle();
  tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  auto cb = [this](const ros::SingleSubscriberPublisher&) { updateSubscription(); };
  targets_pub_ = nh.advertise<instant_motion_tracking::PlanarTargetArray>("planar_targets", 10, cb, cb);
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 10, cb, cb);
  add_srv_ = nh.advertiseService("add_planar_target", &PlanarTargetNodelet::addCb, this);
  add_image_srv_ = nh.advertiseService("add_image_target", &PlanarTargetNodelet::addImageCb, this);
  remove_srv_ = nh.advertiseService("remove_planar_target", &PlanarTargetNodelet::removeCb, this);
  startSession("camera_info", nh.resolveName("motion_data"), "planar targets",
               {"tracked", "predicted", "out_of_view", "lost", "not_found"});
}

bool PlanarTargetNodelet::wantsImages() const {
  return config_.pipeline.planar_tracking.usesImages();
}

// A target's tf is wanted even without topic subscribers.
bool PlanarTargetNodelet::wantsFrames() {
  return session([](TrackingSession& s) { return s.planarTargetCount() > 0; }) ||
         targets_pub_.getNumSubscribers() > 0 || markers_pub_.getNumSubscribers() > 0;
}

void PlanarTargetNodelet::onResult(const FrameResult& r, const std_msgs::Header& header,
                                   const ros::WallTime& received) {
  if (!r.reset.empty() && health_.noteReset(r.reset)) NODELET_WARN("%s; planar targets cleared", r.reset.c_str());
  if (targets_pub_.getNumSubscribers() > 0) targets_pub_.publish(toMsg(r.targets, header));
  if (config_.ros.publish_tf && !r.targets.empty() && !fromBeforeTimeJump(header.stamp)) {
    const auto transforms = planarTargetTransforms(r.targets, header, config_.ros.frame_prefix);
    if (!transforms.empty()) tf_->sendTransform(transforms);
  }
  if (markers_pub_.getNumSubscribers() > 0) markers_pub_.publish(planarTargetMarkers(r.targets, header));
  std::vector<std::string> statuses;
  for (const PlanarTargetState& s : r.targets) statuses.push_back(targetStatusName(s.status));
  health_.setItems(statuses);
  health_.noteFrame(header.stamp, received);
}

bool PlanarTargetNodelet::addCb(instant_motion_tracking::AddPlanarTarget::Request& req,
                                instant_motion_tracking::AddPlanarTarget::Response& res) {
  std::array<cv::Point2d, 4> corners;
  for (int i = 0; i < 4; ++i) corners[i] = cv::Point2d(req.corners[i].x, req.corners[i].y);
  std::string error;
  uint32_t id = 0;
  res.success = session([&](TrackingSession& s) {
    return s.addPlanarTarget(req.id, req.stamp.toSec(), corners, req.width_m, req.height_m, &id, &error);
  });
  res.id = res.success ? id : 0;
  res.message = res.success ? "tracking planar target " + std::to_string(id) : error;
  if (!res.success) NODELET_WARN_THROTTLE(1.0, "add_planar_target refused: %s", error.c_str());
  updateSubscription();
  if (!res.success) res.message += retryHint();
  return true;
}

bool PlanarTargetNodelet::addImageCb(instant_motion_tracking::AddImageTarget::Request& req,
                                     instant_motion_tracking::AddImageTarget::Response& res) {
  cv::Mat picture;
  std::string error;
  if (!req.image_path.empty()) {
    picture = ImageTargetDetector::readPicture(req.image_path, &error);
  } else if (req.image.data.empty()) {
    error = "no picture: give image_path or image";
  } else if (!imageToGray(req.image, &picture, &error)) {
    error = "image: " + error;
  }
  uint32_t id = 0;
  res.success = error.empty() && session([&](TrackingSession& s) {
                  return s.addImageTarget(req.id, 0, picture, req.width_m, req.height_m, &id, &error);
                });
  res.id = res.success ? id : 0;
  res.message = res.success ? "looking for image target " + std::to_string(id) : error;
  if (!res.success) NODELET_WARN_THROTTLE(1.0, "add_image_target refused: %s", error.c_str());
  updateSubscription();
  if (!res.success) res.message += retryHint();
  return true;
}

bool PlanarTargetNodelet::removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                                   instant_motion_tracking::RemoveRegion::Response& res) {
  std::string error;
  res.success = session([&](TrackingSession& s) { return s.removePlanarTarget(req.id, &error); });
  res.message = res.success ? "removed planar target " + std::to_string(req.id) : error;
  updateSubscription();
  return true;
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::PlanarTargetNodelet, nodelet::Nodelet)
