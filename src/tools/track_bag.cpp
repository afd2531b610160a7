// track_bag: runs the pipeline on a rosbag as fast as the machine allows and
// writes the results (docs: interface.md, "Offline tool: track_bag"). No
// roscore needed. This file parses the options and wires the pieces together:
// ros/bag_input (reading), ros/image_conversion (gray frames), core/pipeline
// (the same code the nodelets run), io/ (INIT.yaml, CSV, summary.json).
//
// On any bad input it exits non-zero with one line on stderr; warnings and
// notes of a successful run are printed once each, after the run.
#include "instant_motion_tracking/core/anchor_manager.h"
#include "instant_motion_tracking/core/pipeline.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/io/csv_writer.h"
#include "instant_motion_tracking/io/init_spec.h"
#include "instant_motion_tracking/io/summary.h"
#include "instant_motion_tracking/ros/bag_input.h"
#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/image_conversion.h"

#include <console_bridge/console.h>
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
                            (/motion_data, /regions, /planar_targets, /anchors, /tf)
  --start S, --end E        process only the part from S to E seconds after
                            the bag's first message (bag time, as rosbag play -s)
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

// Collects what the ROS libraries log through console_bridge (rosbag and
// roscpp's header parser print errors there before throwing), instead of
// letting it reach stderr: a failure is then still one line, carrying the
// library's words; on success they are printed as warnings, once each.
class LibraryLog : public console_bridge::OutputHandler {
 public:
  void log(const std::string& text, console_bridge::LogLevel level, const char*, int) override {
    if (level < console_bridge::CONSOLE_BRIDGE_LOG_WARN) return;
    std::string line;
    bool space = false;
    for (char c : text) {  // one line, runs of whitespace collapsed
      const bool ws = c == ' ' || c == '\n' || c == '\r' || c == '\t';
      if (ws) {
        space = !line.empty();
      } else {
        if (space) line += ' ';
        line += c;
        space = false;
      }
    }
    if (line.empty() || messages.size() >= 5) return;
    for (const std::string& m : messages)
      if (m == line) return;
    messages.push_back(line);
  }
  std::vector<std::string> messages;
};

LibraryLog& libraryLog() {
  static LibraryLog log;
  return log;
}

// Messages printed once each after a successful run.
struct Notes {
  std::vector<std::string> lines;
  void warn(const std::string& s) { lines.push_back("warning: " + s); }
  void note(const std::string& s) { lines.push_back("note: " + s); }
};

// One run of the tool: inputs, outputs, the frame loop and the summary. Every
// step fails through fail(); the frame callbacks return false with a message.
class TrackBagRun {
 public:
  explicit TrackBagRun(const Args& args) : args_(args) {}

  int run() {
    loadInputs();
    openOutputs();
    play();
    trackItems();
    finish();
    writeSummary();
    for (const std::string& line : notes_.lines) std::fprintf(stderr, "track_bag: %s\n", line.c_str());
    if (!args_.quiet && isatty(STDERR_FILENO))
      std::fprintf(stderr, "track_bag: %zu frames in %.2f s (%.1f frames/s); results in %s\n",
                   frames_, seconds_, seconds_ > 0 ? frames_ / seconds_ : 0.0, args_.out_dir.c_str());
    return 0;
  }

 private:
  struct ResetInfo {
    int count = 0;
    int first_frame = 0;
    double first_stamp = 0;
  };

