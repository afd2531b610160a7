// track_bag: runs the pipeline on a rosbag as fast as the machine allows and
// writes the results (docs: interface.md, "Offline tool: track_bag"). No
// roscore needed. This file parses the options and wires the pieces together:
// ros/bag_input (reading), ros/image_conversion (gray frames), core/pipeline
// (the same code the nodelets run), io/ (INIT.yaml, CSV, summary.json), and
// track_bag_ledger.h (what the run dropped or refused, for the notes).
//
// On any bad input it exits non-zero with one line on stderr; warnings and
// notes of a successful run are printed once each, after the run. Bad
// messages inside a usable bag are what the live graph drops: a malformed
// image, a refused camera_info (counted in summary.json, one warning per
// cause with its count); a bag with no usable image at all is an error.
#include "instant_motion_tracking/core/tracking_session.h"
#include "instant_motion_tracking/io/config.h"
#include "instant_motion_tracking/io/csv_writer.h"
#include "instant_motion_tracking/io/init_spec.h"
#include "instant_motion_tracking/io/summary.h"
#include "instant_motion_tracking/ros/bag_input.h"
#include "instant_motion_tracking/ros/conversions.h"
#include "instant_motion_tracking/ros/image_conversion.h"
#include "track_bag_args.h"
#include "track_bag_ledger.h"
#include "track_bag_util.h"

#include <console_bridge/console.h>
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
using imt::track_bag::Args;
using imt::track_bag::defaultConfigPath;
using imt::track_bag::fail;
using imt::track_bag::Failure;
using imt::track_bag::kUsage;
using imt::track_bag::libraryLog;
using imt::track_bag::Notes;
using imt::track_bag::parseArgs;
using imt::track_bag::Progress;
using imt::track_bag::RunLedger;
using imt::track_bag::StderrCapture;
using imt::track_bag::Stopwatch;

namespace {

// One run of the tool: inputs, outputs, the frame loop and the summary. Every
// step fails through fail(); the frame callbacks return false with a message.
// The tracking itself is the session's (core/tracking_session.h), as live.
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
  struct FrameOut {
    double stamp;
    std_msgs::Header header;
    ros::Time bag_time;
  };

  // Configuration, INIT.yaml (cheap to check, so first), the bag with every
  // frame's stamp, then the session with the camera_info and the IMU -> camera rotation.
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

    // The whole bag stays in the session's motion-data cache: items given at
    // any frame are then tracked backwards and forwards from it (trackItems()).
    session_ = std::make_unique<imt::TrackingSession>(config_.pipeline, imt::TrackingSession::Mode::kOffline);

    // The first valid camera_info, else the field-of-view default.
    sensor_msgs::CameraInfo info;
    std::string why;
    const bool have_info = input_.firstCameraInfo(
        [&](const sensor_msgs::CameraInfo& m, std::string* reason) {
          return imt::fromCameraInfo(m, &k_info_, reason, config_.pipeline.image_rectified);
        },
        &info, &why);
    if (have_info)
      session_->setCameraInfo(k_info_);
    else
      notes_.note(why + "; intrinsics from default_hfov_deg " + hfov() + " deg");

