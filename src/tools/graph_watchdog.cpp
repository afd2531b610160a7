// graph_watchdog: says loudly when a nodelet of the live graph is gone or
// stops working, which the nodelet itself cannot (launch/tracking.launch
// starts it beside the manager, as a process of its own).
//
// Every `period` s of wall time it asks the manager which nodelets are
// loaded (`<manager>/list`) and reads each nodelet's own "<name>: input"
// status on /diagnostics (NodeletHealth). After its first `silence` s (the
// graph coming up), a nodelet is in ERROR when
//  - it is not loaded in the manager (unloaded: a broken bond, a crash, a
//    user's unload; read from the manager's last answer), or the manager has
//    not answered for `silence` s (a loaded machine makes one call late, which
//    is no failure);
//  - its diagnostics have been silent for `silence` s (hung, or its manager
//    died);
//  - a tracker is subscribed (someone wants its outputs) and has processed
//    no frame for `silence` s while motion_data keeps coming (the motion
//    analysis, the first of `nodelets`, reports frames). The motion analysis
//    says itself when no images come.
// Each nodelet's verdict is published on /diagnostics as
// "graph_watchdog: <nodelet>" (OK or ERROR, with the reason), and each change
// to ERROR is logged at ERROR (again every 30 s while it lasts; the recovery
// at INFO).
//
// Private parameters: manager (default imt_manager), nodelets (list; default
// motion_analysis, region_tracker, planar_targets, anchor_tracker; the first
// is the motion analysis), period (s, default 1.0), silence (s, default 5.0).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <nodelet/NodeletList.h>
#include <ros/ros.h>

#include <algorithm>
#include <cstdlib>
#include <map>
#include <set>
#include <string>
#include <vector>

namespace {

using diagnostic_msgs::DiagnosticStatus;

std::string withoutSlash(const std::string& name) {
  return !name.empty() && name[0] == '/' ? name.substr(1) : name;
}

struct Watched {
  ros::WallTime last_diagnostics;  // zero: never seen
  ros::WallTime last_frames;       // when it last reported frames (or began to be watched)
  bool subscribed = false;
  double rate = 0;                 // Hz, its last reported input rate
  bool in_error = false;
  std::string reason;
  ros::WallTime last_log;
};

class GraphWatchdog {
 public:
  GraphWatchdog(ros::NodeHandle nh, ros::NodeHandle pnh) : nh_(nh) {
    pnh.param<std::string>("manager", manager_, "imt_manager");
    pnh.param("nodelets", names_,
              std::vector<std::string>{"motion_analysis", "region_tracker", "planar_targets", "anchor_tracker"});
    pnh.param("period", period_, 1.0);
    pnh.param("silence", silence_, 5.0);
    if (!(period_ > 0) || !(silence_ > 0) || names_.empty()) {
      ROS_FATAL("graph_watchdog: period and silence must be > 0 s and nodelets not empty (period %g, silence %g, "
                "%zu nodelets)", period_, silence_, names_.size());
      ros::shutdown();
      return;
    }
    started_ = ros::WallTime::now();
    // Full names without the leading slash, as the manager lists them and
    // the diagnostics name them.
    for (std::string& n : names_) {
      n = withoutSlash(ros::names::resolve(n));
      watched_[n].last_frames = started_;
    }
    list_ = nh_.serviceClient<nodelet::NodeletList>(ros::names::resolve(manager_) + "/list");
    pub_ = nh_.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 10);
    sub_ = nh_.subscribe("/diagnostics", 100, &GraphWatchdog::onDiagnostics, this);
    timer_ = nh_.createWallTimer(ros::WallDuration(period_), [this](const ros::WallTimerEvent&) { check(); });
  }

 private:
  void onDiagnostics(const diagnostic_msgs::DiagnosticArray& msg) {
    const ros::WallTime now = ros::WallTime::now();
    for (const DiagnosticStatus& s : msg.status) {
      const size_t colon = s.name.find(": input");
      if (colon == std::string::npos || colon + 7 != s.name.size()) continue;
      auto it = watched_.find(withoutSlash(s.name.substr(0, colon)));
      if (it == watched_.end()) continue;
      Watched& w = it->second;
      w.last_diagnostics = now;
      for (const auto& kv : s.values) {
        if (kv.key == "subscribed") w.subscribed = kv.value == "True" || kv.value == "true" || kv.value == "1";
        if (kv.key == "rate (Hz)") w.rate = std::atof(kv.value.c_str());
      }
      if (w.rate > 0 || !w.subscribed) w.last_frames = now;
    }
  }