  // Configuration, INIT.yaml (cheap to check, so first), the bag with every
  // frame's stamp, intrinsics and the IMU -> camera rotation.
  void loadInputs() {
    std::string err;
    config_path_ = args_.config.empty() ? defaultConfigPath() : args_.config;
    if (config_path_.empty())
      fail("cannot find config/default.yaml of package instant_motion_tracking (source the "
           "workspace's setup.bash, or pass --config FILE)");
    if (!imt::loadConfigFile(config_path_, &config_, &err)) fail(err);
    if (!args_.init.empty() && !imt::loadInitSpecFile(args_.init, &init_, &err)) fail(err);

    Stopwatch clock;
    imt::BagInputOptions opt;
    opt.image_topic = args_.image_topic;
    opt.camera_info_topic = args_.camera_info_topic;
    opt.imu_topic = args_.imu_topic;
    opt.start = args_.start;
    opt.end = args_.end;
    if (!input_.open(args_.bag, opt, &err)) fail(err);
    const bool windowed = args_.start > 0 || args_.end >= 0;
    if (!imt::resolveInitStamps(input_.frameStamps(), args_.init,
                                windowed ? "the part of the bag given by --start/--end" : "the bag",
                                &init_, &err))
      fail(err);

    // Intrinsics: the first valid camera_info, else the field-of-view default.
    sensor_msgs::CameraInfo info;
    std::string why;
    const bool have_info = input_.firstCameraInfo(
        [&](const sensor_msgs::CameraInfo& m, std::string* reason) {
          return imt::fromCameraInfo(m, &k_info_, reason, config_.pipeline.image_rectified);
        },
        &info, &why);
    if (!have_info) {
      k_info_ = imt::CameraModel();
      notes_.note(why + "; intrinsics from default_hfov_deg " + hfov() + " deg");
    }

    // IMU -> camera rotation from tf (or the anchors.rotation_cam_imu
    // parameter, which overrides it), kept for the IMU-aided trackers.
    if (!input_.imuTopic().empty()) {
      imu_frame_ = input_.imuFrameId();
      Eigen::Quaterniond q;
      if (config_.pipeline.anchors.rotationCamImu(&q) ||
          input_.lookupRotation(input_.imageFrameId(), imu_frame_, &q, &tf_why_))
        q_cam_imu_ = q;
    }
    stage_seconds_["open"] = clock.lap();
  }

  // Created before the long run, so that a bad --out-dir fails fast.
  void openOutputs() {
    std::string err;
    std::error_code ec;
    fs::create_directories(args_.out_dir, ec);
    if (!fs::is_directory(args_.out_dir))
      fail("cannot create --out-dir '" + args_.out_dir + "'" + (ec ? ": " + ec.message() : ""));
    const std::string dir = args_.out_dir + "/";
    if (!camera_csv_.open(dir + "camera_motion.csv", imt::cameraMotionColumns(), &err) ||
        !regions_csv_.open(dir + "regions.csv", imt::regionColumns(), &err) ||
        !targets_csv_.open(dir + "planar_targets.csv", imt::planarTargetColumns(), &err) ||
        !anchors_csv_.open(dir + "anchors.csv", imt::anchorColumns(), &err))
      fail(err);

    if (!args_.out_bag.empty()) {
      if (fs::equivalent(args_.out_bag, args_.bag, ec))
        fail("--out-bag '" + args_.out_bag + "' is the input bag");
      try {
        out_bag_ = std::make_unique<rosbag::Bag>(args_.out_bag, rosbag::bagmode::Write);
      } catch (const std::exception& e) {
        fail("cannot create --out-bag '" + args_.out_bag + "': " + e.what());
      }
    }
  }

  void play() {
    // The whole bag stays in the motion-data cache: items given at any frame
    // are then tracked backwards and forwards from it (trackItems()).
    pipeline_ = std::make_unique<imt::Pipeline>(config_.pipeline, /*keep_all_motion_data=*/true);
    // Frames for the planar targets' appearance alignment, only when there are
    // targets (within planar_tracking.image_memory_mb; the oldest go first).
    pipeline_->setKeepImages(!init_.planar_targets.empty());
    progress_ = std::make_unique<Progress>(input_.frameStamps().size(),
                                           !args_.quiet && isatty(STDERR_FILENO));
    imt::BagInput::Callbacks cb;
    cb.imu = [this](const sensor_msgs::Imu& m, const ros::Time&) { onImu(m); };
    cb.image = [this](const imt::BagImage& im, std::string* why) { return onImage(im, why); };
    Stopwatch clock;
    std::string err;
    if (!input_.play(cb, &err)) {
      progress_->finish();
      fail(err);
    }
    play_seconds_ = clock.lap();
    progress_->finish();
  }

