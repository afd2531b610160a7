// SessionNodelet: what the four nodelets share. Each is a thin view of the
// one TrackingSession of its camera stream in this nodelet manager
// (ros/session_hub.h): it loads the parameters, joins the session, feeds it
// camera_info, publishes its part of each frame's result and serves its
// services on the session. No nodelet holds tracking state of its own.
//
// Subclasses implement:
//   wantsFrames()      whether this nodelet needs frames analysed (items, subscribers)
//   onResult()         publish its outputs of one frame (runs under the hub's lock)
//   inputsWanted()/subscribeInputs()   its own inputs (default: motion_data, read
//                      by the hub's motion feeder when no image feeder is in the manager)
// Parameters: the private namespace, config/default.yaml (ros/params.h).
// Threading: callbacks may run on several threads: the hub serialises the
// session; subscriptions change under `inputs_mutex_`.
#pragma once

#include "instant_motion_tracking/MotionData.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/ros/nodelet_health.h"
#include "instant_motion_tracking/ros/session_hub.h"

#include <message_filters/subscriber.h>
#include <message_filters/time_synchronizer.h>
#include <nodelet/nodelet.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace imt {

class SessionNodelet : public nodelet::Nodelet {
 public:
  ~SessionNodelet() override;

 protected:
  // Loads the parameters and joins the session: first thing in onInit().
  // Throws (the nodelet does not start) on a bad parameter, naming it.
  void joinSession();
  // Then, once the publishers exist: becomes a member of the session (its
  // results reach onResult()); `camera_info_topic` is subscribed while this
  // nodelet feeds the session (subscribeCameraInfo)
  // (`camera_info_topic`). `items_title`/`statuses`: the diagnostics of this
  // nodelet's items (see NodeletHealth::start).
  void startSession(const std::string& camera_info_topic, const std::string& input_topic,
                    const std::string& items_title, const std::vector<std::string>& statuses,
                    bool feeds_images = false);
  // Stops being a member of the session (idempotent). The first thing each
  // derived nodelet's destructor does: the session calls onResult() from
  // other nodelets' threads, and once the derived part is gone that call
  // would reach a pure virtual (an unload, or a broken bond, would take the
  // whole manager down).
  void leaveSession();
  // Re-checks whether this nodelet wants frames, then every input.
  void updateSubscription();
  // camera_info into the session, while this nodelet feeds it frames (one
  // subscriber per manager, not one per nodelet). A refused one
  // (cameraInfoForFrames, ros/conversions.h) is warned about, throttled, and
  // counted in this nodelet's input diagnostics.
  void subscribeCameraInfo(bool on);
  // Whether a request refused for want of frames should keep the inputs up.
  void awaitFrames(bool refused_without_frames) { awaiting_frames_ = refused_without_frames; }
  bool awaitingFrames() const { return awaiting_frames_; }
  // " (subscribed to <motion_data>; retry shortly)" when the session has no frame yet.
  std::string retryHint();

  virtual bool wantsFrames() = 0;
  virtual void onResult(const FrameResult& result, const std_msgs::Header& header, const ros::WallTime& received) = 0;
  // Default: motion_data, while this nodelet is the hub's motion feeder and frames are wanted.
  virtual bool inputsWanted();
  virtual void subscribeInputs(bool wanted);
  // Whether, when it feeds the session from motion_data, this nodelet also
  // wants each frame's image (`image`, raw transport), joined to it by stamp
  // with message_filters; frames whose image does not come (or all frames,
  // while no image has come for a second) go in without one.
  virtual bool wantsImages() const { return false; }

  // Runs `f` on the session (see SessionHub::run).
  template <class F>
  auto session(F&& f) {
    return hub_->run(std::forward<F>(f));
  }

  Config config_;
  std::shared_ptr<SessionHub> hub_;
  NodeletHealth health_;
  std::mutex inputs_mutex_;  // guards the subscriptions

 private:
  void updateInputs();
  void infoCb(const sensor_msgs::CameraInfoConstPtr& msg);
  void motionCb(const instant_motion_tracking::MotionDataConstPtr& msg);
  void pairedCb(const instant_motion_tracking::MotionDataConstPtr& msg, const sensor_msgs::ImageConstPtr& image);
  void feed(const instant_motion_tracking::MotionDataConstPtr& msg, const cv::Mat& gray);

  SessionHub::MemberId member_ = -1;
  std::string camera_info_topic_;
  ros::Subscriber info_sub_, motion_sub_;
  // motion_data joined with image (wantsImages()).
  using Sync = message_filters::TimeSynchronizer<instant_motion_tracking::MotionData, sensor_msgs::Image>;
  std::unique_ptr<message_filters::Subscriber<instant_motion_tracking::MotionData>> paired_motion_;
  std::unique_ptr<message_filters::Subscriber<sensor_msgs::Image>> paired_image_;
  std::unique_ptr<Sync> sync_;
  std::mutex feed_mutex_;  // guards the two below
  ros::Time last_fed_;
  ros::WallTime last_image_;
  bool awaiting_frames_ = false;
};

}  // namespace imt
