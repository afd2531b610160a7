// TrackingSession: everything that tracks one camera stream, the one object
// behind both the live nodelets and the offline track_bag (docs/architecture.md).
//
// It owns the motion analysis (paper 3.1), the motion-data cache, the camera
// model of the frames, the IMU orientation (inside the anchors) and the
// trackers: regions (3.2), planar targets (3.3) and anchors (3.4), all over
// that one cache. A frame goes in as an image (analyze) or as motion data
// analysed elsewhere (pushMotion); the trackers run on it once the IMU has
// passed its stamp (only while anchors wait for it), and its results come
// out of takeResults(), in frame order.
//
// Usage (live):
//   imt::TrackingSession session(options, imt::TrackingSession::Mode::kLive);
//   on camera_info:  session.setCameraInfo(model);
//   on IMU:          session.addImu(sample, &why);
//   on image:        publish(session.analyze(gray, stamp));      // motion data at once
//   after either:    for (auto& r : session.takeResults()) publish(r);
//   on a request:    session.addRegion(0, stamp_in_the_past, box, &id, &error);
// Offline (track_bag, Mode::kOffline: the cache keeps the whole stream, the
// IMU window spans up to an hour): analyze() every frame, then add the items
// at their frames and read every frame's states with statesAt(), which tracks
// them backwards and forwards through the cache. Images the cache no longer
// holds come from setImageSource() (the bag, read again).
// Threading: not thread-safe; callers serialise.
#pragma once

#include "instant_motion_tracking/core/anchor/anchor_manager.h"
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/motion_cache.h"
#include "instant_motion_tracking/core/options.h"
#include "instant_motion_tracking/core/planar/planar_target_manager.h"
#include "instant_motion_tracking/core/region/region_manager.h"
#include "instant_motion_tracking/core/types.h"

#include <array>
#include <deque>
#include <map>
#include <limits>
#include <memory>
#include <optional>
#include <string>
#include <vector>

namespace imt {

// What the trackers made of one frame.
struct FrameResult {
  MotionData motion;
  std::vector<RegionState> regions;        // the user's regions (anchors' own excluded)
  std::vector<PlanarTargetState> targets;  // every planar target
  std::vector<AnchorState> anchors;        // every anchor
  // Why the trackers were cleared at this frame (time went back, the image
  // size changed); "" normally. The items given before are gone.
  std::string reset;
  // The frame (live, when given to analyze()), for overlays: the session's
  // copy where its trackers keep frames or the frame waited for the IMU,
  // else the caller's image as given.
  cv::Mat gray;
  CameraModel camera;  // the camera model of the frame
};

// Accumulated wall time per stage (s) and the frame count.
struct StageTimes {
  std::map<std::string, double> seconds;  // stage name -> total seconds
  int frames = 0;
};

class TrackingSession {
 public:
  enum class Mode {
    kLive,    // cache_seconds of motion data; results as frames become ready
    kOffline  // the whole stream kept: items given at any frame, tracked both ways
  };

  // Throws std::invalid_argument on invalid options (validate(); the
  // loaders check them first, naming the parameter).
  TrackingSession(const PipelineOptions& options, Mode mode);
  TrackingSession(const TrackingSession&) = delete;
  TrackingSession& operator=(const TrackingSession&) = delete;

