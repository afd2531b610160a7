// NodeletHealth: what a nodelet reports about itself, kept out of the nodelets.
//
// - Resets (time going backwards at a bag loop, an image size change, a bad
//   frame) are counted and each is logged once, at most one log per wall
//   second: ROS time may be sim time that jumps back, which would confuse a
//   ROS-time throttle, and a stream that resets on every frame must not flood.
// - Diagnostics through diagnostic_updater on /diagnostics, every
//   ~diagnostic_period s of wall time (so a paused or looping bag on sim time
//   does not stop them), named "<nodelet name>: <task>":
//     input        rate (Hz, wall), frames, dropped inputs, resets, gaps,
//                  camera_info refused; WARN when subscribed without input,
//                  or on a reset, drop, gap or refused camera_info in the
//                  period
//     processing   callback time (ms, wall) and delay of the output after its
//                  image stamp (ms, ROS time), mean and max over the period
//     <items>      e.g. "regions": how many items are in each status, plus
//                  what the nodelet adds with setNote() (e.g. the anchors'
//                  IMU-to-camera rotation: where it came from)
//
// Usage (the nodelet's callbacks, under its own lock or not: this class locks):
//   health_.start(nh, pnh, getName(), nh.resolveName("image"), period, "regions", {"tracked", ...});
//   health_.setSubscribed(bool(sub_));                       // lazy subscription state
//   const ros::WallTime started = ros::WallTime::now();  ...  health_.noteFrame(stamp, started);
//   health_.setItems({"tracked", "lost"});                   // one status per item
//   if (health_.noteReset(reason)) NODELET_WARN("%s", reason.c_str());
// Threading: every method may be called from any thread.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <ros/ros.h>

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace imt {

class NodeletHealth {
 public:
  // Starts reporting. `name`: the nodelet's name (getName()); `input`: its
  // input topic (reported as the hardware id). `items_title` empty: no items
  // task; `item_statuses`: the statuses always listed (0 when none).
  void start(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& name, const std::string& input,
             double period_s, const std::string& items_title = "",
             const std::vector<std::string>& item_statuses = {});

  void setSubscribed(bool subscribed);
  // One input processed: its stamp and the wall time its callback began.
  void noteFrame(const ros::Time& stamp, const ros::WallTime& started);
  // One input dropped (bad encoding, no image size, ...).
  void noteDropped(const std::string& why);
  // Counts a reset; true when it should be logged now.
  bool noteReset(const std::string& reason);
  // Counts a gap (frames missing for longer than the cache: tracks kept).
  void noteGap(const std::string& reason);
  // Counts a camera_info refused (ros/conversions.h cameraInfoForFrames).
  void noteCameraInfoRefused(const std::string& why);
  // The current items' statuses, one entry per item.
  void setItems(const std::vector<std::string>& statuses);
  // A key and value shown with the items (replacing the key's last value).
  void setNote(const std::string& key, const std::string& value);

  uint64_t resets() const;

 private:
  struct Window {
    ros::WallTime begin, end;
    int frames = 0, dropped = 0, resets = 0, gaps = 0, info_refused = 0;
    double processing_sum = 0, processing_max = 0, delay_sum = 0, delay_max = 0;
    std::string drop_reason, reset_reason, gap_reason, info_reason;
  };
  void report();
  void inputStatus(diagnostic_updater::DiagnosticStatusWrapper& s);
  void processingStatus(diagnostic_updater::DiagnosticStatusWrapper& s);
  void itemsStatus(diagnostic_updater::DiagnosticStatusWrapper& s);

  mutable std::mutex mutex_;
  std::unique_ptr<diagnostic_updater::Updater> updater_;
  ros::WallTimer timer_;
  std::string input_, items_title_;
  std::vector<std::string> item_statuses_;
  std::map<std::string, int> items_;
  std::map<std::string, std::string> notes_;
  bool subscribed_ = false;
  Window window_, reported_;  // the period being filled, the one last reported
  uint64_t frames_ = 0, dropped_ = 0, resets_ = 0, gaps_ = 0, info_refused_ = 0;
  ros::WallTime last_input_, last_reset_log_;
};

// On sim time, a frame stamped well after the current ROS time arrived before
// the clock jumped back (a looping bag) and is processed after it. Its tf
// must not go out: a tf2 listener clears its buffer at the jump, would keep
// this transform, and then see it again from the new pass (TF_REPEATED_DATA).
// `margin_s`: how far ahead of the clock a stamp may be (the clock's own lag).
inline bool fromBeforeTimeJump(const ros::Time& stamp, double margin_s = 0.5) {
  return ros::Time::isSimTime() && (stamp - ros::Time::now()).toSec() > margin_s;
}

}  // namespace imt