  void onImu(const sensor_msgs::Imu& m) {
    Stopwatch clock;
    imt::ImuSample s;
    std::string reason;
    if (imt::fromImuMsg(m, &s, &reason)) {
      pipeline_->addImu(s);
      ++imu_used_;
    } else if (imu_dropped_++ == 0) {
      imu_first_dropped_ = m.header.stamp.toSec();
    }
    stage_seconds_["imu"] += clock.lap();
  }

  bool onImage(const imt::BagImage& im, std::string* why) {
    Stopwatch clock;
    const double stamp = im.header().stamp.toSec();
    const std::string where = "frame " + std::to_string(im.index) + " (stamp " + fixed(stamp, 6) +
                              ") on " + input_.imageTopic();
    cv::Mat gray;
    std::string reason, decoder_said;
    bool ok;
    if (im.raw) {
      ok = imt::imageToGray(*im.raw, &gray, &reason);
    } else {
      capture_.start();
      ok = imt::compressedImageToGray(*im.compressed, &gray, &reason);
      decoder_said = capture_.stop();
    }
    if (!ok) {
      *why = where + ": " + reason + (decoder_said.empty() ? "" : " [" + decoder_said + "]");
      return false;
    }
    if (!decoder_said.empty() && decoder_warnings_++ == 0)
      first_decoder_warning_ = where + ": " + decoder_said;
    stage_seconds_["decode"] += clock.lap();

    setIntrinsicsFor(gray.size(), im.index);
    const imt::FrameResult r = pipeline_->processFrame(gray, stamp);
    if (!pipeline_->lastReset().empty() && im.index > 0) {
      ResetInfo& ri = resets_[pipeline_->lastReset()];
      if (ri.count++ == 0) {
        ri.first_frame = im.index;
        ri.first_stamp = stamp;
      }
    }
    clock.lap();  // the pipeline times its own stages

    ++model_counts_[imt::motionModelName(r.motion.camera.model)];
    frames_out_.push_back({stamp, im.header(), std::max(im.bag_time, ros::TIME_MIN)});
    if (!camera_csv_.write(imt::cameraMotionRow(r.motion), why)) return false;
    if (out_bag_) {
      try {
        const ros::Time when = std::max(im.bag_time, ros::TIME_MIN);
        out_bag_->write("/motion_data", when, imt::toMsg(r.motion, im.header()));
      } catch (const std::exception& e) {
        *why = "cannot write --out-bag '" + args_.out_bag + "': " + e.what();
        return false;
      }
    }
    stage_seconds_["write"] += clock.lap();
    progress_->update(++frames_);
    return true;
  }

  // camera_info's intrinsics when the frame has its size, else the
  // field-of-view default for the frame's size (warned once). Set again only
  // when the frame size changes.
  void setIntrinsicsFor(const cv::Size& size, int index) {
    if (size == intrinsics_size_) return;
    intrinsics_size_ = size;
    if (k_info_.valid && k_info_.width == size.width && k_info_.height == size.height) {
      pipeline_->setIntrinsics(k_info_);
      intrinsics_source_ = "camera_info";
      return;
    }
    if (k_info_.valid && !size_warned_) {
      size_warned_ = true;
      notes_.warn("image size " + std::to_string(size.width) + "x" + std::to_string(size.height) +
                  " (first at frame " + std::to_string(index) + ") differs from " +
                  input_.cameraInfoTopic() + "'s " + std::to_string(k_info_.width) + "x" +
                  std::to_string(k_info_.height) + "; intrinsics from default_hfov_deg " + hfov() +
                  " deg for it");
    }
    pipeline_->setIntrinsics(imt::CameraModel::fromFieldOfView(
        size.width, size.height, config_.pipeline.default_hfov_deg));
    intrinsics_source_ = "field_of_view";
  }