  // --- Inputs ---------------------------------------------------------------
  // The camera model from camera_info (valid = false: none). It is used for
  // frames of its size; other frames get a pinhole of default_hfov_deg.
  void setCameraInfo(const CameraModel& info);
  // The model of the current frames, and where it came from
  // ("camera_info", "field_of_view", or "none" before any frame).
  CameraModel camera() const;
  const char* cameraSource() const;
  // IMU -> camera rotation (tf); ignored (false) when anchors.rotation_cam_imu
  // fixes it or q is not a rotation.
  bool setRotationCamImu(const Eigen::Quaterniond& q_cam_imu);
  bool rotationFromOptions() const { return anchors_->rotationFromOptions(); }
  // The IMU -> camera rotation in use (the option's, tf's once given, or the
  // video's once it showed it); none while unknown (anchors `calibrating`),
  // and where it came from.
  const std::optional<Eigen::Quaterniond>& rotationCamImu() const { return anchors_->imu().rotationCamImu(); }
  AnchorManager::RotationSource rotationSource() const { return anchors_->rotationSource(); }
  const CamImuRotationEstimator& videoRotation() const { return anchors_->videoRotation(); }
  // The last fit from the features' epipolar lines (a camera that travels as it turns).
  const std::optional<EpipolarRotationFit>& epipolarRotationFit() const { return anchors_->epipolarRotationFit(); }
  // "" or a message: tf (or the option) and the video disagree on that rotation.
  std::string rotationDisagreement() const { return anchors_->rotationDisagreement(); }
  // The camera-IMU time offset in use and the video's last fit of it.
  double timeOffset() const { return anchors_->timeOffset(); }
  const std::optional<TimeOffsetFit>& timeOffsetFit() const { return anchors_->timeOffsetFit(); }
  AnchorManager::OffsetSource timeOffsetSource() const { return anchors_->timeOffsetSource(); }
  // The gyro bias in use, its source, and the video's estimate (AnchorManager).
  const Eigen::Vector3d& gyroBias() const { return anchors_->gyroBias(); }
  ImuOrientation::BiasSource gyroBiasSource() const { return anchors_->gyroBiasSource(); }
  const std::optional<VideoGyroBias::Estimate>& videoGyroBias() const { return anchors_->videoGyroBias(); }
  // An IMU sample, in stamp order (see AnchorManager::addImu for the outcomes).
  // Frames waiting for it may become ready: takeResults() afterwards.
  ImuInput addImu(const ImuSample& s, std::string* why = nullptr);
  // Forgets the IMU (its subscriber went away).
  void resetImu() { anchors_->resetImu(); }
  const ImuOrientation& imu() const { return anchors_->imu(); }

  // Analyses one gray frame (CV_8UC1) and queues it for the trackers; returns
  // its motion data (to publish at once: it does not wait for the IMU).
  // Time rules (analyze() and pushMotion() alike): a frame with the newest
  // frame's stamp, or behind it by less than time_jump_reset_seconds, is
  // dropped (not analysed, not tracked: lastDrop() says why, and the
  // returned motion data is the newest frame's); one farther behind restarts
  // tracking (a bag loop: lastAnalysisReset(), FrameResult::reset); a jump
  // forward is a gap, tracked across. The session keeps copies of what it
  // keeps of `gray`: the caller may write into its buffer once this returns.
  const MotionData& analyze(const cv::Mat& gray, double stamp);
  // Why the last frame given was dropped ("" when it was not).
  const std::string& lastDrop() const { return last_drop_; }
  // Frames dropped by the time rules since construction: a repeated stamp,
  // a stamp slightly behind the newest.
  struct TimeDrops {
    size_t duplicate = 0, behind = 0;
  };
  const TimeDrops& timeDrops() const { return time_drops_; }
  // Jumps forward over cache_seconds since construction (gaps: counted,
  // tracked across), and the last one's message ("" when the last frame
  // given was none).
  size_t timeGaps() const { return time_gaps_; }
  const std::string& lastGap() const { return last_gap_; }
  // Why the last analyze() restarted the motion analysis ("" when it did not).
  const std::string& lastAnalysisReset() const { return analyzer_.lastReset(); }
  // Queues motion data analysed elsewhere (a tracker nodelet fed by the
  // motion_data topic); `gray` optional, for the planar alignment (kept as
  // analyze() keeps it).
  void pushMotion(const MotionData& md, const cv::Mat& gray = cv::Mat());
  // Runs the trackers on the queued frames that are ready (all of them with
  // `all`): their IMU has come, or nothing waits for it.
  void advance(bool all = false);
  // The results of the frames the trackers ran on since the last call.
  std::vector<FrameResult> takeResults();
  size_t waitingFrames() const { return pending_.size(); }