    // IMU -> camera rotation from tf (the anchors.rotation_cam_imu parameter overrides it).
    if (!input_.imuTopic().empty()) {
      imu_frame_ = input_.imuFrameId();
      Eigen::Quaterniond q;
      if (!session_->rotationFromOptions() &&
          input_.lookupRotation(input_.imageFrameId(), imu_frame_, &q, &tf_why_))
        session_->setRotationCamImu(q);
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
    // Frames for the trackers that read them: the planar targets' appearance
    // alignment (kept only when there are targets), and the regions' look
    // and own corners (anchors rest on regions). Kept within
    // planar_tracking.image_memory_mb, and read again from the bag for the
    // frames beyond it, as live has every frame: without them a region
    // would be tracked on motion data alone through the frames whose images
    // were dropped (the oldest, on a bag longer than the budget).
    const bool targets = !init_.planar_targets.empty() || !init_.image_targets.empty();
    const bool regions = (!init_.regions.empty() || !init_.anchors.empty()) &&
                         config_.pipeline.region_tracking.usesImages();
    if (targets) session_->setKeepImages(true);
    if (targets || regions) {
      for (size_t i = 0; i < input_.frameStamps().size(); ++i) frame_index_[input_.frameStamps()[i]] = int(i);
      session_->setImageSource([this](double stamp) { return rereadFrame(stamp); });
    }
    progress_ = std::make_unique<Progress>(input_.frameStamps().size(),
                                           !args_.quiet && isatty(STDERR_FILENO));
    imt::BagInput::Callbacks cb;
    cb.imu = [this](const sensor_msgs::Imu& m, const ros::Time&) { onImu(m); };
    cb.camera_info = [this](const sensor_msgs::CameraInfo& m) { onCameraInfo(m); };
    cb.image = [this](const imt::BagImage& im, std::string* why) { return onImage(im, why); };
    Stopwatch clock;
    std::string err;
    if (!input_.play(cb, &err)) {
      progress_->finish();
      fail(err);
    }
    session_->advance(/*all=*/true);
    play_seconds_ = clock.lap();
    progress_->finish();
    if (frames_ == 0) {
      // Every frame malformed (frames dropped by the time rules follow a
      // frame that was not): nothing to track.
      const imt::track_bag::DropInfo& first = ledger_.firstMalformed();
      fail("no usable image on " + input_.imageTopic() + ": all " + std::to_string(ledger_.malformedCount()) +
           " frame(s) are malformed (first: " + first.first_where + ": " + first.first_reason + ")");
    }
  }

  // Each camera_info as it comes, checked as live (the same function): an
  // accepted one becomes the session's camera model (the first valid one is
  // already, from before the first frame); a refused one is counted, by
  // cause, and the model stays.
  void onCameraInfo(const sensor_msgs::CameraInfo& m) {
    imt::CameraModel k;
    std::string why;
    if (imt::cameraInfoForFrames(m, config_.pipeline.image_rectified, session_->cache().imageSize(), &k, &why)) {
      session_->setCameraInfo(k);
      return;
    }
    ledger_.cameraInfoRefused(why, "stamp " + imt::formatFixed(m.header.stamp.toSec(), 6));
  }

  void onImu(const sensor_msgs::Imu& m) {
    imt::ImuSample s;
    std::string reason;
    if (!imt::fromImuMsg(m, &s, &reason)) {
      ledger_.imuDropped(m.header.stamp.toSec());
      return;
    }
    ledger_.imuUsed(session_->addImu(s));
  }

  // "frame 3 (stamp 1000.100000) on /cam/image_raw"
  std::string whereIs(const imt::BagImage& im) const {
    return "frame " + std::to_string(im.index) + " (stamp " + imt::formatFixed(im.header().stamp.toSec(), 6) + ") on " +
           input_.imageTopic();
  }

  // The frame as gray, or why it cannot be (the decoder's words appended).
  bool decode(const imt::BagImage& im, cv::Mat* gray, std::string* why) {
    std::string reason, decoder_said;
    bool ok;
    if (im.raw) {
      ok = imt::imageToGray(*im.raw, gray, &reason);
    } else {
      capture_.start();
      ok = imt::compressedImageToGray(*im.compressed, gray, &reason);
      decoder_said = capture_.stop();
    }
    if (!ok) {
      *why = reason + (decoder_said.empty() ? "" : " [" + decoder_said + "]");
      return false;
    }
    if (!decoder_said.empty()) ledger_.decoderWarning(whereIs(im) + ": " + decoder_said);
    return true;
  }

