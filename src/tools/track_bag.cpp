// track_bag: runs the pipeline on a rosbag as fast as the machine allows and
// writes the results (docs: interface.md, "Offline tool: track_bag"). No
// roscore needed. This file parses the options and wires the pieces together:
// ros/bag_input (reading), ros/image_conversion (gray frames), core/pipeline
// (the same code the nodelets run), io/ (INIT.yaml, CSV, summary.json).
//
// On any bad input it exits non-zero with one line on stderr; warnings and
// notes of a successful run are printed once each, after the run.
#include "instant_motion_tracking/core/pipeline.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/io/csv_writer.h"
#include "instant_motion_tracking/io/init_spec.h"
#include "instant_motion_tracking/io/summary.h"
#include "instant_motion_tracking/ros/bag_input.h"
#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/image_conversion.h"

#include <ros/package.h>
#include <rosbag/bag.h>

#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const char* kUsage = R"(usage: track_bag --bag IN.bag --out-dir DIR [options]

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
                            (/motion_data, ...)
  --start S, --end S        process only the part from S to E seconds after
                            the bag's first message (as rosbag play -s / -u)
  --quiet                   no progress bar
  -h, --help                this text

exit status: 0 success, 1 bad input (named in one line on stderr), 2 bad options
)";

struct Args {
  std::string bag, init, out_dir, image_topic, camera_info_topic, imu_topic, config, out_bag;
  double start = 0, end = -1;
  bool quiet = false, help = false;
};

// Thrown for any problem the user must fix; main prints it as one line.
struct Failure {
  std::string message;
  int status = 1;
};

[[noreturn]] void fail(const std::string& message, int status = 1) { throw Failure{message, status}; }

double parseSeconds(const std::string& option, const std::string& text) {
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !std::isfinite(v) || v < 0)
    fail(option + ": expected a non-negative number of seconds, got '" + text + "'", 2);
  return v;
}