  void check() {
    const ros::WallTime now = ros::WallTime::now();
    // Which nodelets the manager has (a short wait: a busy manager answers late).
    nodelet::NodeletList srv;
    if (list_.waitForExistence(ros::Duration(std::min(1.0, period_))) && list_.call(srv)) {
      last_answer_ = now;
      loaded_.clear();
      for (const std::string& n : srv.response.nodelets) loaded_.insert(withoutSlash(n));
    }
    const double unanswered = (now - (last_answer_.isZero() ? started_ : last_answer_)).toSec();
    const bool grace = (now - started_).toSec() < silence_;  // the graph is still coming up
    const Watched& source = watched_[names_.front()];  // the motion analysis
    diagnostic_msgs::DiagnosticArray out;
    out.header.stamp = ros::Time::now();
    for (const std::string& name : names_) {
      Watched& w = watched_[name];
      std::string reason;
      const double silent = (now - (w.last_diagnostics.isZero() ? started_ : w.last_diagnostics)).toSec();
      if (unanswered > silence_) {
        reason = "its manager " + manager_ + " has not answered " + list_.getService() + " for " +
                 std::to_string(static_cast<int>(unanswered)) + " s";
      } else if (!last_answer_.isZero() && !loaded_.count(name)) {
        reason = "not loaded in " + manager_ + " (unloaded: a broken bond, a crash, or an unload request)";
      } else if (silent > silence_) {
        reason = "no diagnostics for " + std::to_string(static_cast<int>(silent)) + " s (hung?)";
      } else if (name != names_.front() && w.subscribed && source.rate > 0 &&
                 (now - w.last_frames).toSec() > silence_) {
        reason = "no frames processed for " + std::to_string(static_cast<int>((now - w.last_frames).toSec())) +
                 " s while motion_data flows at " + std::to_string(source.rate).substr(0, 5) + " Hz";
      }
      if (grace) reason.clear();  // the loaders may still be loading
      report(name, reason, now, &out);
    }
    pub_.publish(out);
  }

  void report(const std::string& name, const std::string& reason, const ros::WallTime& now,
              diagnostic_msgs::DiagnosticArray* out) {
    Watched& w = watched_[name];
    const bool error = !reason.empty();
    if (error && (!w.in_error || reason != w.reason || (now - w.last_log).toSec() >= 30)) {
      ROS_ERROR("graph_watchdog: nodelet %s: %s", name.c_str(), reason.c_str());
      w.last_log = now;
    } else if (!error && w.in_error) {
      ROS_INFO("graph_watchdog: nodelet %s works again", name.c_str());
    }
    w.in_error = error;
    w.reason = reason;
    DiagnosticStatus s;
    s.name = "graph_watchdog: " + name;
    s.hardware_id = manager_;
    s.level = error ? DiagnosticStatus::ERROR : DiagnosticStatus::OK;
    s.message = error ? reason : "loaded and working";
    out->status.push_back(s);
  }

  ros::NodeHandle nh_;
  std::string manager_;
  std::vector<std::string> names_;
  double period_ = 1, silence_ = 5;
  ros::WallTime started_;
  ros::WallTime last_answer_;    // the manager's last answer to list (zero: none yet)
  std::set<std::string> loaded_;  // the nodelets it listed then
  std::map<std::string, Watched> watched_;
  ros::ServiceClient list_;
  ros::Publisher pub_;
  ros::Subscriber sub_;
  ros::WallTimer timer_;
};

}  // namespace

int main(int argc, char** argv) {
  ros::init(argc, argv, "graph_watchdog");
  ros::NodeHandle nh, pnh("~");
  GraphWatchdog watchdog(nh, pnh);
  ros::spin();
  return 0;
}