  // A frame the session's cache did not keep, read again (empty on failure:
  // the alignment then skips that frame, as it does for a frame without image).
  cv::Mat rereadFrame(double stamp) {
    Stopwatch clock;
    cv::Mat gray;
    imt::BagImage im;
    std::string why;
    const auto it = frame_index_.find(stamp);
    if (it != frame_index_.end() && input_.readFrame(it->second, &im, &why) && decode(im, &gray, &why))
      ledger_.frameReadAgain();
    stage_seconds_["reread"] += clock.lap();
    return gray;
  }

  bool onImage(const imt::BagImage& im, std::string* why) {
    Stopwatch clock;
    const double stamp = im.header().stamp.toSec();
    cv::Mat gray;
    std::string reason;
    if (!decode(im, &gray, &reason)) {
      // Dropped, as live (the motion-analysis nodelet warns and counts it):
      // not a frame of the run; one warning per cause after it.
      ledger_.malformedFrame(im.index, reason, whereIs(im));
      stage_seconds_["decode"] += clock.lap();
      return true;
    }
    stage_seconds_["decode"] += clock.lap();

    const imt::MotionData& md = session_->analyze(gray, stamp);
    if (!session_->lastDrop().empty()) {
      // A repeated stamp or one slightly behind: not a frame of the run
      // (counted in summary.json; the first one named in a note).
      ledger_.timeDrop(im.index, session_->lastDrop());
      return true;
    }
    if (!session_->lastAnalysisReset().empty() && im.index > 0)
      ledger_.analysisReset(session_->lastAnalysisReset(), im.index, stamp);
    if (k_info_.valid && !size_warned_ && std::string(session_->cameraSource()) != "camera_info") {
      size_warned_ = true;
      notes_.warn("image size " + std::to_string(gray.cols) + "x" + std::to_string(gray.rows) +
                  " (first at frame " + std::to_string(im.index) + ") differs from " +
                  input_.cameraInfoTopic() + "'s " + std::to_string(k_info_.width) + "x" +
                  std::to_string(k_info_.height) + "; intrinsics from default_hfov_deg " + hfov() +
                  " deg for it");
    }
    clock.lap();  // the session times its own stages

    ledger_.frameModel(imt::motionModelName(md.camera.model));
    frames_out_.push_back({stamp, im.header(), std::max(im.bag_time, ros::TIME_MIN)});
    if (!camera_csv_.write(imt::cameraMotionRow(md), why)) return false;
    if (out_bag_) {
      try {
        const ros::Time when = std::max(im.bag_time, ros::TIME_MIN);
        out_bag_->write("/motion_data", when, imt::toMsg(md, im.header()));
      } catch (const std::exception& e) {
        *why = "cannot write --out-bag '" + args_.out_bag + "': " + e.what();
        return false;
      }
    }
    stage_seconds_["write"] += clock.lap();
    progress_->update(++frames_);
    return true;
  }