Args parseArgs(int argc, char** argv) {
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
  if (a.help) return a;
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
std::string defaultConfigPath() {
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

std::string fixed(double v, int decimals) { return imt::formatFixed(v, decimals); }

// A one-line progress bar on stderr, when it is a terminal.
class Progress {
 public:
  Progress(size_t total, bool enabled) : total_(total), enabled_(enabled) {}
  void update(size_t done) {
    if (!enabled_) return;
    const auto now = Clock::now();
    if (done < total_ && now - last_ < std::chrono::milliseconds(100)) return;
    last_ = now;
    const double elapsed = std::chrono::duration<double>(now - start_).count();
    const int width = 30;
    const int filled = total_ ? static_cast<int>(width * done / total_) : width;
    std::string bar(filled, '#');
    bar.resize(width, '-');
    std::fprintf(stderr, "\r[%s] %3d%% %zu/%zu frames %.1f fps", bar.c_str(),
                 total_ ? static_cast<int>(100 * done / total_) : 100, done, total_,
                 elapsed > 0 ? done / elapsed : 0.0);
    std::fflush(stderr);
    shown_ = true;
  }
  // Ends the bar's line (before any other output on stderr).
  void finish() {
    if (shown_) std::fputs("\r\033[K", stderr);
    shown_ = false;
  }

 private:
  using Clock = std::chrono::steady_clock;
  size_t total_;
  bool enabled_;
  bool shown_ = false;
  Clock::time_point start_ = Clock::now(), last_ = Clock::time_point();
};

class Stopwatch {
 public:
  double lap() {
    const auto now = std::chrono::steady_clock::now();
    const double s = std::chrono::duration<double>(now - t_).count();
    t_ = now;
    return s;
  }

 private:
  std::chrono::steady_clock::time_point t_ = std::chrono::steady_clock::now();
};

// Captures what libraries write to stderr (libpng and libjpeg print their
// warnings and errors there) around a call, so that this tool keeps its
// promise of one error line, and reports the text itself. Single-threaded.
class StderrCapture {
 public:
  StderrCapture() {
    file_ = std::tmpfile();
    saved_ = dup(STDERR_FILENO);
  }
  ~StderrCapture() {
    if (file_) std::fclose(file_);
    if (saved_ >= 0) ::close(saved_);
  }
  void start() {
    if (!file_ || saved_ < 0) return;
    std::fflush(stderr);
    dup2(fileno(file_), STDERR_FILENO);
  }
  // Restores stderr; returns what was written meanwhile, on one line.
  std::string stop() {
    if (!file_ || saved_ < 0) return "";
    std::fflush(stderr);
    dup2(saved_, STDERR_FILENO);
    const int fd = fileno(file_);
    std::string text;
    char buf[512];
    lseek(fd, 0, SEEK_SET);
    ssize_t n;
    while (text.size() < 4096 && (n = ::read(fd, buf, sizeof(buf))) > 0) text.append(buf, n);
    if (ftruncate(fd, 0) != 0) {
    }
    lseek(fd, 0, SEEK_SET);
    while (!text.empty() && (text.back() == '\n' || text.back() == ' ')) text.pop_back();
    for (char& c : text)
      if (c == '\n' || c == '\r') c = ';';
    return text;
  }

 private:
  std::FILE* file_ = nullptr;
  int saved_ = -1;
};

// Messages printed once each after a successful run.
struct Notes {
  std::vector<std::string> lines;
  void warn(const std::string& s) { lines.push_back("warning: " + s); }
  void note(const std::string& s) { lines.push_back("note: " + s); }
};

int run(const Args& args) {
  Stopwatch total_clock;
  Notes notes;

  // Configuration and INIT.yaml first: they are cheap to check.
  std::string err;
  const std::string config_path = args.config.empty() ? defaultConfigPath() : args.config;
  if (config_path.empty())
    fail("cannot find config/default.yaml of package instant_motion_tracking (source the "
         "workspace's setup.bash, or pass --config FILE)");
  imt::Config config;
  if (!imt::loadConfigFile(config_path, &config, &err)) fail(err);
  imt::InitSpec init;
  if (!args.init.empty() && !imt::loadInitSpecFile(args.init, &init, &err)) fail(err);

  // The bag: topics and every frame's stamp.
  Stopwatch stage;
  imt::BagInputOptions in_opt;
  in_opt.image_topic = args.image_topic;
  in_opt.camera_info_topic = args.camera_info_topic;
  in_opt.imu_topic = args.imu_topic;
  in_opt.start = args.start;
  in_opt.end = args.end;
  imt::BagInput input;
  if (!input.open(args.bag, in_opt, &err)) fail(err);
  const std::vector<double>& frame_stamps = input.frameStamps();
  const bool windowed = args.start > 0 || args.end >= 0;
  if (!imt::resolveInitStamps(frame_stamps, args.init,
                              windowed ? "the part of the bag given by --start/--end" : "the bag",
                              &init, &err))
    fail(err);

  // Intrinsics: the first valid camera_info, else the field-of-view default.
  sensor_msgs::CameraInfo info_msg;
  imt::CameraIntrinsics k_info;
  std::string why;
  if (input.firstCameraInfo(
          [&](const sensor_msgs::CameraInfo& m, std::string* reason) {
            return imt::fromCameraInfo(m, &k_info, reason);
          },
          &info_msg, &why)) {
  } else {
    k_info = imt::CameraIntrinsics();
    notes.note(why + "; intrinsics from default_hfov_deg " +
               imt::formatShortest(config.pipeline.default_hfov_deg) + " deg");
  }

  // IMU -> camera rotation from tf, kept for the IMU-aided trackers.
  std::optional<Eigen::Quaterniond> q_cam_imu;
  std::string imu_frame, tf_why;
  if (!input.imuTopic().empty()) {
    imu_frame = input.imuFrameId();
    Eigen::Quaterniond q;
    if (input.lookupRotation(input.imageFrameId(), imu_frame, &q, &tf_why)) q_cam_imu = q;
  }
  const double open_seconds = stage.lap();

  // Outputs: created before the long run so that a bad --out-dir fails fast.
  std::error_code ec;
  fs::create_directories(args.out_dir, ec);
  if (!fs::is_directory(args.out_dir))
    fail("cannot create --out-dir '" + args.out_dir + "'" + (ec ? ": " + ec.message() : ""));
  const std::string dir = args.out_dir + "/";
  imt::CsvWriter camera_csv, regions_csv, targets_csv, anchors_csv;
  if (!camera_csv.open(dir + "camera_motion.csv", imt::cameraMotionColumns(), &err) ||
      !regions_csv.open(dir + "regions.csv", imt::regionColumns(), &err) ||
      !targets_csv.open(dir + "planar_targets.csv", imt::planarTargetColumns(), &err) ||
      !anchors_csv.open(dir + "anchors.csv", imt::anchorColumns(), &err))
    fail(err);
  // Trackers of later versions: their files hold the header only, said once.
  if (!init.regions.empty())
    notes.note("region tracking is not implemented in this version; regions.csv holds its header only");
  if (!init.planar_targets.empty())
    notes.note("planar target tracking is not implemented in this version; planar_targets.csv "
               "holds its header only");
  if (!init.anchors.empty())
    notes.note("anchor tracking is not implemented in this version; anchors.csv holds its header only");

  std::unique_ptr<rosbag::Bag> out_bag;
  if (!args.out_bag.empty()) {
    try {
      out_bag = std::make_unique<rosbag::Bag>(args.out_bag, rosbag::bagmode::Write);
    } catch (const std::exception& e) {
      fail("cannot create --out-bag '" + args.out_bag + "': " + e.what());
    }
  }

  // The run.
  imt::Pipeline pipeline(config.pipeline);
  const imt::PipelineOptions& popt = config.pipeline;
  std::string intrinsics_source = "none";
  cv::Size intrinsics_size;
  bool size_warned = false;
  std::map<std::string, double> stage_seconds;
  std::map<std::string, int> model_counts;
  struct ResetInfo {
    int count = 0;
    int first_frame = 0;
    double first_stamp = 0;
  };
  std::map<std::string, ResetInfo> resets;
  int imu_used = 0, imu_dropped = 0;
  double imu_first_dropped = 0;
  size_t frames = 0;
  StderrCapture capture;
  int decoder_warnings = 0;
  std::string first_decoder_warning;
  Progress progress(frame_stamps.size(), !args.quiet && isatty(STDERR_FILENO));

  imt::BagInput::Callbacks cb;
  cb.imu = [&](const sensor_msgs::Imu& m, const ros::Time&) {
    Stopwatch t;
    imt::ImuSample s;
    std::string reason;
    if (imt::fromImuMsg(m, &s, &reason)) {
      pipeline.addImu(s);
      ++imu_used;
    } else if (imu_dropped++ == 0) {
      imu_first_dropped = m.header.stamp.toSec();
    }
    stage_seconds["imu"] += t.lap();
  };
  cb.image = [&](const imt::BagImage& im, std::string* why) {
    Stopwatch t;
    const double stamp = im.header().stamp.toSec();
    cv::Mat gray;
    std::string reason, decoder_said;
    bool ok;
    if (im.raw) {
      ok = imt::imageToGray(*im.raw, &gray, &reason);
    } else {
      capture.start();
      ok = imt::compressedImageToGray(*im.compressed, &gray, &reason);
      decoder_said = capture.stop();
    }
    const std::string where =
        "frame " + std::to_string(im.index) + " (stamp " + fixed(stamp, 6) + ") on " + input.imageTopic();
    if (!ok) {
      *why = where + ": " + reason + (decoder_said.empty() ? "" : " [" + decoder_said + "]");
      return false;
    }
    if (!decoder_said.empty() && decoder_warnings++ == 0) first_decoder_warning = where + ": " + decoder_said;
    stage_seconds["decode"] += t.lap();

    // Intrinsics for this frame's size (set again only when the size changes).
    if (gray.size() != intrinsics_size) {
      intrinsics_size = gray.size();
      if (k_info.valid && k_info.width == gray.cols && k_info.height == gray.rows) {
        pipeline.setIntrinsics(k_info);
        intrinsics_source = "camera_info";
      } else {
        if (k_info.valid && !size_warned) {
          size_warned = true;
          notes.warn("image size " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                     " (first at frame " + std::to_string(im.index) + ") differs from " +
                     input.cameraInfoTopic() + "'s " + std::to_string(k_info.width) + "x" +
                     std::to_string(k_info.height) + "; intrinsics from default_hfov_deg " +
                     imt::formatShortest(popt.default_hfov_deg) + " deg for it");
        }
        pipeline.setIntrinsics(
            imt::CameraIntrinsics::fromFieldOfView(gray.cols, gray.rows, popt.default_hfov_deg));
        if (intrinsics_source != "camera_info") intrinsics_source = "field_of_view";
      }
    }

    const imt::FrameResult r = pipeline.processFrame(gray, stamp);
    if (!pipeline.lastReset().empty() && im.index > 0) {
      ResetInfo& ri = resets[pipeline.lastReset()];
      if (ri.count++ == 0) {
        ri.first_frame = im.index;
        ri.first_stamp = stamp;
      }
    }
    t.lap();  // pipeline stages are timed by the pipeline itself

    ++model_counts[imt::motionModelName(r.motion.camera.model)];
    if (!camera_csv.write(imt::cameraMotionRow(r.motion), why)) return false;
    if (out_bag) {
      try {
        const ros::Time when = std::max(im.bag_time, ros::TIME_MIN);
        out_bag->write("/motion_data", when, imt::toMsg(r.motion, im.header()));
      } catch (const std::exception& e) {
        *why = "cannot write --out-bag '" + args.out_bag + "': " + e.what();
        return false;
      }
    }
    stage_seconds["write"] += t.lap();
    progress.update(++frames);
    return true;
  };
  Stopwatch play_clock;
  if (!input.play(cb, &err)) {
    progress.finish();
    fail(err);
  }
  const double play_seconds = play_clock.lap();
  progress.update(frames);
  progress.finish();

  // Close and summarise.
  Stopwatch close_clock;
  for (imt::CsvWriter* w : {&camera_csv, &regions_csv, &targets_csv, &anchors_csv})
    if (!w->close(&err)) fail(err);
  if (out_bag) {
    try {
      out_bag->close();
    } catch (const std::exception& e) {
      fail("cannot write --out-bag '" + args.out_bag + "': " + e.what());
    }
  }
  stage_seconds["write"] += close_clock.lap();

  for (const auto& [reason, ri] : resets)
    notes.warn("motion analysis reset " + std::to_string(ri.count) + " time(s): " + reason +
               " (first at frame " + std::to_string(ri.first_frame) + ", stamp " +
               fixed(ri.first_stamp, 6) + ")");
  if (decoder_warnings)
    notes.warn("the image decoder complained about " + std::to_string(decoder_warnings) +
               " compressed frame(s) (first: " + first_decoder_warning + ")");
  if (imu_dropped)
    notes.warn("dropped " + std::to_string(imu_dropped) + " IMU sample(s) with NaN/Inf values "
               "(first at stamp " + fixed(imu_first_dropped, 6) + ")");
  if (!input.imuTopic().empty() && !q_cam_imu)
    notes.note("IMU-to-camera rotation unknown: " + tf_why);

  imt::RunSummary summary;
  summary.frames = static_cast<int>(frames);
  for (const auto& [name, s] : pipeline.times().seconds) stage_seconds[name] += s;
  double callbacks = 0;
  for (const auto& [name, s] : stage_seconds) callbacks += s;
  stage_seconds["read"] = std::max(0.0, play_seconds - callbacks);
  stage_seconds["open"] = open_seconds;
  summary.stage_seconds = stage_seconds;
  summary.seconds = total_clock.lap();

  nlohmann::json& d = summary.details;
  d["bag"] = args.bag;
  d["config"] = config_path;
  d["init"] = args.init.empty() ? nlohmann::json() : nlohmann::json(args.init);
  d["image_topic"] = input.imageTopic();
  d["image_compressed"] = input.imageCompressed();
  d["camera_info_topic"] =
      input.cameraInfoTopic().empty() ? nlohmann::json() : nlohmann::json(input.cameraInfoTopic());
  d["imu_topic"] = input.imuTopic().empty() ? nlohmann::json() : nlohmann::json(input.imuTopic());
  d["window"] = {{"start", (input.windowBegin() - input.bagBegin()).toSec()},
                 {"end", (input.windowEnd() - input.bagBegin()).toSec()}};
  d["first_stamp"] = frame_stamps.front();
  d["last_stamp"] = frame_stamps.back();
  d["stamps_pass_seconds"] = input.stampsPassSeconds();
  const imt::CameraIntrinsics& k = pipeline.intrinsics();
  d["intrinsics"] = {{"source", intrinsics_source}, {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx},
                     {"cy", k.cy}, {"width", k.width}, {"height", k.height}};
  d["imu_samples"] = imu_used;
  d["imu_dropped"] = imu_dropped;
  d["image_frame"] = input.imageFrameId();
  d["imu_frame"] = imu_frame.empty() ? nlohmann::json() : nlohmann::json(imu_frame);
  if (q_cam_imu) {
    const Eigen::Matrix3d R = q_cam_imu->toRotationMatrix();
    d["R_cam_imu"] = {{R(0, 0), R(0, 1), R(0, 2)}, {R(1, 0), R(1, 1), R(1, 2)},
                      {R(2, 0), R(2, 1), R(2, 2)}};
  } else {
    d["R_cam_imu"] = nullptr;
  }
  d["models"] = model_counts;
  nlohmann::json reset_counts = nlohmann::json::object();
  for (const auto& [reason, ri] : resets) reset_counts[reason] = ri.count;
  d["resets"] = reset_counts;
  d["init_entries"] = {{"regions", init.regions.size()},
                       {"planar_targets", init.planar_targets.size()},
                       {"anchors", init.anchors.size()}};
  d["messages"] = notes.lines;
  if (!imt::writeJsonFile(dir + "summary.json", summary.toJson(), &err)) fail(err);

  for (const std::string& line : notes.lines) std::fprintf(stderr, "track_bag: %s\n", line.c_str());
  if (!args.quiet && isatty(STDERR_FILENO))
    std::fprintf(stderr, "track_bag: %zu frames in %.2f s (%.1f frames/s); results in %s\n", frames,
                 summary.seconds, summary.seconds > 0 ? frames / summary.seconds : 0.0,
                 args.out_dir.c_str());
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  auto error = [](const std::string& message) {
    std::string line = message;
    for (char& c : line)
      if (c == '\n' || c == '\r') c = ' ';
    std::fprintf(stderr, "track_bag: error: %s\n", line.c_str());
  };
  try {
    const Args args = parseArgs(argc, argv);
    if (args.help) {
      std::fputs(kUsage, stdout);
      return 0;
    }
    return run(args);
  } catch (const Failure& f) {
    error(f.message);
    return f.status;
  } catch (const std::exception& e) {
    error(std::string("internal error: ") + e.what());
  } catch (...) {
    error("internal error");
  }
  return 1;
}
