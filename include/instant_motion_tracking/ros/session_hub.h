// SessionHub: the one TrackingSession (core/tracking_session.h) of a camera
// stream, shared by the nodelets of one nodelet manager, so that a manager
// holds one motion-data cache and decodes each image once.
//
// The nodelets that resolve `motion_data` to the same topic in one process
// join the same hub. Its members:
// - MotionAnalysisNodelet feeds it images (analyze) and publishes motion_data;
// - the tracker nodelets serve their services on the session and publish
//   their outputs from each frame's result;
// - without an image feeder in the process (a tracker nodelet started on its
//   own), one tracker member, the motion feeder, subscribes motion_data and
//   feeds the session with it (pushMotion), so a topic is read once too.
// Whoever changes the session (a frame, an IMU sample, a request) does so
// through run(), which then hands every frame that became ready to every
// member, in frame order.
//
// Usage (in a nodelet):
//   hub_ = SessionHub::join(nh.resolveName("motion_data"), config_, &note);
//   member_ = hub_->addMember({on_result, on_demand_changed, /*feeds_images=*/false});
//   hub_->run([&](TrackingSession& s) { ok = s.addRegion(...); });
//   hub_->setWantsFrames(member_, wanted);          // lazy subscriptions
//   ~: hub_->removeMember(member_);  // before the member's callbacks become invalid
// Threading: every method may be called from any thread. `on_result` runs
// under the hub's lock: it must not call the hub's run() (it may read
// through the session reference it is given). `on_demand_changed` runs
// without it, on whichever thread changed the demand. removeMember() returns
// once no callback of that member runs, nor will: a result being dispatched
// holds the lock it takes, and an on_demand_changed in flight on another
// thread is waited for (a member leaving from inside its own callback does
// not wait for that call). So a member may be destroyed as soon as it has
// left; it must not leave under run() or from its on_result.
#pragma once

#include "instant_motion_tracking/core/tracking_session.h"
#include "instant_motion_tracking/io/config.h"

#include <ros/time.h>
#include <std_msgs/Header.h>

#include <condition_variable>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <type_traits>

namespace imt {

class SessionHub {
 public:
  using MemberId = int;
  struct Member {
    // A frame's result (its image header), after the trackers ran on it.
    // `received`: the wall time the frame came in (for processing times).
    std::function<void(const FrameResult&, const std_msgs::Header&, const ros::WallTime& received)> on_result;
    // Whether frames are wanted, or who feeds the session, changed: re-check subscriptions.
    std::function<void()> on_demand_changed;
    bool feeds_images = false;  // MotionAnalysisNodelet
    bool wants_images = false;  // joins images to motion_data when it feeds the session from it
  };

  // The hub of `key` in this process, made with `config` when there is none.
  // When an existing hub's pipeline options differ from `config`'s, `note`
  // says so (the hub keeps its own).
  static std::shared_ptr<SessionHub> join(const std::string& key, const Config& config, std::string* note);

  MemberId addMember(Member member);
  // Waits for the member's on_demand_changed calls in flight on other
  // threads (see Threading above); then none starts.
  void removeMember(MemberId id);
  // Whether this member wants frames analysed (it has items or subscribers).
  void setWantsFrames(MemberId id, bool wants);
  bool framesWanted() const;
  bool hasImageFeeder() const;
  // The tracker member that feeds motion_data while there is no image
  // feeder: the oldest one that joins images to it, else the oldest; -1
  // when there is none.
  MemberId motionFeeder() const;

  // Remembers the header of a frame about to go in (its results go out with
  // it) and when it came in.
  void noteHeader(const std_msgs::Header& header, const ros::WallTime& received);
  // Runs `f` on the session under the hub's lock, then hands the frames that
  // became ready to every member. Returns what `f` returns.
  template <class F>
  auto run(F&& f) {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    if constexpr (std::is_void_v<decltype(f(*session_))>) {
      f(*session_);
      dispatch();
    } else {
      auto r = f(*session_);
      dispatch();
      return r;
    }
  }

  const std::string& key() const { return key_; }

 private:
  SessionHub(const std::string& key, const Config& config);
  void dispatch();  // mutex_ held
  struct Arrival {
    std_msgs::Header header;
    ros::WallTime received;
  };
  Arrival arrivalOf(double stamp) const;
  void notifyDemand();  // without mutex_

  const std::string key_;
  mutable std::recursive_mutex mutex_;
  std::unique_ptr<TrackingSession> session_;
  std::map<MemberId, Member> members_;
  std::map<MemberId, bool> wants_;
  // on_demand_changed calls made and not yet ended, per member (notifyDemand),
  // and their end signalled (removeMember waits on it under mutex_).
  std::map<MemberId, int> calls_in_flight_;
  std::condition_variable_any calls_done_;
  MemberId next_id_ = 0;
  std::deque<Arrival> arrivals_;  // of recent frames, for their results
  std::string frame_id_;
};

}  // namespace imt