  // Regions, planar targets and anchors of INIT.yaml, each given at its frame
  // and tracked by the session over every frame of the run, backwards and
  // forwards through its cache; rows in frame order, then id order.
  void trackItems() {
    if (init_.empty()) return;
    Stopwatch clock;
    std::string err;
    uint32_t id;
    // An item given at a frame that was dropped names the frame's fault.
    auto refused = [&](const char* list, uint32_t item, int frame) {
      const std::string dropped = ledger_.whyDropped(frame);
      fail(args_.init + ": " + list + " (id " + std::to_string(item) + "): " + err +
           (dropped.empty() ? "" : " (" + dropped + ")"));
    };
    for (const imt::RegionInit& r : init_.regions) {
      const cv::Rect2d box(r.box[0], r.box[1], r.box[2], r.box[3]);
      if (!session_->addRegion(r.id, r.stamp, box, &id, &err)) refused("regions", r.id, r.frame);
    }
    for (const imt::PlanarTargetInit& t : init_.planar_targets) {
      std::array<cv::Point2d, 4> corners;
      for (int i = 0; i < 4; ++i) corners[i] = cv::Point2d(t.corners[i][0], t.corners[i][1]);
      if (!session_->addPlanarTarget(t.id, t.stamp, corners, t.size[0], t.size[1], &id, &err))
        refused("planar_targets", t.id, t.frame);
    }
    // Image targets are searched for from the first frame on, as live from
    // the frame they are given at.
    for (const imt::ImageTargetInit& t : init_.image_targets) {
      const imt::MotionCache& cache = session_->cache();
      const double first = cache.empty() ? 0 : cache.at(cache.firstSeq()).stamp;
      if (!session_->addImageTarget(t.id, first, t.picture, t.size[0], t.size[1], &id, &err))
        fail(args_.init + ": image_targets (id " + std::to_string(t.id) + ", " + t.path + "): " + err);
    }
    for (const imt::AnchorInit& a : init_.anchors) {
      if (!session_->addAnchor(a.id, a.stamp, cv::Point2d(a.point[0], a.point[1]), a.depth, &id, &err))
        refused("anchors", a.id, a.frame);
    }
    if (!init_.anchors.empty() && session_->imu().empty())
      notes_.warn("no usable IMU in the bag: anchors are translation-only (status no_imu)");

    size_t missing = 0;
    for (const FrameOut& f : frames_out_) {
      imt::FrameResult r;
      if (!session_->statesAt(f.stamp, &r, &err) || std::abs(r.motion.stamp - f.stamp) > 1e-9) {
        ++missing;  // dropped from the cache by a reset (time going backwards)
        continue;
      }
      writeRows(f, r);
    }
    if (missing)
      notes_.warn(std::to_string(missing) + " frame(s) before a reset have no region, planar-target or anchor rows "
                  "(the motion analysis restarted there)");
    stage_seconds_["track_items"] = clock.lap();
  }

  // A region that is lost, or tracked again after it was (frames in order),
  // is said in the notes with the tracker's reason, as the live graph logs it.
  void noteLostOrFound(const imt::RegionState& s) {
    const std::string change = region_losses_.update(s);
    if (change.empty()) return;
    // A region that flickers between the two says so a bounded number of times.
    constexpr int kMaxNotes = 50;
    if (++region_notes_ <= kMaxNotes) notes_.note(change);
    else if (region_notes_ == kMaxNotes + 1) notes_.note("more regions lost or tracked again: not listed");
  }

  void writeRows(const FrameOut& f, const imt::FrameResult& r) {
    std::string err;
    for (const imt::RegionState& s : r.regions) {
      if (!regions_csv_.write(imt::regionRow(s), &err)) fail(err);
      noteLostOrFound(s);
    }
    for (const imt::PlanarTargetState& s : r.targets)
      if (!targets_csv_.write(imt::planarTargetRow(s), &err)) fail(err);
    for (const imt::AnchorState& a : r.anchors)
      if (!anchors_csv_.write(imt::anchorRow(f.stamp, a.id, a.pixel, a.T_cam_anchor, imt::anchorStatusName(a.status),
                                             a.hasEstimate(), a.status != imt::AnchorStatus::kCalibrating),
                              &err))
        fail(err);
    if (!out_bag_) return;
    try {
      if (!init_.regions.empty()) out_bag_->write("/regions", f.bag_time, imt::toMsg(r.regions, f.header));
      if (!init_.planar_targets.empty() || !init_.image_targets.empty())
        out_bag_->write("/planar_targets", f.bag_time, imt::toMsg(r.targets, f.header));
      if (!init_.anchors.empty()) out_bag_->write("/anchors", f.bag_time, imt::toMsg(r.anchors, f.header));
      // One /tf message per frame: planar_target_<id> and anchor_<id>.
      tf2_msgs::TFMessage tf;
      tf.transforms = imt::planarTargetTransforms(r.targets, f.header, config_.ros.frame_prefix);
      for (auto& t : imt::anchorTransforms(r.anchors, f.header, config_.ros.frame_prefix)) tf.transforms.push_back(t);
      if (!tf.transforms.empty()) out_bag_->write("/tf", f.bag_time, tf);
    } catch (const std::exception& e) {
      fail("cannot write --out-bag '" + args_.out_bag + "': " + e.what());
    }
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

    ledger_.addNotes(session_->timeDrops(), &notes_);
    using Source = imt::AnchorManager::RotationSource;
    if (!input_.imuTopic().empty() && session_->rotationSource() == Source::kNone)
      notes_.warn("IMU-to-camera rotation unknown (" + tf_why_ +
                  ") and not found from the video (it needs turns about two axes): anchors are calibrating "
                  "(translation only)");
    if (session_->rotationSource() == Source::kVideo)
      notes_.note("IMU-to-camera rotation estimated from the video (no tf: " + tf_why_ +
                  "); anchors are calibrating until the frame it was found at");
    if (const size_t gaps = session_->timeGaps())
      notes_.note(std::to_string(gaps) + " gap(s) in the frame stamps over cache_seconds, tracked across");
    const std::string disagreement = session_->rotationDisagreement();
    if (!disagreement.empty()) notes_.warn(disagreement);
    for (const std::string& m : libraryLog().messages) notes_.warn(m);
  }