  // Frames are kept in the cache (within planar_tracking.image_memory_mb) for
  // the planar targets' appearance alignment while `keep` (and refinement is
  // on). Off by default: a session with planar targets turns it on.
  void setKeepImages(bool keep);
  // Where the cache finds the image of a frame it did not keep (offline: the
  // bag, read again), so the alignment sees every frame it needs.
  void setImageSource(MotionCache::ImageSource source) { regions_.setImageSource(std::move(source)); }

  // --- Items (stamp 0 = the latest frame; ids 0 = choose one) ---------------
  bool addRegion(uint32_t id, double stamp, const cv::Rect2d& box, uint32_t* assigned_id,
                 std::string* error);
  bool removeRegion(uint32_t id, std::string* error);
  // The regions' states (ids empty = all) at a cached stamp.
  bool seekRegions(double stamp, const std::vector<uint32_t>& ids, std::vector<RegionState>* states,
                   std::string* error);
  bool addPlanarTarget(uint32_t id, double stamp, const std::array<cv::Point2d, 4>& corners, double width_m,
                       double height_m, uint32_t* assigned_id, std::string* error);
  // A planar target known by its picture (PlanarTargetManager::addImage),
  // searched for from the frame nearest `stamp` on.
  bool addImageTarget(uint32_t id, double stamp, const cv::Mat& picture, double width_m, double height_m, uint32_t* assigned_id,
                      std::string* error);
  bool removePlanarTarget(uint32_t id, std::string* error);
  bool addAnchor(uint32_t id, double stamp, const cv::Point2d& uv, double depth, uint32_t* assigned_id,
                 std::string* error);
  bool removeAnchor(uint32_t id, std::string* error);
  size_t regionCount() const;  // the user's regions
  size_t planarTargetCount() const { return targets_.size(); }
  size_t anchorCount() const { return anchors_->size(); }
  // Every item's state at the cached frame nearest `stamp` (offline output).
  bool statesAt(double stamp, FrameResult* result, std::string* error);

  const MotionCache& cache() const { return regions_.cache(); }
  const StageTimes& times() const { return times_; }
  const PipelineOptions& options() const { return options_; }
  Mode mode() const { return mode_; }

 private:
  struct Pending {
    MotionData md;
    cv::Mat gray;
  };
  // Queues a frame for the trackers and takes through those the IMU allows;
  // a frame left waiting keeps its own copy of `gray`.
  void queue(const MotionData& md, const cv::Mat& gray);
  // `gray` as the trackers keep it: itself when only this session holds its
  // pixels, else a copy (the caller may write into its buffer afterwards).
  static cv::Mat ownImage(const cv::Mat& gray);
  // Takes the oldest waiting frame through the trackers.
  void trackOldest();
  void dropStaleFrames(double stamp);
  // The user's regions among `states` (anchors' own regions dropped).
  static std::vector<RegionState> userRegions(std::vector<RegionState> states);
  // Makes sure the frame nearest `stamp` has gone through the trackers
  // (items given at a frame still waiting for the IMU); stamp 0 ("now") is
  // the newest frame that already has.
  void flushFor(double stamp);
  // The trackers read the frames' images: the planar alignment (while kept)
  // or the regions (their own features, their look). Then the cache keeps
  // them within planar_tracking.image_memory_mb (imageBudget(), else 0).
  bool trackersUseImages() const;
  size_t imageBudget() const;
  void addTime(const char* stage, double seconds) { times_.seconds[stage] += seconds; }

  PipelineOptions options_;
  Mode mode_;
  MotionAnalyzer analyzer_;
  RegionManager regions_;
  PlanarTargetManager targets_;
  std::unique_ptr<AnchorManager> anchors_;  // after regions_, which it refers to
  CameraModel info_;
  std::deque<Pending> pending_;
  std::vector<FrameResult> results_;
  MotionData last_motion_;
  // The time rules (analyze()): true when the frame is to be dropped.
  bool dropByTime(double stamp);
  double newest_stamp_ = -std::numeric_limits<double>::infinity();
  size_t time_gaps_ = 0;
  std::string last_gap_;
  std::string last_drop_;
  TimeDrops time_drops_;
  StageTimes times_;
  bool keep_images_ = false;
};

}  // namespace imt
