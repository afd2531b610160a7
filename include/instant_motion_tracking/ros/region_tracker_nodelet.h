// RegionTrackerNodelet (pluginlib: instant_motion_tracking/RegionTrackerNodelet)
//
// Tracks any number of 2D regions from motion data alone (core/region_manager.h).
// Subscribes:
//   motion_data       instant_motion_tracking/MotionData (from MotionAnalysisNodelet)
//   camera_info       sensor_msgs/CameraInfo (optional; for the rviz markers only)
// Publishes, stamped with the image stamp of the motion data:
//   regions           instant_motion_tracking/TrackedRegionArray
//   markers           visualization_msgs/MarkerArray (boxes on a plane 1 m ahead)
// Services:
//   add_region        AddRegion: a box at a stamp within the cache (0 = latest frame)
//   remove_region     RemoveRegion
//   seek_regions      SeekRegions: states at any cached stamp
// Parameters (private namespace; config/default.yaml): cache_seconds,
//   default_hfov_deg, region_tracking/*, queue_size, always_subscribe, diagnostic_period.
// Diagnostics (/diagnostics, ros/nodelet_health.h): input rate, processing time and
// delay after the image stamp, regions by status.
// motion_data is subscribed while an output has a subscriber, a region
// exists, or ~always_subscribe is set. Bad requests get success=false and a
// message; nothing a client sends can stop the nodelet.
#pragma once

#include "instant_motion_tracking/AddRegion.h"
#include "instant_motion_tracking/MotionData.h"
#include "instant_motion_tracking/RemoveRegion.h"
#include "instant_motion_tracking/SeekRegions.h"
#include "instant_motion_tracking/core/region_manager.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/ros/nodelet_health.h"

#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>

#include <memory>
#include <mutex>
#include <set>

namespace imt {

class RegionTrackerNodelet : public nodelet::Nodelet {
 public:
  void onInit() override;

 private:
  void updateSubscription();  // call with mutex_ held
  void motionCb(const instant_motion_tracking::MotionDataConstPtr& msg);
  void infoCb(const sensor_msgs::CameraInfoConstPtr& msg);
  bool addCb(instant_motion_tracking::AddRegion::Request& req, instant_motion_tracking::AddRegion::Response& res);
  bool removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                instant_motion_tracking::RemoveRegion::Response& res);
  bool seekCb(instant_motion_tracking::SeekRegions::Request& req,
              instant_motion_tracking::SeekRegions::Response& res);

  Config config_;
  std::unique_ptr<RegionManager> manager_;
  CameraModel intrinsics_;
  std::string frame_id_;
  ros::Subscriber motion_sub_, info_sub_;
  ros::Publisher regions_pub_, markers_pub_;
  ros::ServiceServer add_srv_, remove_srv_, seek_srv_;
  std::mutex mutex_;
  std::set<uint32_t> reported_lost_;  // regions whose loss was logged
  NodeletHealth health_;
};

}  // namespace imt
