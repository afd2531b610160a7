// track_bag's command line: the usage text, the options, their parsing and
// the package's default config file. Private to src/tools/track_bag.cpp.
// Every problem is thrown as a Failure (main prints its one line).
#pragma once

#include <ros/package.h>

#include <fcntl.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <string>

namespace imt::track_bag {

namespace fs = std::filesystem;

inline const char* kUsage = R"(usage: track_bag --bag IN.bag --out-dir DIR [options]

Runs the instant_motion_tracking pipeline on a rosbag (no roscore needed) and
writes camera_motion.csv, regions.csv, planar_targets.csv, anchors.csv and
summary.json to DIR.

options:
  --bag FILE                input rosbag (required)
  --init FILE               INIT.yaml: regions, planar targets, anchors to track
                            (without it only camera motion is written)
  --out-dir DIR             output directory, created if missing (required);
                            the CSV files in it are overwritten
  --image-topic T           default: the only sensor_msgs/Image or
                            sensor_msgs/CompressedImage topic
  --camera-info-topic T     default: the image topic's sibling camera_info, if
                            present (else intrinsics from default_hfov_deg)
  --imu-topic T             default: the only sensor_msgs/Imu topic, if any
  --config FILE             parameter file (default: config/default.yaml of the
                            package, the file the nodelets load)
  --out-bag FILE            also write every output message to this bag
                            (/motion_data, /regions, /planar_targets, /anchors, /tf)
  --start S, --end E        process only the part from S to E seconds after
                            the bag's first message (bag time, as rosbag play -s)
  --quiet                   no progress bar
  --print-default-config    print every parameter with its default and what it
                            does (config/default.yaml is this output) and exit
  -h, --help                this text

exit status: 0 success, 1 bad input (named in one line on stderr), 2 bad options.
A malformed frame or a refused camera_info in a usable bag is dropped, as live:
the run goes on, one warning per cause after it, counted in summary.json.
)";

struct Args {
  std::string bag, init, out_dir, image_topic, camera_info_topic, imu_topic, config, out_bag;
  double start = 0, end = -1;
  bool quiet = false, help = false, print_config = false;
};

// Thrown for any problem the user must fix; main prints it as one line.
struct Failure {
  std::string message;
  int status = 1;
};

[[noreturn]] inline void fail(const std::string& message, int status = 1) { throw Failure{message, status}; }

inline double parseSeconds(const std::string& option, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v) || v < 0)
    fail(option + ": expected a non-negative number of seconds, got '" + text + "'", 2);
  return v;
}

inline Args parseArgs(int argc, char** argv) {
  Args a;
  const std::map<std::string, std::string*> valued = {
      {"--bag", &a.bag},
      {"--init", &a.init},
      {"--out-dir", &a.out_dir},
      {"--image-topic", &a.image_topic},
      {"--camera-info-topic", &a.camera_info_topic},
      {"--imu-topic", &a.imu_topic},
      {"--config", &a.config},
      {"--out-bag", &a.out_bag}};
  std::string start, end;
  std::map<std::string, bool> seen;
  for (int i = 1; i < argc; ++i) {
    std::string opt = argv[i], value;
    bool has_inline_value = false;
    const auto eq = opt.find('=');
    if (opt.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = opt.substr(eq + 1);
      opt = opt.substr(0, eq);
      has_inline_value = true;
    }
    if (opt == "-h" || opt == "--help") {
      a.help = true;
      continue;
    }
    if (opt == "--print-default-config") {
      if (has_inline_value) fail("--print-default-config takes no value", 2);
      a.print_config = true;
      continue;
    }
    if (opt == "--quiet") {
      if (has_inline_value) fail("--quiet takes no value", 2);
      a.quiet = true;
      continue;
    }
    const bool is_time = opt == "--start" || opt == "--end";
    const auto it = valued.find(opt);
    if (it == valued.end() && !is_time) {
      if (opt.rfind("-", 0) == 0) fail("unknown option '" + opt + "' (see --help)", 2);
      fail("unexpected argument '" + opt + "' (options take the form --name VALUE; see --help)", 2);
    }
    if (seen[opt]) fail("option " + opt + " given twice", 2);
    seen[opt] = true;
    if (!has_inline_value) {
      if (i + 1 >= argc) fail("option " + opt + " needs a value", 2);
      value = argv[++i];
    }
    if (value.empty()) fail("option " + opt + " needs a value", 2);
    if (opt == "--start")
      start = value;
    else if (opt == "--end")
      end = value;
    else
      *it->second = value;
  }
  if (a.help || a.print_config) return a;
  if (a.bag.empty()) fail("missing --bag (see --help)", 2);
  if (a.out_dir.empty()) fail("missing --out-dir (see --help)", 2);
  if (!start.empty()) a.start = parseSeconds("--start", start);
  if (!end.empty()) a.end = parseSeconds("--end", end);
  if (!end.empty() && a.end <= a.start)
    fail("--end " + end + " must be after --start " + (start.empty() ? "0" : start), 2);
  return a;
}

// config/default.yaml of the package: found through ROS_PACKAGE_PATH (devel
// or installed), else next to an installed executable. "" when not found.
inline std::string defaultConfigPath() {
  // rospack prints two lines on stderr when the package is unknown; this tool
  // promises one line on failure, so they are silenced for this call.
  std::string dir;
  {
    std::fflush(stderr);
    const int saved = dup(STDERR_FILENO);
    const int null_fd = ::open("/dev/null", O_WRONLY);
    if (saved >= 0 && null_fd >= 0) dup2(null_fd, STDERR_FILENO);
    dir = ros::package::getPath("instant_motion_tracking");
    std::fflush(stderr);
    if (saved >= 0) {
      dup2(saved, STDERR_FILENO);
      ::close(saved);
    }
    if (null_fd >= 0) ::close(null_fd);
  }
  std::error_code ec;
  if (!dir.empty() && fs::is_regular_file(dir + "/config/default.yaml", ec))
    return dir + "/config/default.yaml";
  // <prefix>/lib/instant_motion_tracking/track_bag -> <prefix>/share/instant_motion_tracking/
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path p = exe.parent_path().parent_path().parent_path() / "share" /
                       "instant_motion_tracking" / "config" / "default.yaml";
    if (fs::is_regular_file(p, ec)) return p.string();
  }
  return "";
}

}  // namespace imt::track_bag
