#include "instant_motion_tracking/ros/session_hub.h"

#include <algorithm>
#include <utility>
#include <vector>

namespace imt {
namespace {

// The member callbacks this thread is running (hub, member), innermost last:
// a member that leaves from inside its own callback does not wait for itself.
thread_local std::vector<std::pair<const SessionHub*, SessionHub::MemberId>> t_running;

// Runs `f` when the scope ends, however it ends.
template <class F>
struct Finally {
  F f;
  ~Finally() { f(); }
};
template <class F>
Finally(F) -> Finally<F>;

// The pipeline parameters in which `a` and `b` differ, by name (at most
// three); "" when they agree.
std::string differences(const Config& a, const Config& b) {
  Config ca, cb;
  ca.pipeline = a.pipeline;
  cb.pipeline = b.pipeline;
  const auto la = listParameters(ca), lb = listParameters(cb);
  std::string out;
  int n = 0;
  for (size_t i = 0; i < la.size() && i < lb.size(); ++i) {
    if (la[i].second == lb[i].second) continue;
    if (n++ < 3) out += (out.empty() ? "" : ", ") + la[i].first + " " + lb[i].second + " vs " + la[i].second;
  }
  if (n > 3) out += ", ...";
  return out;
}

std::mutex& registryMutex() {
  static std::mutex m;
  return m;
}

struct Entry {
  std::weak_ptr<SessionHub> hub;
  Config config;
};

std::map<std::string, Entry>& registry() {
  static std::map<std::string, Entry> r;
  return r;
}

constexpr size_t kHeadersKept = 300;  // frames' headers awaiting their results (10 s at 30 Hz)

}  // namespace

SessionHub::SessionHub(const std::string& key, const Config& config)
    : key_(key),
      session_(std::make_unique<TrackingSession>(config.pipeline, TrackingSession::Mode::kLive)) {}

std::shared_ptr<SessionHub> SessionHub::join(const std::string& key, const Config& config, std::string* note) {
  std::lock_guard<std::mutex> lock(registryMutex());
  Entry& e = registry()[key];
  if (auto hub = e.hub.lock()) {
    const std::string differ = differences(e.config, config);
    if (!differ.empty() && note)
      *note = "this nodelet's parameters differ from those the session of " + key + " was made with (" + differ +
              "); the session's are used";
    return hub;
  }
  std::shared_ptr<SessionHub> hub(new SessionHub(key, config));
  e.hub = hub;
  e.config = config;
  return hub;
}

SessionHub::MemberId SessionHub::addMember(Member member) {
  MemberId id;
  {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    id = next_id_++;
    if (member.feeds_images) {
      // Images are decoded once, by the image feeder: the cache keeps them
      // for the planar targets' alignment.
      session_->setKeepImages(true);
    }
    members_[id] = std::move(member);
    wants_[id] = false;
  }
  notifyDemand();
  return id;
}

void SessionHub::removeMember(MemberId id) {
  {
    std::unique_lock<std::recursive_mutex> lock(mutex_);
    members_.erase(id);  // no call of its callbacks starts after this
    wants_.erase(id);
    // Calls already started (notifyDemand() makes them outside the lock) are
    // waited for: once this returns, the member may be destroyed. Its own
    // calls that this thread is inside (it leaves from its callback) are not.
    const std::pair<const SessionHub*, MemberId> self(this, id);
    const auto own = std::count(t_running.begin(), t_running.end(), self);
    calls_done_.wait(lock, [&] {
      const auto it = calls_in_flight_.find(id);
      return it == calls_in_flight_.end() || it->second <= own;
    });
  }
  notifyDemand();
}

void SessionHub::setWantsFrames(MemberId id, bool wants) {
  {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    const auto it = wants_.find(id);
    if (it == wants_.end() || it->second == wants) return;
    const bool before = framesWanted();
    it->second = wants;
    if (framesWanted() == before) return;
  }
  notifyDemand();
}

bool SessionHub::framesWanted() const {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
  for (const auto& [id, w] : wants_)
    if (w) return true;
  return false;
}

bool SessionHub::hasImageFeeder() const {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
  for (const auto& [id, m] : members_)
    if (m.feeds_images) return true;
  return false;
}

SessionHub::MemberId SessionHub::motionFeeder() const {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
  for (const auto& [id, m] : members_)
    if (!m.feeds_images && m.wants_images) return id;
  for (const auto& [id, m] : members_)
    if (!m.feeds_images) return id;
  return -1;
}

void SessionHub::noteHeader(const std_msgs::Header& header, const ros::WallTime& received) {
  std::lock_guard<std::recursive_mutex> lock(mutex_);
  if (!arrivals_.empty() && !(header.stamp > arrivals_.back().header.stamp)) arrivals_.clear();  // time went back
  arrivals_.push_back({header, received});
  while (arrivals_.size() > kHeadersKept) arrivals_.pop_front();
  frame_id_ = header.frame_id;
}

SessionHub::Arrival SessionHub::arrivalOf(double stamp) const {
  for (auto it = arrivals_.rbegin(); it != arrivals_.rend(); ++it)
    if (it->header.stamp.toSec() == stamp) return *it;
  Arrival a;
  a.header.stamp.fromSec(stamp);
  a.header.frame_id = frame_id_;
  a.received = ros::WallTime::now();
  return a;
}

void SessionHub::dispatch() {
  for (const FrameResult& r : session_->takeResults()) {
    const Arrival a = arrivalOf(r.motion.stamp);
    for (auto& [id, m] : members_)
      if (m.on_result) m.on_result(r, a.header, a.received);
  }
}

void SessionHub::notifyDemand() {
  // The callbacks are called outside the lock (they re-check subscriptions,
  // which may ask the hub again or wait for ROS), each counted in flight from
  // here until it ends: removeMember() waits for those of its member.
  std::vector<std::pair<MemberId, std::function<void()>>> calls;
  {
    std::lock_guard<std::recursive_mutex> lock(mutex_);
    for (const auto& [id, m] : members_) {
      if (!m.on_demand_changed) continue;
      calls.emplace_back(id, m.on_demand_changed);
      ++calls_in_flight_[id];
    }
  }
  size_t next = 0;
  auto endCall = [this](MemberId id) {
    {
      std::lock_guard<std::recursive_mutex> lock(mutex_);
      if (--calls_in_flight_[id] == 0) calls_in_flight_.erase(id);
    }
    calls_done_.notify_all();
  };
  // Should a callback throw, the calls not made are ended too.
  const Finally end_rest{[&] {
    for (; next < calls.size(); ++next) endCall(calls[next].first);
  }};
  for (; next < calls.size(); ++next) {
    const MemberId id = calls[next].first;
    bool member;
    {
      std::lock_guard<std::recursive_mutex> lock(mutex_);
      member = members_.count(id) > 0;  // it may have left since the copy
    }
    if (member) {
      t_running.emplace_back(this, id);
      const Finally pop{[] { t_running.pop_back(); }};
      calls[next].second();
    }
    endCall(id);
  }
}

}  // namespace imt