  // The anchors over the pipeline's regions, with the bag's IMU stream
  // integrated over the whole run (offline: the window spans the bag, up to
  // an hour), rotated into the camera by /tf_static (or the parameter).
  std::unique_ptr<imt::AnchorManager> anchorManager() {
    const auto& samples = pipeline_->imuSamples();
    imt::ImuOptions o = config_.pipeline.imu;
    if (!samples.empty())
      o.window_seconds = std::min(3600.0, std::max(o.window_seconds, samples.back().stamp - samples.front().stamp + 1.0));
    auto anchors = std::make_unique<imt::AnchorManager>(config_.pipeline.anchors, o, config_.pipeline.default_hfov_deg,
                                                        &pipeline_->regions());
    anchors->setIntrinsics(k_info_);
    if (q_cam_imu_) anchors->setRotationCamImu(*q_cam_imu_);
    if (samples.size() < 2) return anchors;
    size_t dropped = 0, restarts = 0, gaps = 0;
    for (const imt::ImuSample& s : samples) {
      const imt::ImuInput r = anchors->addImu(s);
      dropped += r == imt::ImuInput::kDropped;
      restarts += r == imt::ImuInput::kReset;
      gaps += r == imt::ImuInput::kGap;
    }
    if (gaps)
      notes_.warn("the IMU stream has " + std::to_string(gaps) + " gap(s) longer than imu.max_gap_seconds " +
                  "(no anchor orientation inside them; roll and pitch re-levelled after each)");
    if (dropped) notes_.warn("the IMU orientation dropped " + std::to_string(dropped) + " sample(s) (NaN or out of order)");
    if (restarts)
      notes_.warn("the IMU orientation restarted " + std::to_string(restarts) + " time(s) (IMU time jumped back)");
    return anchors;
  }

  // Regions and planar targets of INIT.yaml, each given at its frame and
  // tracked over every frame of the run, backwards and forwards through the
  // motion-data cache; rows in frame order, then id order.
  void trackItems() {
    if (init_.regions.empty() && init_.planar_targets.empty() && init_.anchors.empty()) return;
    Stopwatch clock;
    std::string err;
    const imt::MotionCache& cache = pipeline_->cache();
    std::vector<uint32_t> region_ids, target_ids;
    for (const imt::RegionInit& r : init_.regions) {
      uint32_t id;
      const cv::Rect2d box(r.box[0], r.box[1], r.box[2], r.box[3]);
      if (!pipeline_->regions().add(r.id, r.stamp, box, &id, &err))
        fail(args_.init + ": regions (id " + std::to_string(r.id) + "): " + err);
      region_ids.push_back(id);
    }
    for (const imt::PlanarTargetInit& t : init_.planar_targets) {
      std::array<cv::Point2d, 4> corners;
      for (int i = 0; i < 4; ++i) corners[i] = cv::Point2d(t.corners[i][0], t.corners[i][1]);
      uint32_t id;
      if (!pipeline_->planarTargets().add(t.id, t.stamp, corners, t.size[0], t.size[1],
                                          pipeline_->intrinsics(), cache, &id, &err))
        fail(args_.init + ": planar_targets (id " + std::to_string(t.id) + "): " + err);
      target_ids.push_back(id);
    }
    // Anchors: a region around the tapped pixel + the IMU orientation.
    std::unique_ptr<imt::AnchorManager> anchors;
    std::vector<uint32_t> anchor_ids;
    if (!init_.anchors.empty()) anchors = anchorManager();
    for (const imt::AnchorInit& a : init_.anchors) {
      uint32_t id;
      if (!anchors->add(a.id, a.stamp, cv::Point2d(a.point[0], a.point[1]), a.depth, &id, &err))
        fail(args_.init + ": anchors (id " + std::to_string(a.id) + "): " + err);
      anchor_ids.push_back(id);
    }
    if (anchors && anchors->imu().empty())
      notes_.warn("no usable IMU in the bag: anchors are translation-only (status no_imu)");

    size_t missing = 0;
    for (const FrameOut& f : frames_out_) {
      uint64_t seq;
      if (!cache.find(f.stamp, &seq, &err) || std::abs(cache.at(seq).stamp - f.stamp) > 1e-9) {
        ++missing;  // dropped from the cache by a reset (time going backwards)
        continue;
      }
      std::vector<imt::RegionState> regions;
      if (!region_ids.empty() && !pipeline_->regions().seek(f.stamp, region_ids, &regions, &err)) fail(err);
      for (const imt::RegionState& r : regions)
        if (!regions_csv_.write(imt::regionRow(r), &err)) fail(err);
      std::vector<imt::PlanarTargetState> targets;
      for (uint32_t id : target_ids) {
        imt::PlanarTargetState st;
        if (!pipeline_->planarTargets().stateAt(id, seq, cache, &st, &err)) fail(err);
        if (!targets_csv_.write(imt::planarTargetRow(st), &err)) fail(err);
        targets.push_back(st);
      }
      std::vector<imt::AnchorState> anchor_states;
      if (!anchor_ids.empty() && !anchors->stateAt(f.stamp, anchor_ids, &anchor_states, &err)) fail(err);
      for (const imt::AnchorState& a : anchor_states)
        if (!anchors_csv_.write(imt::anchorRow(f.stamp, a.id, a.pixel, a.T_cam_anchor, imt::anchorStatusName(a.status),
                                               a.hasEstimate()),
                                &err))
          fail(err);
      if (out_bag_) {
        try {
          if (!region_ids.empty()) out_bag_->write("/regions", f.bag_time, imt::toMsg(regions, f.header));
          if (!target_ids.empty()) out_bag_->write("/planar_targets", f.bag_time, imt::toMsg(targets, f.header));
          if (!anchor_ids.empty()) out_bag_->write("/anchors", f.bag_time, imt::toMsg(anchor_states, f.header));
          // One /tf message per frame: planar_target_<id> and anchor_<id>.
          tf2_msgs::TFMessage tf;
          tf.transforms = imt::planarTargetTransforms(targets, f.header, config_.ros.frame_prefix);
          for (auto& t : imt::anchorTransforms(anchor_states, f.header, config_.ros.frame_prefix))
            tf.transforms.push_back(t);
          if (!tf.transforms.empty()) out_bag_->write("/tf", f.bag_time, tf);
        } catch (const std::exception& e) {
          fail("cannot write --out-bag '" + args_.out_bag + "': " + e.what());
        }
      }
    }
    if (missing)
      notes_.warn(std::to_string(missing) + " frame(s) before a reset have no region, planar-target or anchor rows "
                  "(the motion analysis restarted there)");
    stage_seconds_["track_items"] = clock.lap();
  }

