#include "instant_motion_tracking/ros/planar_target_nodelet.h"

#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/markers.h"
#include "instant_motion_tracking/ros/params.h"

#include <pluginlib/class_list_macros.hpp>

namespace imt {

void PlanarTargetNodelet::onInit() {
  ros::NodeHandle& nh = getNodeHandle();
  std::string error;
  if (!loadConfigFromRos(getPrivateNodeHandle(), &config_, &error)) {
    NODELET_ERROR("bad parameter, using the defaults instead: %s", error.c_str());
  }
  cache_ = std::make_unique<MotionCache>(config_.pipeline.cache_seconds);
  targets_ = std::make_unique<PlanarTargetManager>(config_.pipeline.planar_tracking);
  if (wantImages())
    cache_->setImageBudget(static_cast<size_t>(config_.pipeline.planar_tracking.image_memory_mb * 1024 * 1024));
  tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  std::lock_guard<std::mutex> lock(mutex_);
  auto cb = [this](const ros::SingleSubscriberPublisher&) {
    std::lock_guard<std::mutex> l(mutex_);
    updateSubscription();
  };
  targets_pub_ = nh.advertise<instant_motion_tracking::PlanarTargetArray>("planar_targets", 10, cb, cb);
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 10, cb, cb);
  updateSubscription();
  info_sub_ = nh.subscribe("camera_info", 1, &PlanarTargetNodelet::infoCb, this);
  add_srv_ = nh.advertiseService("add_planar_target", &PlanarTargetNodelet::addCb, this);
  remove_srv_ = nh.advertiseService("remove_planar_target", &PlanarTargetNodelet::removeCb, this);
  health_.start(nh, getPrivateNodeHandle(), getName(), nh.resolveName("motion_data"),
                config_.ros.diagnostic_period, "planar targets", {"tracked", "out_of_view", "lost"});
  health_.setSubscribed(bool(motion_sub_));
}

// Lazy like the other nodelets: motion_data is subscribed while an output has
// a subscriber, a target exists (its tf is wanted), or ~always_subscribe.
void PlanarTargetNodelet::updateSubscription() {
  const bool wanted = config_.ros.always_subscribe || targets_->size() > 0 ||
                      targets_pub_.getNumSubscribers() > 0 || markers_pub_.getNumSubscribers() > 0;
  if (wanted && !motion_sub_) {
    motion_sub_ = getNodeHandle().subscribe("motion_data", 10 * config_.ros.queue_size,
                                            &PlanarTargetNodelet::motionCb, this);
    if (wantImages())
      image_sub_.subscribe(
          getNodeHandle(), "image", config_.ros.image_transport, config_.ros.queue_size,
          [this](const std_msgs::Header& h, const cv::Mat& gray) { imageCb(h, gray); },
          [this](const std::string& why) {
            NODELET_WARN_THROTTLE(5.0, "image not used for the alignment: %s", why.c_str());
          });
  } else if (!wanted && motion_sub_) {
    motion_sub_.shutdown();
    image_sub_.shutdown();
    flush(true);
    images_.clear();
  }
  health_.setSubscribed(bool(motion_sub_));
}

CameraModel PlanarTargetNodelet::intrinsics() const {
  const cv::Size size = cache_->imageSize();
  if (info_.valid && info_.width == size.width && info_.height == size.height) return info_;
  return CameraModel::fromFieldOfView(size.width, size.height, config_.pipeline.default_hfov_deg);
}

void PlanarTargetNodelet::infoCb(const sensor_msgs::CameraInfoConstPtr& msg) {
  CameraModel k;
  std::string why;
  std::lock_guard<std::mutex> lock(mutex_);
  if (fromCameraInfo(*msg, &k, &why, config_.pipeline.image_rectified)) {
    info_ = k;
  } else {
    NODELET_WARN_THROTTLE(10.0, "ignoring camera_info: %s", why.c_str());
  }
}

bool PlanarTargetNodelet::wantImages() const {
  const PlanarTargetOptions& o = config_.pipeline.planar_tracking;
  return o.refine && o.model == "perspective" && o.image_memory_mb > 0;
}

void PlanarTargetNodelet::imageCb(const std_msgs::Header& header, const cv::Mat& gray) {
  std::lock_guard<std::mutex> lock(mutex_);
  last_image_ = ros::WallTime::now();
  const double stamp = header.stamp.toSec();
  if (!images_.empty() && stamp < images_.rbegin()->first) images_.clear();  // time went back
  images_[stamp] = gray;
  while (images_.size() > 30) images_.erase(images_.begin());  // motion data never came for these
  flush(false);
}

