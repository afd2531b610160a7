// RegionTrackerNodelet (pluginlib: instant_motion_tracking/RegionTrackerNodelet)
//
// Tracks any number of 2D regions from motion data alone (core/region_manager.h),
// as a view of the manager's TrackingSession (ros/session_nodelet.h).
// Frames come from a MotionAnalysisNodelet in the same manager, else it subscribes:
//   motion_data       instant_motion_tracking/MotionData (from MotionAnalysisNodelet)
// and then also (the image feeder subscribes it otherwise):
//   camera_info       sensor_msgs/CameraInfo (optional; the camera model)
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
// Frames are wanted while an output has a subscriber, a region exists, or
// ~always_subscribe is set. Bad requests get success=false and a
// message; nothing a client sends can stop the nodelet.
#pragma once

#include "instant_motion_tracking/AddRegion.h"
#include "instant_motion_tracking/RemoveRegion.h"
#include "instant_motion_tracking/SeekRegions.h"
#include "instant_motion_tracking/ros/session_nodelet.h"

namespace imt {

class RegionTrackerNodelet : public SessionNodelet {
 public:
  // Leaves the session first: no frame result may reach a half-destroyed nodelet.
  ~RegionTrackerNodelet() override { leaveSession(); }
  void onInit() override;

 private:
  bool wantsFrames() override;
  void onResult(const FrameResult& result, const std_msgs::Header& header, const ros::WallTime& received) override;
  bool addCb(instant_motion_tracking::AddRegion::Request& req, instant_motion_tracking::AddRegion::Response& res);
  bool removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                instant_motion_tracking::RemoveRegion::Response& res);
  bool seekCb(instant_motion_tracking::SeekRegions::Request& req,
              instant_motion_tracking::SeekRegions::Response& res);

  ros::Publisher regions_pub_, markers_pub_;
  ros::ServiceServer add_srv_, remove_srv_, seek_srv_;
  RegionLossLog losses_;  // regions whose loss was logged (under the hub's lock)
  std::string frame_id_;              // of the latest frame (under the hub's lock)
};

}  // namespace imt