  // Closes the outputs and turns the counts into warnings.
  void finish() {
    Stopwatch clock;
    std::string err;
    for (imt::CsvWriter* w : {&camera_csv_, &regions_csv_, &targets_csv_, &anchors_csv_})
      if (!w->close(&err)) fail(err);
    if (out_bag_) {
      try {
        out_bag_->close();
      } catch (const std::exception& e) {
        fail("cannot write --out-bag '" + args_.out_bag + "': " + e.what());
      }
    }
    stage_seconds_["write"] += clock.lap();

    for (const auto& [reason, ri] : resets_)
      notes_.warn("motion analysis reset " + std::to_string(ri.count) + " time(s): " + reason +
                  " (first at frame " + std::to_string(ri.first_frame) + ", stamp " +
                  fixed(ri.first_stamp, 6) + ")");
    if (decoder_warnings_)
      notes_.warn("the image decoder complained about " + std::to_string(decoder_warnings_) +
                  " compressed frame(s) (first: " + first_decoder_warning_ + ")");
    if (imu_dropped_)
      notes_.warn("dropped " + std::to_string(imu_dropped_) + " IMU sample(s) with NaN/Inf values "
                  "(first at stamp " + fixed(imu_first_dropped_, 6) + ")");
    if (!input_.imuTopic().empty() && !q_cam_imu_)
      notes_.note("IMU-to-camera rotation unknown: " + tf_why_);
    for (const std::string& m : libraryLog().messages) notes_.warn(m);
  }

