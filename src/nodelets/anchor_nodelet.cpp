#include "instant_motion_tracking/ros/anchor_nodelet.h"

#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/markers.h"
#include "instant_motion_tracking/ros/params.h"

#include <visualization_msgs/MarkerArray.h>
#include <pluginlib/class_list_macros.hpp>

namespace imt {

void AnchorNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  std::string error;
  if (!loadConfigFromRos(getPrivateNodeHandle(), &config_, &error)) {
    NODELET_ERROR("bad parameter, using the defaults instead: %s", error.c_str());
  }
  const PipelineOptions& o = config_.pipeline;
  regions_ = std::make_unique<RegionManager>(o.region_tracking, o.cache_seconds);
  anchors_ = std::make_unique<AnchorManager>(o.anchors, o.imu, o.default_hfov_deg, regions_.get());
  rotation_known_ = anchors_->rotationFromOptions();
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
  tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  std::lock_guard<std::mutex> lock(mutex_);
  auto cb = [this](const ros::SingleSubscriberPublisher&) {
    std::lock_guard<std::mutex> l(mutex_);
    updateSubscription();
  };
  anchors_pub_ = nh.advertise<instant_motion_tracking::AnchorArray>("anchors", 10, cb, cb);
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 10, cb, cb);
  info_sub_ = nh.subscribe("camera_info", 1, &AnchorNodelet::infoCb, this);
  add_srv_ = nh.advertiseService("add_anchor", &AnchorNodelet::addCb, this);
  remove_srv_ = nh.advertiseService("remove_anchor", &AnchorNodelet::removeCb, this);
  health_.start(nh, getPrivateNodeHandle(), getName(), nh.resolveName("motion_data"),
                config_.ros.diagnostic_period, "anchors",
                {"tracked", "out_of_view", "no_imu", "lost"});
  updateSubscription();
}

void AnchorNodelet::updateSubscription() {
  const bool wanted = config_.ros.always_subscribe || anchors_->size() > 0 || awaiting_frames_ ||
                      anchors_pub_.getNumSubscribers() > 0 || markers_pub_.getNumSubscribers() > 0;
  ros::NodeHandle& nh = getNodeHandle();
  if (wanted && !motion_sub_) {
    motion_sub_ =
        nh.subscribe("motion_data", 10 * config_.ros.queue_size, &AnchorNodelet::motionCb, this);
    imu_sub_ = nh.subscribe("imu", 1000, &AnchorNodelet::imuCb, this);  // up to ~1 s at 1 kHz
  } else if (!wanted && motion_sub_) {
    motion_sub_.shutdown();
    imu_sub_.shutdown();
    // No anchor is left; frames and IMU samples from before a gap would only mislead.
    regions_->clear();
    anchors_->resetImu();
    pending_.clear();
  }
  health_.setSubscribed(bool(motion_sub_));
}

void AnchorNodelet::infoCb(const sensor_msgs::CameraInfoConstPtr& msg) {
  CameraModel k;
  std::string why;
  std::lock_guard<std::mutex> lock(mutex_);
  if (fromCameraInfo(*msg, &k, &why, config_.pipeline.image_rectified)) {
    anchors_->setIntrinsics(k);
  } else {
    NODELET_WARN_THROTTLE(10.0, "ignoring camera_info: %s", why.c_str());
  }
}

void AnchorNodelet::lookupRotation(const std::string& imu_frame) {
  if (imu_frame != imu_frame_)
    rotation_known_ = anchors_->rotationFromOptions();  // a new IMU frame
  imu_frame_ = imu_frame;
  if (rotation_known_ || camera_frame_.empty()) return;
  if (imu_frame.empty() || imu_frame == camera_frame_) {
    rotation_known_ = anchors_->setRotationCamImu(Eigen::Quaterniond::Identity());
    return;
  }
  std::string why;
  try {
    if (tf_buffer_->canTransform(camera_frame_, imu_frame, ros::Time(0), &why)) {
      const auto t = tf_buffer_->lookupTransform(camera_frame_, imu_frame, ros::Time(0));
      const auto& q = t.transform.rotation;
      rotation_known_ = anchors_->setRotationCamImu(Eigen::Quaterniond(q.w, q.x, q.y, q.z));
      if (rotation_known_) {
        NODELET_INFO("IMU-to-camera rotation from tf: %s <- %s", camera_frame_.c_str(),
                     imu_frame.c_str());
        return;
      }
      why = "not a rotation";
    }
  } catch (const tf2::TransformException& e) {
    why = e.what();
  }
  NODELET_WARN_THROTTLE(
      10.0, "no tf %s <- %s yet (%s); assuming the IMU axes are the camera's until it comes",
      camera_frame_.c_str(), imu_frame.c_str(), why.c_str());
}

