// Helpers shared by the rostest nodes: wall-time polling (the graph may run
// on sim time) and playing a bag's images into the graph as a child process.
#pragma once

#include <ros/ros.h>

#include <csignal>
#include <string>
#include <vector>
#include <sys/wait.h>
#include <unistd.h>

namespace imt {
namespace test {

// Spins until `done()` or `timeout_s` of wall time; returns done().
template <class F>
bool spinUntil(F done, double timeout_s) {
  const ros::WallTime end = ros::WallTime::now() + ros::WallDuration(timeout_s);
  while (ros::ok() && ros::WallTime::now() < end) {
    ros::spinOnce();
    if (done()) return true;
    ros::WallDuration(0.01).sleep();
  }
  return done();
}

// Starts rosbag play of /camera/image_raw of `bag`, once something subscribes
// to it. Returns the child's pid (<= 0 on failure); stop it with stopPlayer().
inline pid_t playImages(const std::string& bag) {
  const pid_t player = fork();
  if (player == 0) {
    execl("/usr/lib/rosbag/play", "play", "--quiet", "--wait-for-subscribers", "--topics", "/camera/image_raw",
          "--bags", bag.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  return player;
}

// The same for several topics of `bag` (rosbag play waits for a subscriber
// on each of them).
inline pid_t playTopics(const std::string& bag, const std::vector<std::string>& topics) {
  std::vector<std::string> args = {"play", "--quiet", "--wait-for-subscribers", "--topics"};
  args.insert(args.end(), topics.begin(), topics.end());
  args.insert(args.end(), {"--bags", bag});
  const pid_t player = fork();
  if (player == 0) {
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    execv("/usr/lib/rosbag/play", argv.data());
    _exit(127);
  }
  return player;
}

inline void stopPlayer(pid_t player) {
  kill(player, SIGINT);
  waitpid(player, nullptr, 0);
}

}  // namespace test
}  // namespace imt
