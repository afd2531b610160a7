#include "instant_motion_tracking/ros/anchor_nodelet.h"

#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/markers.h"

#include <pluginlib/class_list_macros.hpp>
#include <visualization_msgs/MarkerArray.h>

namespace imt {

void AnchorNodelet::onInit() {
  joinSession();
  ros::NodeHandle& nh = getNodeHandle();
  tf_buffer_ = std::make_unique<tf2_ros::Buffer>();
  tf_listener_ = std::make_unique<tf2_ros::TransformListener>(*tf_buffer_);
  tf_ = std::make_unique<tf2_ros::TransformBroadcaster>();
  auto cb = [this](const ros::SingleSubscriberPublisher&) { updateSubscription(); };
  anchors_pub_ = nh.advertise<instant_motion_tracking::AnchorArray>("anchors", 10, cb, cb);
  markers_pub_ = nh.advertise<visualization_msgs::MarkerArray>("markers", 10, cb, cb);
  add_srv_ = nh.advertiseService("add_anchor", &AnchorNodelet::addCb, this);
  remove_srv_ = nh.advertiseService("remove_anchor", &AnchorNodelet::removeCb, this);
  startSession("camera_info", nh.resolveName("motion_data"), "anchors", {"tracked", "out_of_view", "no_imu", "lost", "calibrating"});
}

bool AnchorNodelet::wantsFrames() {
  return session([](TrackingSession& s) { return s.anchorCount() > 0; }) ||
         anchors_pub_.getNumSubscribers() > 0 || markers_pub_.getNumSubscribers() > 0;
}

// The IMU is read whenever the session wants frames: the anchors need it, and
// it stands in for the camera motion of frames without a model for every region.
bool AnchorNodelet::inputsWanted() { return hub_->framesWanted(); }

void AnchorNodelet::subscribeInputs(bool wanted) {
  SessionNodelet::subscribeInputs(SessionNodelet::inputsWanted());
  if (wanted && !imu_sub_) {
    imu_sub_ = getNodeHandle().subscribe("imu", 1000, &AnchorNodelet::imuCb, this);  // up to ~1 s at 1 kHz
  } else if (!wanted && imu_sub_) {
    imu_sub_.shutdown();
    // Samples from before a gap would only mislead.
    session([](TrackingSession& s) { s.resetImu(); });
  }
}

void AnchorNodelet::lookupRotation(TrackingSession& s, const std::string& imu_frame) {
  const bool new_frame = imu_frame != imu_frame_;
  imu_frame_ = imu_frame;
  // tf is looked up until it answers, and again when the IMU's frame changes
  // (the video's own estimate does not stop it: tf is the user's word).
  const bool from_tf = s.rotationSource() == AnchorManager::RotationSource::kTf;
  if (s.rotationFromOptions() || camera_frame_.empty() || (from_tf && !new_frame)) return;
  if (imu_frame.empty() || imu_frame == camera_frame_) {
    s.setRotationCamImu(Eigen::Quaterniond::Identity());
    return;
  }
  std::string why;
  try {
    if (tf_buffer_->canTransform(camera_frame_, imu_frame, ros::Time(0), &why)) {
      const auto t = tf_buffer_->lookupTransform(camera_frame_, imu_frame, ros::Time(0));
      const auto& q = t.transform.rotation;
      if (s.setRotationCamImu(Eigen::Quaterniond(q.w, q.x, q.y, q.z))) {
        NODELET_INFO("IMU-to-camera rotation from tf: %s <- %s", camera_frame_.c_str(), imu_frame.c_str());
        return;
      }
      why = "not a rotation";
    }
  } catch (const tf2::TransformException& e) {
    why = e.what();
  }
  NODELET_WARN_THROTTLE(10.0,
                        "no tf %s <- %s yet (%s); the IMU-to-camera rotation is estimated from the video until it "
                        "comes (%s)",
                        camera_frame_.c_str(), imu_frame.c_str(), why.c_str(),
                        s.rotationSource() == AnchorManager::RotationSource::kVideo
                            ? "found: anchors tracked with it"
                            : "not found yet: anchors calibrating");
}

// Where the IMU-to-camera rotation came from, and what the video shows of it:
// "tf (video: residual 0.040 over 120 turns)", "none (video: 3 turns so far)".
std::string AnchorNodelet::rotationReport(const TrackingSession& s) {
  const auto& video = s.videoRotation();
  std::string r = AnchorManager::rotationSourceName(s.rotationSource());
  char fit[96];
  if (video.residual() >= 0)
    std::snprintf(fit, sizeof(fit), " (video: residual %.3f over %zu turns)", video.residual(), video.pairs());
  else
    std::snprintf(fit, sizeof(fit), " (video: %zu turns so far)", video.pairs());
  // The camera-IMU time offset in use, and the video's.
  char offset[128];
  const auto& f = s.timeOffsetFit();
  const char* from = AnchorManager::offsetSourceName(s.timeOffsetSource());
  if (f && f->found)
    std::snprintf(offset, sizeof(offset), "; time offset %.1f ms from %s (video: %.1f ms, correlation %.2f)",
                  1000 * s.timeOffset(), from, 1000 * f->offset, f->correlation);
  else
    std::snprintf(offset, sizeof(offset), "; time offset %.1f ms from %s (video: none yet)", 1000 * s.timeOffset(),
                  from);
  return r + fit + offset + biasReport(s);
}

// The gyro bias in use and the video's estimate of it (deg/s):
// "; gyro bias (0.29 -0.34 0.20) deg/s from video (video: +-0.004 over 873 frames)".
std::string AnchorNodelet::biasReport(const TrackingSession& s) {
  constexpr double kDeg = 180 / M_PI;
  const Eigen::Vector3d b = s.gyroBias() * kDeg;
  char text[160];
  std::snprintf(text, sizeof(text), "; gyro bias (%.3f %.3f %.3f) deg/s from %s", b.x(), b.y(), b.z(),
                ImuOrientation::biasSourceName(s.gyroBiasSource()));
  char video[96];
  if (const auto& e = s.videoGyroBias())
    std::snprintf(video, sizeof(video), " (video: +-%.3f over %d frames; gyro late by %.1f +- %.1f ms)",
                  e->sigma.norm() * kDeg, e->frames, 1000 * e->lateness, 1000 * e->lateness_sigma);
  else
    std::snprintf(video, sizeof(video), " (video: none yet)");
  return std::string(text) + video;
}

void AnchorNodelet::imuCb(const sensor_msgs::ImuConstPtr& msg) {
  ImuSample sample;
  std::string why;
  if (!fromImuMsg(*msg, &sample, &why)) {
    NODELET_WARN_THROTTLE(5.0, "dropping IMU sample: %s", why.c_str());
    return;
  }
  std::string disagreement, rotation;
  const ImuInput r = session([&](TrackingSession& s) {
    imu_seen_ = true;
    lookupRotation(s, msg->header.frame_id);
    disagreement = s.rotationDisagreement();
    rotation = rotationReport(s);
    return s.addImu(sample, &why);
  });
  health_.setNote("IMU-to-camera rotation", rotation);
  if (!disagreement.empty()) NODELET_WARN_THROTTLE(30.0, "%s", disagreement.c_str());
  switch (r) {
    case ImuInput::kAccepted:
      break;
    case ImuInput::kReset:
      // Throttled: a driver that sends stamps out of order would restart it
      // on every backward sample (issue 16 measured 200 lines a second).
      NODELET_WARN_THROTTLE(5.0, "%s", why.c_str());
      break;
    case ImuInput::kDropped:
    case ImuInput::kGap:
      NODELET_WARN_THROTTLE(5.0, "%s", why.c_str());
      break;
  }
}

void AnchorNodelet::onResult(const FrameResult& r, const std_msgs::Header& header, const ros::WallTime& received) {
  camera_frame_ = header.frame_id;
  if (!r.reset.empty()) {
    // Time went back (a looping bag) or the image size changed: the tf
    // history belongs to the old stream.
    if (health_.noteReset(r.reset)) NODELET_WARN("%s; anchors cleared", r.reset.c_str());
    tf_buffer_->clear();
  }
  for (const AnchorState& s : r.anchors) {
    if (s.status != AnchorStatus::kNoImu) continue;
    const std::string where = imu_seen_ ? "" : " on " + getNodeHandle().resolveName("imu");
    NODELET_WARN_THROTTLE(10.0, "anchors are translation-only (status no_imu): %s%s", s.reason.c_str(),
                          where.c_str());
    break;
  }
  for (const AnchorState& s : r.anchors) {
    if (s.status != AnchorStatus::kCalibrating) continue;
    NODELET_WARN_THROTTLE(10.0, "anchors are translation-only (status calibrating): %s", s.reason.c_str());
    break;
  }

  if (anchors_pub_.getNumSubscribers() > 0) anchors_pub_.publish(toMsg(r.anchors, header));
  if (config_.ros.publish_tf && !r.anchors.empty() && !fromBeforeTimeJump(header.stamp)) {
    const auto transforms = anchorTransforms(r.anchors, header, config_.ros.frame_prefix);
    if (!transforms.empty()) tf_->sendTransform(transforms);
  }
  if (markers_pub_.getNumSubscribers() > 0) markers_pub_.publish(anchorMarkers(r.anchors, header));
  std::vector<std::string> statuses;
  for (const AnchorState& s : r.anchors) statuses.push_back(anchorStatusName(s.status));
  health_.setItems(statuses);
  // Processing time includes the wait for the IMU: what a consumer sees.
  health_.noteFrame(header.stamp, received);
}

bool AnchorNodelet::addCb(instant_motion_tracking::AddAnchor::Request& req,
                          instant_motion_tracking::AddAnchor::Response& res) {
  std::string error;
  uint32_t id = 0;
  bool no_frames = false;
  res.success = session([&](TrackingSession& s) {
    const bool ok = s.addAnchor(req.id, req.stamp.toSec(), cv::Point2d(req.u, req.v), req.depth, &id, &error);
    no_frames = !ok && s.cache().empty();
    return ok;
  });
  res.id = res.success ? id : 0;
  res.message = res.success ? "tracking anchor " + std::to_string(id) : error;
  if (!res.success) NODELET_WARN_THROTTLE(1.0, "add_anchor refused: %s", error.c_str());
  // Refused for want of frames: stay subscribed so that a retry finds some.
  awaitFrames(no_frames);
  updateSubscription();
  if (!res.success) res.message += retryHint();
  return true;
}

bool AnchorNodelet::removeCb(instant_motion_tracking::RemoveRegion::Request& req,
                             instant_motion_tracking::RemoveRegion::Response& res) {
  std::string error;
  res.success = session([&](TrackingSession& s) { return s.removeAnchor(req.id, &error); });
  res.message = res.success ? "removed anchor " + std::to_string(req.id) : error;
  updateSubscription();
  return true;
}

}  // namespace imt

PLUGINLIB_EXPORT_CLASS(imt::AnchorNodelet, nodelet::Nodelet)
