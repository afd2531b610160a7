#include "instant_motion_tracking/ros/session_nodelet.h"

#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/params.h"

#include <stdexcept>

namespace imt {

SessionNodelet::~SessionNodelet() {
  if (hub_) hub_->removeMember(member_);
}

void SessionNodelet::joinSession() {
  std::string error;
  if (!loadConfigFromRos(getPrivateNodeHandle(), &config_, &error)) {
    // A typo or a wrong type is never swapped for a default: the nodelet
    // does not start (the manager refuses the load and lives on).
    NODELET_FATAL("not started: %s", error.c_str());
    throw std::runtime_error(getName() + ": " + error);
  }
  std::string note;
  hub_ = SessionHub::join(getNodeHandle().resolveName("motion_data"), config_, &note);
  if (!note.empty()) NODELET_WARN("%s", note.c_str());
}

void SessionNodelet::startSession(const std::string& camera_info_topic, const std::string& input_topic,
                                  const std::string& items_title, const std::vector<std::string>& statuses,
                                  bool feeds_images) {
  ros::NodeHandle& nh = getNodeHandle();
  SessionHub::Member m;
  m.on_result = [this](const FrameResult& r, const std_msgs::Header& h, const ros::WallTime& received) {
    onResult(r, h, received);
  };
  m.on_demand_changed = [this] { updateInputs(); };
  m.feeds_images = feeds_images;
  info_sub_ = nh.subscribe(camera_info_topic, 1, &SessionNodelet::infoCb, this);
  health_.start(nh, getPrivateNodeHandle(), getName(), input_topic, config_.ros.diagnostic_period, items_title,
                statuses);
  member_ = hub_->addMember(std::move(m));
  updateSubscription();
}

void SessionNodelet::updateSubscription() {
  hub_->setWantsFrames(member_, config_.ros.always_subscribe || awaiting_frames_ || wantsFrames());
  updateInputs();
}

void SessionNodelet::updateInputs() {
  std::lock_guard<std::mutex> lock(inputs_mutex_);
  subscribeInputs(inputsWanted());
}

bool SessionNodelet::inputsWanted() {
  return !hub_->hasImageFeeder() && hub_->motionFeeder() == member_ && hub_->framesWanted();
}

void SessionNodelet::subscribeInputs(bool wanted) {
  if (wanted && !motion_sub_) {
    motion_sub_ = getNodeHandle().subscribe("motion_data", 10 * config_.ros.queue_size, &SessionNodelet::motionCb, this);
  } else if (!wanted && motion_sub_) {
    motion_sub_.shutdown();
  }
  health_.setSubscribed(bool(motion_sub_) || hub_->hasImageFeeder());
}

std::string SessionNodelet::retryHint() {
  if (session([](TrackingSession& s) { return !s.cache().empty(); })) return "";
  return " (subscribed to " + getNodeHandle().resolveName(hub_->hasImageFeeder() ? "image" : "motion_data") +
         "; retry shortly)";
}

void SessionNodelet::infoCb(const sensor_msgs::CameraInfoConstPtr& msg) {
  CameraModel k;
  std::string why;
  if (fromCameraInfo(*msg, &k, &why, config_.pipeline.image_rectified)) {
    session([&](TrackingSession& s) { s.setCameraInfo(k); });
  } else {
    NODELET_WARN_THROTTLE(10.0, "ignoring camera_info: %s", why.c_str());
  }
}

// motion_data from another process (no image feeder in this manager).
void SessionNodelet::motionCb(const instant_motion_tracking::MotionDataConstPtr& msg) {
  const ros::WallTime received = ros::WallTime::now();
  const MotionData md = fromMsg(*msg);
  if (md.width <= 0 || md.height <= 0) {
    NODELET_WARN_THROTTLE(5.0, "dropping motion_data without an image size");
    health_.noteDropped("motion_data without an image size");
    return;
  }
  hub_->noteHeader(msg->header, received);
  session([&](TrackingSession& s) { s.pushMotion(md); });
}

}  // namespace imt
