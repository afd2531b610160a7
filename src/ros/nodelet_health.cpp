#include "instant_motion_tracking/ros/nodelet_health.h"

#include <algorithm>
#include <sstream>

namespace imt {

using diagnostic_msgs::DiagnosticStatus;

void NodeletHealth::start(ros::NodeHandle nh, ros::NodeHandle pnh, const std::string& name,
                          const std::string& input, double period_s, const std::string& items_title,
                          const std::vector<std::string>& item_statuses) {
  std::lock_guard<std::mutex> lock(mutex_);
  input_ = input;
  items_title_ = items_title;
  item_statuses_ = item_statuses;
  window_.begin = ros::WallTime::now();
  updater_ = std::make_unique<diagnostic_updater::Updater>(nh, pnh, name);
  updater_->setHardwareID(input);
  updater_->add("input", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { inputStatus(s); });
  updater_->add("processing", [this](diagnostic_updater::DiagnosticStatusWrapper& s) { processingStatus(s); });
  if (!items_title.empty())
    updater_->add(items_title, [this](diagnostic_updater::DiagnosticStatusWrapper& s) { itemsStatus(s); });
  // Wall time: ROS time may be a paused or looping sim clock.
  timer_ = nh.createWallTimer(ros::WallDuration(period_s), [this](const ros::WallTimerEvent&) { report(); });
}

void NodeletHealth::setSubscribed(bool subscribed) {
  std::lock_guard<std::mutex> lock(mutex_);
  subscribed_ = subscribed;
}

void NodeletHealth::noteFrame(const ros::Time& stamp, const ros::WallTime& started) {
  const ros::WallTime now = ros::WallTime::now();
  const double processing = (now - started).toSec();
  const double delay = (ros::Time::now() - stamp).toSec();
  std::lock_guard<std::mutex> lock(mutex_);
  ++frames_;
  ++window_.frames;
  last_input_ = now;
  window_.processing_sum += processing;
  window_.processing_max = std::max(window_.processing_max, processing);
  window_.delay_sum += delay;
  window_.delay_max = window_.frames == 1 ? delay : std::max(window_.delay_max, delay);
}

void NodeletHealth::noteDropped(const std::string& why) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++dropped_;
  ++window_.dropped;
  window_.drop_reason = why;
  last_input_ = ros::WallTime::now();
}

bool NodeletHealth::noteReset(const std::string& reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++resets_;
  ++window_.resets;
  window_.reset_reason = reason;
  const ros::WallTime now = ros::WallTime::now();
  if (!last_reset_log_.isZero() && now - last_reset_log_ < ros::WallDuration(1.0)) return false;
  last_reset_log_ = now;
  return true;
}

void NodeletHealth::noteGap(const std::string& reason) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++gaps_;
  ++window_.gaps;
  window_.gap_reason = reason;
}

void NodeletHealth::noteCameraInfoRefused(const std::string& why) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++info_refused_;
  ++window_.info_refused;
  window_.info_reason = why;
}

void NodeletHealth::setItems(const std::vector<std::string>& statuses) {
  std::lock_guard<std::mutex> lock(mutex_);
  items_.clear();
  for (const std::string& s : statuses) ++items_[s];
}

uint64_t NodeletHealth::resets() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return resets_;
}

void NodeletHealth::report() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    reported_ = window_;
    reported_.end = ros::WallTime::now();
    window_ = Window();
    window_.begin = reported_.end;
  }
  updater_->force_update();  // runs the status functions below
}

void NodeletHealth::inputStatus(diagnostic_updater::DiagnosticStatusWrapper& s) {
  std::lock_guard<std::mutex> lock(mutex_);
  const Window& w = reported_;
  const double seconds = std::max(1e-6, (w.end - w.begin).toSec());
  const double rate = w.frames / seconds;
  if (!subscribed_) {
    s.summary(DiagnosticStatus::OK, "idle: nothing subscribes to the outputs (lazy subscription)");
  } else if (w.resets > 0) {
    s.summaryf(DiagnosticStatus::WARN, "reset: %s", w.reset_reason.c_str());
  } else if (w.dropped > 0) {
    s.summaryf(DiagnosticStatus::WARN, "dropped %d inputs: %s", w.dropped, w.drop_reason.c_str());
  } else if (w.gaps > 0) {
    s.summaryf(DiagnosticStatus::WARN, "gap: %s", w.gap_reason.c_str());
  } else if (w.info_refused > 0) {
    s.summaryf(DiagnosticStatus::WARN, "refused %d camera_info: %s", w.info_refused, w.info_reason.c_str());
  } else if (w.frames == 0) {
    const double quiet = last_input_.isZero() ? -1 : (w.end - last_input_).toSec();
    if (quiet < 0)
      s.summaryf(DiagnosticStatus::WARN, "no input yet on %s", input_.c_str());
    else
      s.summaryf(DiagnosticStatus::WARN, "no input on %s for %.1f s", input_.c_str(), quiet);
  } else {
    s.summaryf(DiagnosticStatus::OK, "%.1f Hz", rate);
  }
  s.add("topic", input_);
  s.add("subscribed", subscribed_);
  s.addf("rate (Hz)", "%.2f", rate);
  s.add("frames", frames_);
  s.add("dropped", dropped_);
  s.add("resets", resets_);
  s.add("gaps", gaps_);
  s.add("camera_info refused", info_refused_);
}

void NodeletHealth::processingStatus(diagnostic_updater::DiagnosticStatusWrapper& s) {
  std::lock_guard<std::mutex> lock(mutex_);
  const Window& w = reported_;
  const double n = std::max(1, w.frames);
  s.summaryf(DiagnosticStatus::OK, w.frames ? "%.2f ms per frame" : "no frames in the period",
             1e3 * w.processing_sum / n);
  s.addf("processing mean (ms)", "%.3f", 1e3 * w.processing_sum / n);
  s.addf("processing max (ms)", "%.3f", 1e3 * w.processing_max);
  s.addf("delay after the image stamp mean (ms)", "%.1f", 1e3 * w.delay_sum / n);
  s.addf("delay after the image stamp max (ms)", "%.1f", 1e3 * w.delay_max);
}

void NodeletHealth::setNote(const std::string& key, const std::string& value) {
  std::lock_guard<std::mutex> lock(mutex_);
  notes_[key] = value;
}

void NodeletHealth::itemsStatus(diagnostic_updater::DiagnosticStatusWrapper& s) {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<std::string, int> counts = items_;
  for (const std::string& status : item_statuses_) counts.emplace(status, 0);
  int total = 0;
  std::ostringstream text;
  for (const auto& [status, count] : counts) {
    total += count;
    s.add(status, count);
    if (count > 0) text << (text.tellp() > 0 ? ", " : "") << count << " " << status;
  }
  s.add("total", total);
  for (const auto& [key, value] : notes_) s.add(key, value);
  s.summaryf(DiagnosticStatus::OK, "%d %s%s%s", total, items_title_.c_str(), total ? ": " : "",
             text.str().c_str());
}

}  // namespace imt