void AnchorNodelet::imuCb(const sensor_msgs::ImuConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  ImuSample s;
  std::string why;
  if (!fromImuMsg(*msg, &s, &why)) {
    NODELET_WARN_THROTTLE(5.0, "dropping IMU sample: %s", why.c_str());
    return;
  }
  imu_seen_ = true;
  lookupRotation(msg->header.frame_id);
  switch (anchors_->addImu(s, &why)) {
    case ImuInput::kAccepted:
      break;
    case ImuInput::kDropped:
      NODELET_WARN_THROTTLE(5.0, "%s", why.c_str());
      break;
    case ImuInput::kReset:
      NODELET_WARN("%s", why.c_str());
      break;
    case ImuInput::kGap:
      NODELET_WARN_THROTTLE(5.0, "%s", why.c_str());
      break;
  }
  flush(false);
}

void AnchorNodelet::motionCb(const instant_motion_tracking::MotionDataConstPtr& msg) {
  const ros::WallTime started = ros::WallTime::now();
  std::lock_guard<std::mutex> lock(mutex_);
  const MotionData md = fromMsg(*msg);
  if (md.width <= 0 || md.height <= 0) {
    NODELET_WARN_THROTTLE(5.0, "dropping motion_data without an image size");
    health_.noteDropped("motion_data without an image size");
    return;
  }
  camera_frame_ = msg->header.frame_id;
  // Time going back (a looping bag): the old stream's frames still waiting
  // for the IMU are dropped, not published late; their tf would reach
  // listeners after they cleared for the jump and be repeated by the new pass.
  if (!pending_.empty() && !(md.stamp > pending_.back().md.stamp)) pending_.clear();
  pending_.push_back({msg->header, md, started});
  flush(false);
}

void AnchorNodelet::flush(bool all) {
  while (!pending_.empty() &&
         (all || anchors_->ready(pending_.front().md.stamp, pending_.back().md.stamp))) {
    const Pending frame = std::move(pending_.front());
    pending_.pop_front();
    track(frame);
  }
}

void AnchorNodelet::track(const Pending& frame) {
  const std_msgs::Header& header = frame.header;
  regions_->update(frame.md);
  if (!regions_->lastReset().empty()) {
    // Time went back (a looping bag) or the image size changed: the tf
    // history belongs to the old stream.
    if (health_.noteReset(regions_->lastReset()))
      NODELET_WARN("%s; anchors cleared", regions_->lastReset().c_str());
    tf_buffer_->clear();
  }
  anchors_->update();
  std::vector<AnchorState> states;
  std::string error;
  if (!anchors_->stateAt(header.stamp.toSec(), {}, &states, &error)) {
    NODELET_WARN_THROTTLE(5.0, "no anchors for stamp %.6f: %s", header.stamp.toSec(),
                          error.c_str());
    return;
  }
  for (const AnchorState& s : states) {
    if (s.status != AnchorStatus::kNoImu) continue;
    const std::string where = imu_seen_ ? "" : " on " + getNodeHandle().resolveName("imu");
    NODELET_WARN_THROTTLE(10.0, "anchors are translation-only (status no_imu): %s%s",
                          s.reason.c_str(), where.c_str());
    break;
  }
  if (anchors_pub_.getNumSubscribers() > 0) anchors_pub_.publish(toMsg(states, header));
  if (config_.ros.publish_tf && !states.empty() && !fromBeforeTimeJump(header.stamp)) {
    const auto transforms = anchorTransforms(states, header, config_.ros.frame_prefix);
    if (!transforms.empty()) tf_->sendTransform(transforms);
  }
  if (markers_pub_.getNumSubscribers() > 0) markers_pub_.publish(anchorMarkers(states, header));
  std::vector<std::string> statuses;
  for (const AnchorState& s : states) statuses.push_back(anchorStatusName(s.status));
  health_.setItems(statuses);
  // Processing time includes the wait for the IMU: what a consumer sees.
  health_.noteFrame(header.stamp, frame.started);
}

bool AnchorNodelet::addCb(instant_motion_tracking::AddAnchor::Request& req,
                          instant_motion_tracking::AddAnchor::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  // A stamp among the frames still waiting for the IMU: they go in now.
  if (req.stamp.toSec() > regions_->newestStamp()) flush(true);
  std::string error;
  uint32_t id = 0;
  res.success =
      anchors_->add(req.id, req.stamp.toSec(), cv::Point2d(req.u, req.v), req.depth, &id, &error);
  res.id = res.success ? id : 0;
  res.message = res.success ? "tracking anchor " + std::to_string(id) : error;
  if (!res.success) NODELET_WARN_THROTTLE(1.0, "add_anchor refused: %s", error.c_str());
  // Refused for want of frames: stay subscribed so that a retry finds some.
  awaiting_frames_ = !res.success && regions_->cachedFrames() == 0;
  if (awaiting_frames_)
    res.message +=
        " (subscribed to " + getNodeHandle().resolveName("motion_data") + "; retry shortly)";
  updateSubscription();
  return true;
}

bool AnchorNodelet::removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                             instant_motion_tracking::RemoveRegion::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string error;
  res.success = anchors_->remove(req.id, &error);
  res.message = res.success ? "removed anchor " + std::to_string(req.id) : error;
  updateSubscription();
  return true;
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::AnchorNodelet, nodelet::Nodelet)
