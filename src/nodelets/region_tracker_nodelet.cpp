#include "instant_motion_tracking/ros/region_tracker_nodelet.h"

#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/markers.h"
#include "instant_motion_tracking/ros/params.h"

#include <pluginlib/class_list_macros.hpp>
#include <visualization_msgs/MarkerArray.h>

namespace imt {

void RegionTrackerNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  std::string error;
  if (!loadConfigFromRos(getPrivateNodeHandle(), &config_, &error)) {
    NODELET_ERROR("bad parameter, using the defaults instead: %s", error.c_str());
  }
  manager_ = std::make_unique<RegionManager>(config_.pipeline.region_tracking, config_.pipeline.cache_seconds);

  std::lock_guard<std::mutex> lock(mutex_);
  auto cb = [this](const ros::SingleSubscriberPublisher&) {
    std::lock_guard<std::mutex> l(mutex_);
    updateSubscription();
  };
  regions_pub_ = nh.advertise<instant_motion_tracking::TrackedRegionArray>("regions", 10, cb, cb);
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 10, cb, cb);
  info_sub_ = nh.subscribe("camera_info", 1, &RegionTrackerNodelet::infoCb, this);
  add_srv_ = nh.advertiseService("add_region", &RegionTrackerNodelet::addCb, this);
  remove_srv_ = nh.advertiseService("remove_region", &RegionTrackerNodelet::removeCb, this);
  seek_srv_ = nh.advertiseService("seek_regions", &RegionTrackerNodelet::seekCb, this);
  health_.start(nh, getPrivateNodeHandle(), getName(), nh.resolveName("motion_data"),
                config_.ros.diagnostic_period, "regions", {"tracked", "featureless", "out_of_view", "lost"});
  updateSubscription();
}

void RegionTrackerNodelet::updateSubscription() {
  const bool wanted = config_.ros.always_subscribe || manager_->regionCount() > 0 ||
                      regions_pub_.getNumSubscribers() > 0 || markers_pub_.getNumSubscribers() > 0;
  if (wanted && !motion_sub_) {
    motion_sub_ = getNodeHandle().subscribe("motion_data", 10 * config_.ros.queue_size,
                                            &RegionTrackerNodelet::motionCb, this);
  } else if (!wanted && motion_sub_) {
    motion_sub_.shutdown();
  }
  health_.setSubscribed(bool(motion_sub_));
}

void RegionTrackerNodelet::infoCb(const sensor_msgs::CameraInfoConstPtr& msg) {
  CameraModel k;
  std::string why;
  std::lock_guard<std::mutex> lock(mutex_);
  if (fromCameraInfo(*msg, &k, &why, config_.pipeline.image_rectified)) {
    intrinsics_ = k;
  } else {
    NODELET_WARN_THROTTLE(10.0, "ignoring camera_info: %s", why.c_str());
  }
}

void RegionTrackerNodelet::motionCb(const instant_motion_tracking::MotionDataConstPtr& msg) {
  const ros::WallTime started = ros::WallTime::now();
  std::lock_guard<std::mutex> lock(mutex_);
  const MotionData md = fromMsg(*msg);
  if (md.width <= 0 || md.height <= 0) {
    NODELET_WARN_THROTTLE(5.0, "dropping motion_data without an image size");
    health_.noteDropped("motion_data without an image size");
    return;
  }
  frame_id_ = msg->header.frame_id;
  const std::vector<RegionState> states = manager_->update(md);
  if (!manager_->lastReset().empty()) {
    reported_lost_.clear();  // the regions are gone
    if (health_.noteReset(manager_->lastReset())) NODELET_WARN("%s", manager_->lastReset().c_str());
  }
  for (const RegionState& s : states) {
    if (s.status == RegionStatus::kLost && !reported_lost_.count(s.id)) {
      reported_lost_.insert(s.id);  // said once per region
      NODELET_INFO("region %u lost at stamp %.6f: %s", s.id, s.stamp, s.reason.c_str());
    }
  }
  if (regions_pub_.getNumSubscribers() > 0) regions_pub_.publish(toMsg(states, msg->header));
  if (markers_pub_.getNumSubscribers() > 0) {
    CameraModel k = intrinsics_;
    if (!k.valid || k.width != md.width)
      k = CameraModel::fromFieldOfView(md.width, md.height, config_.pipeline.default_hfov_deg);
    markers_pub_.publish(regionMarkers(states, msg->header, k));
  }
  std::vector<std::string> statuses;
  for (const RegionState& s : states) statuses.push_back(regionStatusName(s.status));
  health_.setItems(statuses);
  health_.noteFrame(msg->header.stamp, started);
}

bool RegionTrackerNodelet::addCb(instant_motion_tracking::AddRegion::Request& req,
                                 instant_motion_tracking::AddRegion::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string error;
  uint32_t id = 0;
  res.success = manager_->add(req.id, req.stamp.toSec(), cv::Rect2d(req.x, req.y, req.width, req.height),
                              &id, &error);
  res.id = res.success ? id : 0;
  res.message = res.success ? "tracking region " + std::to_string(id) : error;
  if (!res.success) NODELET_WARN_THROTTLE(1.0, "add_region refused: %s", error.c_str());
  updateSubscription();
  if (!res.success && manager_->cachedFrames() == 0)
    res.message += " (subscribed to " + getNodeHandle().resolveName("motion_data") + "; retry shortly)";
  return true;
}

bool RegionTrackerNodelet::removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                                    instant_motion_tracking::RemoveRegion::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string error;
  res.success = manager_->remove(req.id, &error);
  reported_lost_.erase(req.id);
  res.message = res.success ? "removed region " + std::to_string(req.id) : error;
  updateSubscription();
  return true;
}

bool RegionTrackerNodelet::seekCb(instant_motion_tracking::SeekRegions::Request& req,
                                  instant_motion_tracking::SeekRegions::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string error;
  std::vector<RegionState> states;
  res.success = manager_->seek(req.stamp.toSec(), req.ids, &states, &error);
  res.message = res.success ? std::to_string(states.size()) + " regions" : error;
  if (res.success) {
    std_msgs::Header h;
    h.frame_id = frame_id_;
    h.stamp = states.empty() ? req.stamp : ros::Time(states.front().stamp);
    res.regions = toMsg(states, h);
  }
  return true;
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::RegionTrackerNodelet, nodelet::Nodelet)