  void writeSummary() {
    imt::RunSummary summary;
    summary.frames = static_cast<int>(frames_);
    std::map<std::string, double> stages = stage_seconds_;
    for (const auto& [name, s] : pipeline_->times().seconds) stages[name] += s;
    double accounted = 0;  // time of the play loop spent outside reading the bag
    for (const auto& [name, s] : stages)
      if (name != "open") accounted += s;
    stages["read"] = std::max(0.0, play_seconds_ - accounted);
    summary.stage_seconds = stages;
    summary.seconds = seconds_ = total_clock_.lap();

    auto orNull = [](const std::string& s) { return s.empty() ? nlohmann::json() : nlohmann::json(s); };
    nlohmann::json& d = summary.details;
    d["bag"] = args_.bag;
    d["config"] = config_path_;
    d["init"] = orNull(args_.init);
    d["image_topic"] = input_.imageTopic();
    d["image_compressed"] = input_.imageCompressed();
    d["camera_info_topic"] = orNull(input_.cameraInfoTopic());
    d["imu_topic"] = orNull(input_.imuTopic());
    d["window"] = {{"start", (input_.windowBegin() - input_.bagBegin()).toSec()},
                   {"end", (input_.windowEnd() - input_.bagBegin()).toSec()}};
    d["first_stamp"] = input_.frameStamps().front();
    d["last_stamp"] = input_.frameStamps().back();
    d["stamps_pass_seconds"] = input_.stampsPassSeconds();
    const imt::CameraModel& k = pipeline_->intrinsics();
    d["intrinsics"] = {{"source", intrinsics_source_}, {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx},
                       {"cy", k.cy}, {"width", k.width}, {"height", k.height}};
    d["imu_samples"] = imu_used_;
    d["imu_dropped"] = imu_dropped_;
    d["image_frame"] = input_.imageFrameId();
    d["imu_frame"] = orNull(imu_frame_);
    d["R_cam_imu"] = nullptr;
    if (q_cam_imu_) {
      const Eigen::Matrix3d R = q_cam_imu_->toRotationMatrix();
      d["R_cam_imu"] = {{R(0, 0), R(0, 1), R(0, 2)}, {R(1, 0), R(1, 1), R(1, 2)},
                        {R(2, 0), R(2, 1), R(2, 2)}};
    }
    d["models"] = model_counts_;
    nlohmann::json resets = nlohmann::json::object();
    for (const auto& [reason, ri] : resets_) resets[reason] = ri.count;
    d["resets"] = resets;
    d["init_entries"] = {{"regions", init_.regions.size()},
                         {"planar_targets", init_.planar_targets.size()},
                         {"anchors", init_.anchors.size()}};
    d["messages"] = notes_.lines;
    std::string err;
    if (!imt::writeJsonFile(args_.out_dir + "/summary.json", summary.toJson(), &err)) fail(err);
  }

  std::string hfov() const { return imt::formatShortest(config_.pipeline.default_hfov_deg); }

  const Args& args_;
  Stopwatch total_clock_;
  Notes notes_;
  // Inputs.
  std::string config_path_;
  imt::Config config_;
  imt::InitSpec init_;
  imt::BagInput input_;
  imt::CameraModel k_info_;  // from camera_info; valid = false without one
  std::string imu_frame_, tf_why_;
  std::optional<Eigen::Quaterniond> q_cam_imu_;
  // Outputs.
  imt::CsvWriter camera_csv_, regions_csv_, targets_csv_, anchors_csv_;
  struct FrameOut {
    double stamp;
    std_msgs::Header header;
    ros::Time bag_time;
  };
  std::vector<FrameOut> frames_out_;  // every processed frame, for trackItems()
  std::unique_ptr<rosbag::Bag> out_bag_;
  // The run.
  std::unique_ptr<imt::Pipeline> pipeline_;
  std::unique_ptr<Progress> progress_;
  StderrCapture capture_;
  cv::Size intrinsics_size_;
  std::string intrinsics_source_ = "none";
  bool size_warned_ = false;
  size_t frames_ = 0;
  std::map<std::string, double> stage_seconds_;
  std::map<std::string, int> model_counts_;
  std::map<std::string, ResetInfo> resets_;
  int imu_used_ = 0, imu_dropped_ = 0;
  double imu_first_dropped_ = 0;
  int decoder_warnings_ = 0;
  std::string first_decoder_warning_;
  double play_seconds_ = 0, seconds_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  console_bridge::useOutputHandler(&libraryLog());
  auto error = [](const std::string& message) {
    std::string line = message;
    if (!libraryLog().messages.empty()) line += " [" + libraryLog().messages.front() + "]";
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
    return TrackBagRun(args).run();
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
