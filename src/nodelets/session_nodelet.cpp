#include "instant_motion_tracking/ros/session_nodelet.h"

#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/image_conversion.h"
#include "instant_motion_tracking/ros/params.h"

#include <stdexcept>

namespace imt {

SessionNodelet::~SessionNodelet() { leaveSession(); }

void SessionNodelet::leaveSession() {
  if (hub_ && member_ != -1) hub_->removeMember(member_);  // waits for a result being dispatched
  member_ = -1;
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
  m.wants_images = wantsImages();
  camera_info_topic_ = camera_info_topic;
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
  const bool subscribed = motion_sub_ || paired_motion_;
  const uint32_t queue = 10 * config_.ros.queue_size;
  if (wanted && !subscribed) {
    if (wantsImages() && config_.ros.image_transport == "raw") {
      ros::NodeHandle& nh = getNodeHandle();
      paired_motion_ = std::make_unique<message_filters::Subscriber<instant_motion_tracking::MotionData>>(
          nh, "motion_data", queue);
      paired_image_ = std::make_unique<message_filters::Subscriber<sensor_msgs::Image>>(nh, "image", queue);
      sync_ = std::make_unique<Sync>(*paired_motion_, *paired_image_, 10);
      sync_->registerCallback(&SessionNodelet::pairedCb, this);
      paired_motion_->registerCallback(&SessionNodelet::motionCb, this);  // frames without an image
      session([](TrackingSession& s) { s.setKeepImages(true); });
    } else {
      motion_sub_ = getNodeHandle().subscribe("motion_data", queue, &SessionNodelet::motionCb, this);
    }
  } else if (!wanted && subscribed) {
    motion_sub_.shutdown();
    sync_.reset();
    paired_image_.reset();
    paired_motion_.reset();
  }
  subscribeCameraInfo(wanted);
  health_.setSubscribed(bool(motion_sub_) || bool(paired_motion_) || hub_->hasImageFeeder());
}

void SessionNodelet::subscribeCameraInfo(bool on) {
  if (on && !info_sub_)
    info_sub_ = getNodeHandle().subscribe(camera_info_topic_, 1, &SessionNodelet::infoCb, this);
  else if (!on && info_sub_)
    info_sub_.shutdown();
}

std::string SessionNodelet::retryHint() {
  if (session([](TrackingSession& s) { return !s.cache().empty(); })) return "";
  return " (subscribed to " + getNodeHandle().resolveName(hub_->hasImageFeeder() ? "image" : "motion_data") +
         "; retry shortly)";
}

// camera_info into the session; a refused one (ros/conversions.h
// cameraInfoForFrames: the same check as track_bag's) is warned about,
// throttled, and counted; the session keeps the camera model it had.
void SessionNodelet::infoCb(const sensor_msgs::CameraInfoConstPtr& msg) {
  std::string why;
  const bool accepted = session([&](TrackingSession& s) {
    CameraModel k;
    if (!cameraInfoForFrames(*msg, config_.pipeline.image_rectified, s.cache().imageSize(), &k, &why)) return false;
    s.setCameraInfo(k);
    return true;
  });
  if (accepted) return;
  NODELET_WARN_THROTTLE(5.0, "camera_info refused (the last one accepted, else default_hfov_deg, stands): %s",
                        why.c_str());
  health_.noteCameraInfoRefused(why);
}

// motion_data from another process (no image feeder in this manager). When
// images are joined to it, a frame goes in here only while no image has come
// for a second (the joined callback feeds the others).
void SessionNodelet::motionCb(const instant_motion_tracking::MotionDataConstPtr& msg) {
  if (sync_) {
    std::lock_guard<std::mutex> lock(feed_mutex_);
    if ((ros::WallTime::now() - last_image_).toSec() < 1.0) return;
  }
  feed(msg, cv::Mat());
}

void SessionNodelet::pairedCb(const instant_motion_tracking::MotionDataConstPtr& msg,
                              const sensor_msgs::ImageConstPtr& image) {
  cv::Mat gray;
  std::string why;
  if (!imageToGray(*image, &gray, &why)) {
    NODELET_WARN_THROTTLE(5.0, "image not used for the alignment: %s", why.c_str());
    gray.release();
  }
  {
    std::lock_guard<std::mutex> lock(feed_mutex_);
    last_image_ = ros::WallTime::now();
  }
  feed(msg, gray);
}

void SessionNodelet::feed(const instant_motion_tracking::MotionDataConstPtr& msg, const cv::Mat& gray) {
  const ros::WallTime received = ros::WallTime::now();
  {
    // A frame both callbacks saw (as images start or stop): once.
    std::lock_guard<std::mutex> lock(feed_mutex_);
    if (msg->header.stamp == last_fed_) return;
    last_fed_ = msg->header.stamp;
  }
  const MotionData md = fromMsg(*msg);
  if (md.width <= 0 || md.height <= 0) {
    NODELET_WARN_THROTTLE(5.0, "dropping motion_data without an image size");
    health_.noteDropped("motion_data without an image size");
    return;
  }
  hub_->noteHeader(msg->header, received);
  std::string dropped, gap;
  session([&](TrackingSession& s) {
    s.pushMotion(md, gray);
    dropped = s.lastDrop();
    gap = s.lastGap();
  });
  if (!gap.empty()) {
    NODELET_WARN_THROTTLE(5.0, "%s", gap.c_str());
    health_.noteGap(gap);
  }
  if (!dropped.empty()) {
    // A repeated stamp, or one slightly behind: dropped, tracks kept.
    NODELET_WARN_THROTTLE(5.0, "%s", dropped.c_str());
    health_.noteDropped(dropped);
  }
}

}  // namespace imt