void PlanarTargetNodelet::motionCb(const instant_motion_tracking::MotionDataConstPtr& msg) {
  std::lock_guard<std::mutex> lock(mutex_);
  // Time going back (a looping bag): the old stream's frames still waiting
  // are dropped, not published late; their tf would reach listeners after
  // they cleared for the jump and be repeated by the new pass.
  if (!pending_.empty() && !(msg->header.stamp > pending_.back().msg->header.stamp)) pending_.clear();
  pending_.push_back({msg, ros::WallTime::now()});
  flush(false);
}

// Motion data is tracked in order, each frame once its image is here, a later
// image came (its own was dropped), images stopped arriving, or it has waited
// for two further frames.
void PlanarTargetNodelet::flush(bool all) {
  const bool images_flowing = image_sub_ && (ros::WallTime::now() - last_image_).toSec() < 1.0;
  while (!pending_.empty()) {
    const Pending p = pending_.front();
    const double stamp = p.msg->header.stamp.toSec();
    const bool have = images_.count(stamp) > 0;
    const bool later = !images_.empty() && images_.rbegin()->first > stamp;
    if (!(all || have || later || !images_flowing || pending_.size() > 2)) break;
    pending_.pop_front();
    track(*p.msg, p.started);
  }
}

void PlanarTargetNodelet::track(const instant_motion_tracking::MotionData& msg, const ros::WallTime& started) {
  const MotionData md = fromMsg(msg);
  if (md.width <= 0 || md.height <= 0) {
    NODELET_WARN_THROTTLE(5.0, "dropping motion_data without an image size");
    health_.noteDropped("motion_data without an image size");
    return;
  }
  cv::Mat gray;
  const auto it = images_.find(md.stamp);
  if (it != images_.end() && it->second.cols == md.width && it->second.rows == md.height) gray = it->second;
  // Images up to this stamp are of no further use.
  images_.erase(images_.begin(), images_.upper_bound(md.stamp));
  std::string reset;
  if (!cache_->push(md, &reset, gray)) {
    targets_->clear();
    if (health_.noteReset(reset)) NODELET_WARN("%s; planar targets cleared", reset.c_str());
  }
  const std::vector<PlanarTargetState> states = targets_->update(*cache_);
  if (targets_pub_.getNumSubscribers() > 0) targets_pub_.publish(toMsg(states, msg.header));
  if (config_.ros.publish_tf && !states.empty() && !fromBeforeTimeJump(msg.header.stamp)) {
    const auto transforms = planarTargetTransforms(states, msg.header, config_.ros.frame_prefix);
    if (!transforms.empty()) tf_->sendTransform(transforms);
  }
  if (markers_pub_.getNumSubscribers() > 0) markers_pub_.publish(planarTargetMarkers(states, msg.header));
  std::vector<std::string> statuses;
  for (const PlanarTargetState& s : states) statuses.push_back(targetStatusName(s.status));
  health_.setItems(statuses);
  health_.noteFrame(msg.header.stamp, started);
}

bool PlanarTargetNodelet::addCb(instant_motion_tracking::AddPlanarTarget::Request& req,
                                instant_motion_tracking::AddPlanarTarget::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::array<cv::Point2d, 4> corners;
  for (int i = 0; i < 4; ++i) corners[i] = cv::Point2d(req.corners[i].x, req.corners[i].y);
  std::string error;
  uint32_t id = 0;
  res.success = targets_->add(req.id, req.stamp.toSec(), corners, req.width_m, req.height_m, intrinsics(),
                              *cache_, &id, &error);
  res.id = res.success ? id : 0;
  res.message = res.success ? "tracking planar target " + std::to_string(id) : error;
  if (!res.success) NODELET_WARN_THROTTLE(1.0, "add_planar_target refused: %s", error.c_str());
  if (!res.success && cache_->empty())
    res.message += " (subscribed to " + getNodeHandle().resolveName("motion_data") + "; retry shortly)";
  updateSubscription();
  return true;
}

bool PlanarTargetNodelet::removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                                   instant_motion_tracking::RemoveRegion::Response& res) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::string error;
  res.success = targets_->remove(req.id, &error);
  res.message = res.success ? "removed planar target " + std::to_string(req.id) : error;
  updateSubscription();
  return true;
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::PlanarTargetNodelet, nodelet::Nodelet)