  void writeSummary() {
    imt::RunSummary summary;
    summary.frames = static_cast<int>(frames_);
    std::map<std::string, double> stages = stage_seconds_;
    for (const auto& [name, s] : session_->times().seconds) stages[name] += s;
    double accounted = 0;  // time of the play loop spent outside reading the bag
    for (const auto& [name, s] : stages)
      if (name != "open" && name != "track_items" && name != "reread") accounted += s;
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
    d["image_frame"] = input_.imageFrameId();
    d["imu_frame"] = orNull(imu_frame_);
    imt::addSessionDetails(*session_, &d);
    ledger_.addDetails(session_->timeDrops(), &d);
    d["frame_gaps"] = session_->timeGaps();
    d["init_entries"] = {{"regions", init_.regions.size()},
                         {"planar_targets", init_.planar_targets.size()},
                         {"image_targets", init_.image_targets.size()},
                         {"anchors", init_.anchors.size()}};
    d["messages"] = notes_.lines;
    std::string err;
    if (!imt::writeJsonFile(args_.out_dir + "/summary.json", summary.toJson(), &err)) fail(err);
  }

  std::string hfov() const { return imt::formatShortest(config_.pipeline.default_hfov_deg); }

  const Args& args_;
  Stopwatch total_clock_;
  imt::RegionLossLog region_losses_;
  int region_notes_ = 0;
  Notes notes_;
  // Inputs.
  std::string config_path_;
  imt::Config config_;
  imt::InitSpec init_;
  imt::BagInput input_;
  imt::CameraModel k_info_;  // from camera_info; valid = false without one
  std::string imu_frame_, tf_why_;
  std::map<double, int> frame_index_;  // stamp -> frame index, for rereadFrame()
  // Outputs.
  imt::CsvWriter camera_csv_, regions_csv_, targets_csv_, anchors_csv_;
  std::vector<FrameOut> frames_out_;  // every processed frame, for trackItems()
  std::unique_ptr<rosbag::Bag> out_bag_;
  // The run.
  std::unique_ptr<imt::TrackingSession> session_;
  std::unique_ptr<Progress> progress_;
  StderrCapture capture_;
  bool size_warned_ = false;
  size_t frames_ = 0;
  RunLedger ledger_;  // what was dropped, refused, restarted or read again
  std::map<std::string, double> stage_seconds_;
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
    if (args.print_config) {
      std::fputs(imt::defaultConfigYaml().c_str(), stdout);
      return 0;
    }
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
