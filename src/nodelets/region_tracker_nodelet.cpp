#include "instant_motion_tracking/ros/region_tracker_nodelet.h"

#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/markers.h"

#include <pluginlib/class_list_macros.hpp>
#include <visualization_msgs/MarkerArray.h>

namespace imt {

void RegionTrackerNodelet::onInit() {
  joinSession();
  ros::NodeHandle& nh = getNodeHandle();
  auto cb = [this](const ros::SingleSubscriberPublisher&) { updateSubscription(); };
  regions_pub_ = nh.advertise<instant_motion_tracking::TrackedRegionArray>("regions", 10, cb, cb);
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 10, cb, cb);
  add_srv_ = nh.advertiseService("add_region", &RegionTrackerNodelet::addCb, this);
  remove_srv_ = nh.advertiseService("remove_region", &RegionTrackerNodelet::removeCb, this);
  seek_srv_ = nh.advertiseService("seek_regions", &RegionTrackerNodelet::seekCb, this);
  startSession("camera_info", nh.resolveName("motion_data"), "regions",
               {"tracked", "featureless", "out_of_view", "lost"});
}

bool RegionTrackerNodelet::wantsFrames() {
  return session([](TrackingSession& s) { return s.regionCount() > 0; }) ||
         regions_pub_.getNumSubscribers() > 0 || markers_pub_.getNumSubscribers() > 0;
}

void RegionTrackerNodelet::onResult(const FrameResult& r, const std_msgs::Header& header,
                                    const ros::WallTime& received) {
  frame_id_ = header.frame_id;
  if (!r.reset.empty()) {
    losses_.clear();  // the regions are gone
    if (health_.noteReset(r.reset)) NODELET_WARN("%s", r.reset.c_str());
  }
  for (const RegionState& s : r.regions) {
    const std::string change = losses_.update(s);  // said once per change
    if (!change.empty()) NODELET_INFO("%s", change.c_str());
  }
  if (regions_pub_.getNumSubscribers() > 0) regions_pub_.publish(toMsg(r.regions, header));
  if (markers_pub_.getNumSubscribers() > 0) markers_pub_.publish(regionMarkers(r.regions, header, r.camera));
  std::vector<std::string> statuses;
  for (const RegionState& s : r.regions) statuses.push_back(regionStatusName(s.status));
  health_.setItems(statuses);
  health_.noteFrame(header.stamp, received);
}

bool RegionTrackerNodelet::addCb(instant_motion_tracking::AddRegion::Request& req,
                                 instant_motion_tracking::AddRegion::Response& res) {
  std::string error;
  uint32_t id = 0;
  res.success = session([&](TrackingSession& s) {
    return s.addRegion(req.id, req.stamp.toSec(), cv::Rect2d(req.x, req.y, req.width, req.height), &id, &error);
  });
  res.id = res.success ? id : 0;
  res.message = res.success ? "tracking region " + std::to_string(id) : error;
  if (!res.success) NODELET_WARN_THROTTLE(1.0, "add_region refused: %s", error.c_str());
  updateSubscription();
  if (!res.success) res.message += retryHint();
  return true;
}

bool RegionTrackerNodelet::removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                                    instant_motion_tracking::RemoveRegion::Response& res) {
  std::string error;
  res.success = session([&](TrackingSession& s) {
    losses_.forget(req.id);
    return s.removeRegion(req.id, &error);
  });
  res.message = res.success ? "removed region " + std::to_string(req.id) : error;
  updateSubscription();
  return true;
}

bool RegionTrackerNodelet::seekCb(instant_motion_tracking::SeekRegions::Request& req,
                                  instant_motion_tracking::SeekRegions::Response& res) {
  std::string error;
  std::vector<RegionState> states;
  std_msgs::Header h;
  res.success = session([&](TrackingSession& s) {
    h.frame_id = frame_id_;
    return s.seekRegions(req.stamp.toSec(), req.ids, &states, &error);
  });
  res.message = res.success ? std::to_string(states.size()) + " regions" : error;
  if (res.success) {
    h.stamp = states.empty() ? req.stamp : ros::Time(states.front().stamp);
    res.regions = toMsg(states, h);
  }
  return true;
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::RegionTrackerNodelet, nodelet::Nodelet)
