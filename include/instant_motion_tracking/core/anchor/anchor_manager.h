// Calibration-free 6DoF anchors (paper 3.4) over a region manager and the IMU:
// the logic behind the AnchorNodelet and track_bag's anchors.csv.
//
// An anchor is a square region around the tapped pixel, tracked by the
// region tracker (translation and scale; predicted by the background motion
// while out of view), plus the camera orientation from the IMU
// (ImuOrientation, owned here). Its pose (core/anchor.h): the point lies along
// the ray through the region's centre at depth * initial side / current side;
// its frame has z up and x the camera's levelled viewing direction at
// placement. The scale change is corrected (patchSizeFactor) for the region's
// place in the image and, on a horizontal surface (anchors.surface), for the
// changing obliqueness of the view. The anchor is tracked from the very frame it is placed.
//
// The regions live in a RegionManager owned by the caller (the nodelet's
// own, or the pipeline's in track_bag), under region ids >= kAnchorRegionBase
// so they never meet the user's regions. The manager installs the IMU
// rotation as the region manager's camera fallback (RegionManager::
// setCameraFallback) for frames without a usable camera model; call update() after every
// RegionManager::update() so a reset there (time going backwards, a new image
// size) clears the anchors too.
//
// Without IMU orientation for a frame (no IMU, or it has not reached the
// frame) the status is no_imu: the translation is still tracked and the
// orientation is the one at placement, relative to the camera. An anchor
// placed before any IMU sample covers its frame takes its world orientation
// ("x = levelled viewing direction") from the first frame the IMU covers.
//
// The IMU-to-camera rotation comes from anchors.rotation_cam_imu, else from
// tf (setRotationCamImu), else from the video itself: each frame's camera
// motion, read as a turn, against the gyro's turn between the same stamps
// (CamImuRotationEstimator; needs turns about two axes; once it has a first
// estimate, the turns are read over the floor where that explains the
// background better, as the bias's are below). A camera that travels as it
// turns (a phone in a car) adds its travel to those turns: their fit
// refuses, or takes a rotation some degrees off; the features' epipolar
// lines then give it or check it (EpipolarCamImuRotation, each row's gyro
// turn at its own time under anchors.rolling_shutter_readout). Until one of them
// gives it the anchors are `calibrating`: translation only, as no_imu. When
// the rotation changes (tf arrives, the video's estimate moves by more than
// kRotationUpdateDeg) the anchors' orientations follow it: each keeps the
// IMU's orientation at placement, and the camera's comes through the
// rotation in use at the frame asked for.
// The video's estimate is kept up also when tf gives the rotation, to check
// it (rotationDisagreement()).
//
// The gyro bias is tracked from the video while the camera moves
// (imu.video_bias; VideoGyroBias): each turn the gyro covers is also read off
// the background's motion as a turn over the floor (rotationFromPlaneHomography,
// the IMU's up as the normal) or a turn and zoom, whichever explains it
// within kVideoBiasMaxRmsPx, and compared with the gyro's. The readings
// outlive the video's rotation refining itself (they take the rotation at
// each fit), not a rotation given by the options or tf.
//
// The turns wait for the gyro to cover them and are read as soon as it does
// (addImu() and update() alike), so what they teach depends on the data
// alone, not on when frames were tracked: live and offline agree.
//
// Usage (live):
//   imt::RegionManager regions(o.region_tracking, o.cache_seconds);
//   imt::AnchorManager anchors(o.anchors, o.imu, o.default_hfov_deg, &regions);
//   anchors.setRotationCamImu(q_cam_imu_from_tf);   // ignored when anchors.rotation_cam_imu is set
//   on IMU:   if (anchors.addImu(sample, &why) == ImuInput::kDropped) warn(why);
//   on frame: queue md; while (anchors.ready(oldest_queued, newest_queued))
//               { regions.update(oldest md); anchors.update();
//                 anchors.statesAt(its stamp, {}, &states, &err); publish(states); pop; }
//   anchors.add(0, stamp, {u, v}, depth, &id, &error);   // stamp 0 = the latest frame
// Threading: not thread-safe; callers serialise (the nodelet holds a mutex).
#pragma once

#include "instant_motion_tracking/core/anchor/cam_imu_rotation.h"
#include "instant_motion_tracking/core/anchor/epipolar_rotation.h"
#include "instant_motion_tracking/core/anchor/time_offset.h"
#include "instant_motion_tracking/core/anchor/video_gyro_bias.h"
#include "instant_motion_tracking/core/anchor/imu_orientation.h"
#include "instant_motion_tracking/core/region/region_manager.h"
#include "instant_motion_tracking/core/types.h"
#include "instant_motion_tracking/core/anchor/anchor_options.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <cstdint>
#include <deque>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace imt {

enum class AnchorStatus : uint8_t { kTracked, kOutOfView, kNoImu, kLost, kCalibrating };
// "tracked", "out_of_view", "no_imu", "lost", "calibrating" (the CSV and message spelling).
const char* anchorStatusName(AnchorStatus s);

// One anchor at one frame.
struct AnchorState {
  uint32_t id = 0;
  double stamp = 0;
  // Projection of the anchor point (predicted when out of view); meaningless when lost.
  cv::Point2d pixel;
  // The anchor frame in the camera optical frame.
  Eigen::Isometry3d T_cam_anchor = Eigen::Isometry3d::Identity();
  AnchorStatus status = AnchorStatus::kTracked;
  double confidence = 0;  // 0 .. 1 (the region's; 0 when lost)
  std::string reason;     // why no_imu, calibrating or lost (empty otherwise)

  bool hasEstimate() const { return status != AnchorStatus::kLost; }
  // Whether the orientation is the world's (else the one at placement, relative to the camera).
  bool hasOrientation() const { return status == AnchorStatus::kTracked || status == AnchorStatus::kOutOfView; }
};

// What became of an IMU sample given to AnchorManager::addImu().
// kGap: accepted after a gap longer than imu.max_gap_seconds (no orientation
// inside it; roll and pitch re-levelled, yaw carried over: worth a warning).
enum class ImuInput { kAccepted, kDropped, kReset, kGap };

class AnchorManager {
 public:
  // Internal region ids of anchors start here (user regions stay below).
  static constexpr uint32_t kAnchorRegionBase = 1000000000u;

  // `regions` must outlive the manager. Throws std::invalid_argument on
  // invalid options (validate()).
  AnchorManager(const AnchorOptions& options, const ImuOptions& imu_options,
                double default_hfov_deg, RegionManager* regions);
  ~AnchorManager();  // removes its camera fallback from the region manager
  AnchorManager(const AnchorManager&) = delete;
  AnchorManager& operator=(const AnchorManager&) = delete;

  // The camera model of the images (camera_info's, with its distortion);
  // intrinsics() is CameraModel::forFrame(it, the frames' size, default_hfov_deg).
  void setIntrinsics(const CameraModel& k) { info_ = k; }
  CameraModel intrinsics() const;

  // IMU -> camera rotation (from tf2); ignored (false) when the options fix it
  // or when q is not a usable rotation.
  bool setRotationCamImu(const Eigen::Quaterniond& q_cam_imu);
  bool rotationFromOptions() const { return rotation_source_ == RotationSource::kOptions; }
  // Where the IMU -> camera rotation in use came from.
  enum class RotationSource { kNone, kOptions, kTf, kVideo };
  RotationSource rotationSource() const { return rotation_source_; }
  static const char* rotationSourceName(RotationSource s);  // "none", "options", "tf", "video"
  // The video's own estimate (also when another source gives the rotation).
  const CamImuRotationEstimator& videoRotation() const { return video_rotation_; }
  // The last fit from the features' epipolar lines (none until one was made).
  const std::optional<EpipolarRotationFit>& epipolarRotationFit() const { return epipolar_fit_; }
  // "" or, when the rotation in use (options or tf) and the video's estimate
  // differ by more than kRotationDisagreementDeg, a message naming both.
  std::string rotationDisagreement() const;
  // The camera-IMU time offset in use (s; IMU stamp = image stamp + it), and
  // the last fit from the video (none before one had turns to work with).
  double timeOffset() const { return imu_.timeOffset(); }
  const std::optional<TimeOffsetFit>& timeOffsetFit() const { return time_offset_fit_; }
  // Where the offset in use came from: the parameter (anchors.imu_time_offset),
  // the turn rates' correlation (TimeOffsetFit), or the gyro bias's fit (its
  // lateness, VideoGyroBias::Estimate, taken off the offset it was read at).
  // The correlation finds any offset within its reach but carries a scene's
  // bias (the floor's flow: +13.6 ms on the rendered walk); the bias fit is
  // sharp (under 1 ms there) but linear, good for the last tens of ms. So
  // once the bias fit reads the lateness sharply (imu.video_bias), the
  // correlation moves the offset only by more than kOffsetCorrelationReach
  // and the bias fit refines it (where the video found the rotation, once
  // its last two sharp fits agree). Until then, or without the bias fit,
  // the correlation's offset is used as it is.
  enum class OffsetSource { kParameter, kCorrelation, kBiasFit };
  OffsetSource timeOffsetSource() const { return offset_source_; }
  static const char* offsetSourceName(OffsetSource s);  // "parameter", "correlation", "bias_fit"
  // The bias fit's lateness is applied when its standard error is under
  // this (s), it is over kOffsetMinChange and (rotation from the video) the
  // offset it implies agrees with the last sharp fit's.
  static constexpr double kOffsetMaxLatenessSigma = 0.002;
  static constexpr double kOffsetMinChange = 0.001;
  // s: the bias fit's reach (its linear model is 2% short at 40 ms).
  static constexpr double kOffsetCorrelationReach = 0.05;
  // The gyro bias in use (rad/s, IMU frame) and its source; the video's
  // estimate of it while the camera moves (imu.video_bias; none before it
  // has VideoGyroBias::kMinFrames frames), also when a still stretch gave
  // the bias in use.
  const Eigen::Vector3d& gyroBias() const { return imu_.gyroBias(); }
  ImuOrientation::BiasSource gyroBiasSource() const { return imu_.biasSource(); }
  const std::optional<VideoGyroBias::Estimate>& videoGyroBias() const { return video_bias_estimate_; }
  // A frame counts toward the video's bias when the background's motion is
  // explained by the camera's turn (over the floor, or not) to within this.
  static constexpr double kVideoBiasMaxRmsPx = 1.0;
  // The video's estimate is used once its standard error is under this
  // (rad/s per axis; 0.06 deg/s), refitted every kVideoBiasRefitTurns turns
  // read (keyed to the turns, which are read in the same order live and
  // offline). What the old bias put into the orientation since the last
  // estimate used (at most kVideoBiasReach of window_seconds back) is taken
  // out at the turn's end (ImuOrientation::setVideoGyroBias).
  static constexpr double kVideoBiasMaxSigma = 0.001;
  static constexpr int kVideoBiasRefitTurns = 30;
  static constexpr double kVideoBiasReach = 0.9;
  // Anchors add() accepts: depth 0 (the default) or in [kMinDepth, kMaxDepth]
  // m, at most options' max_anchors at once (each tracks a region).
  static constexpr double kMinDepth = 0.01;
  static constexpr double kMaxDepth = 1e4;
  static constexpr double kRotationUpdateDeg = 0.2;
  static constexpr double kRotationDisagreementDeg = 5.0;
  // Appends an IMU sample (stamp order). kDropped with *why for NaN values or
  // a stamp not after the previous one; kReset when the stamp is more than
  // imu_reset_seconds behind the newest (a bag loop): the orientation
  // restarts from this sample and the anchors re-take their world
  // orientation from the next frame the IMU covers.
  ImuInput addImu(const ImuSample& s, std::string* why = nullptr);
  const ImuOrientation& imu() const { return imu_; }
  // Forgets every IMU sample (and the estimated bias); anchors re-take their
  // world orientation from the next frame the IMU covers.
  void resetImu();

  // After every RegionManager::update(): clears the anchors when it reset,
  // and reads the new frame's turn for the video's IMU -> camera rotation.
  void update();

  // Places an anchor at the pixel `uv` (our pixel convention) of the frame
  // nearest `stamp` (0 = latest; within the cache). id 0 chooses a free id;
  // depth 0 = default_depth. False with a message for a duplicate id, a NaN
  // pixel or a depth out of range (validateAnchorRequest, item_requests.h),
  // too many anchors, a stamp outside the cache, or a pixel outside the image.
  bool add(uint32_t id, double stamp, const cv::Point2d& uv, double depth, uint32_t* assigned_id,
           std::string* error);
  bool remove(uint32_t id, std::string* error);
  void clear();

  // The states of `ids` (empty = all, in id order) at a cached `stamp` (0 = latest).
  bool statesAt(double stamp, const std::vector<uint32_t>& ids, std::vector<AnchorState>* states,
               std::string* error);
  // Whether the frame at `stamp` can be given its anchors now (live): no
  // anchors, no IMU ever seen, the IMU past the stamp, or the newest frame
  // imu_wait_seconds after it. `newest_frame_stamp`: the newest frame known,
  // when the caller holds frames back from the region manager until they
  // are ready (so the IMU can stand in for a missing camera model).
  bool ready(double stamp) const { return ready(stamp, regions_->newestStamp()); }
  bool ready(double stamp, double newest_frame_stamp) const;

  size_t size() const { return anchors_.size(); }
  std::vector<uint32_t> ids() const;  // in id order
  bool contains(uint32_t id) const { return anchors_.count(id) > 0; }
  const AnchorOptions& options() const { return options_; }

 private:
  struct Anchor {
    uint32_t id = 0, region_id = 0;
    double stamp = 0;    // placement frame
    double depth = 1.0;  // m along the tap's ray at placement
    double side = 0;     // px, initial region side
    cv::Point2d uv0;     // px, the tapped pixel
    bool bound = false;  // the IMU's orientation at placement known
    // The IMU at binding (the camera's follows with the rotation in use).
    Eigen::Matrix3d R_world_imu0 = Eigen::Matrix3d::Identity();
  };
  void tryBind(Anchor& a, double stamp);
  AnchorState stateOf(Anchor& a, const RegionState& r, double stamp);
  // The rotation in use becomes `q` from `source`: a given one (options, tf)
  // for every frame, the video's from the frame stamped `from` on. The
  // anchors' orientations follow it (they keep the IMU's at placement).
  bool useRotation(const Eigen::Quaterniond& q, RotationSource source, double from = 0);
  // The video's turns waiting for the gyro to cover them, and the estimate
  // fed with those it does.
  void readTurns();
  // The IMU's turn between image stamps t0 and t1 (the IMU at t1 in the IMU
  // at t0, read at the time offset, as the gyro measured it); false before
  // the IMU began or across a gap.
  bool imuTurn(double t0, double t1, Eigen::Matrix3d* turn) const;
  // Whether the gyro covers a frame stamped t1 (its last row's time, at the time offset).
  bool gyroCovers(double t1) const;
  // The IMU's turn between IMU stamps s0 and s1 for the camera fallback;
  // up to kFallbackLeadSeconds past the newest sample, extrapolated.
  bool fallbackTurn(double s0, double s1, Eigen::Matrix3d* turn) const;
  static constexpr double kFallbackLeadSeconds = 0.1;  // the time offset's reach
  static constexpr double kFallbackRateSeconds = 0.02;

  AnchorOptions options_;
  double default_hfov_deg_;
  RegionManager* regions_;
  ImuOrientation imu_;
  RotationSource rotation_source_ = RotationSource::kNone;
  CamImuRotationEstimator video_rotation_;
  struct Turn {
    double t0 = 0, t1 = 0;
    Eigen::Vector3d theta_cam = Eigen::Vector3d::Zero();  // the camera's turn from t0 to t1 (rotation vector)
    double rms_px = 0;                                     // what the turn and zoom leave of H (cameraTurn)
    Eigen::Matrix3d H = Eigen::Matrix3d::Identity();       // the frame's camera motion
  };
  std::deque<Turn> turns_;
  // The IMU-to-camera rotation from the features' epipolar lines, for a
  // camera that travels as it turns (a phone in a car, a walking robot),
  // where the turns' fit above takes part of the travel for a turn: it
  // refuses, or it accepts a rotation some degrees off (a rendered drive:
  // 6-18 deg). While no rotation is known or the video's turns gave it,
  // each frame's feature pairs (at most the estimator's max_pairs_per_frame)
  // wait, as its turn does, for the gyro to cover them, and are read in
  // stamp order with the turns: each pair's gyro turn is read then, over
  // its own rows' times. Every kEpipolarRefitFrames frames so read
  // (doubling after the third fit that is not sharp, and each after it, up
  // to 8 times) the pairs are fitted from the turns' best fit. The first
  // sharp fit ends it: used where no rotation is known or where the turns'
  // disagrees with it by more than kRotationDisagreementDeg (the turns' fit
  // then moves it only within that of it), else it confirms the turns'. The frames read
  // and their order are the same live and offline, so is the fit.
  struct EpipolarFrame {
    double t1 = 0, focal_px = 0;
    std::vector<EpipolarPair> pairs;
    std::vector<std::pair<double, double>> times;  // each pair's rows' image stamps
  };
  void addEpipolarFrame(const MotionData& md, double t0);
  void readEpipolarFrames(double before);  // those the gyro covers, stamped before `before`
  void clearEpipolarFrames();
  bool epipolarWanted() const;
  std::optional<Eigen::Quaterniond> epipolar_used_;  // the epipolar fit's rotation, once used
  bool epipolar_done_ = false;           // a sharp epipolar fit was made (kept across resets: the rig's)
  EpipolarCamImuRotation epipolar_rotation_;
  std::deque<EpipolarFrame> epipolar_frames_;
  int epipolar_since_fit_ = 0;
  static constexpr int kEpipolarRefitFrames = 30;
  int epipolar_interval_ = kEpipolarRefitFrames;
  int epipolar_refused_ = 0;  // fits that were not sharp
  std::optional<EpipolarRotationFit> epipolar_fit_;
  // The camera's turn over `t` read over the floor or as a turn and a zoom,
  // whichever explains the background better; false when neither does.
  bool floorTurn(const Turn& t, Eigen::Vector3d* theta_cam) const;
  static constexpr size_t kMaxWaitingTurns = 300;
  // Consecutive turns each under the rotation estimator's min_angle (a
  // slow pan: under 6 deg/s at 30 frames/s), composed until together they
  // reach it, over at most kMaxSlowTurns frames: a slow turn still shows
  // the IMU-to-camera rotation, over several frames.
  struct SlowTurn {
    double t0 = 0, t1 = 0;
    Eigen::Matrix3d R_cam = Eigen::Matrix3d::Identity();  // the camera at t1 in the camera at t0
    int frames = 0;
  };
  SlowTurn slow_turn_;
  static constexpr int kMaxSlowTurns = 15;
  // A turn for the IMU-to-camera rotation; `over_floor`, where given, is the
  // camera's turn read over the floor (floorTurn()).
  void addRotationTurn(const Turn& t, const Eigen::Matrix3d& R_imu0_imu1, const Eigen::Vector3d* over_floor);
  // The camera-IMU time offset (anchors.estimate_imu_time_offset): the
  // video's turn angles, refitted every kOffsetRefitTurns of them.
  void fitTimeOffset();
  void clearTimeOffsetTurns();
  TimeOffsetEstimator time_offset_;
  size_t next_offset_fit_ = TimeOffsetEstimator::Options().min_turns;
  static constexpr size_t kOffsetRefitTurns = 60;
  std::optional<TimeOffsetFit> time_offset_fit_;
  OffsetSource offset_source_ = OffsetSource::kParameter;
  // The gyro bias from the video (imu.video_bias): read at frames stamped
  // t1 when the options ask for it and a rotation is known there; a reading
  // is the gyro's turn against the camera's, `theta_cam` (floorTurn()).
  bool readsVideoBias(double t1) const;
  void addBiasTurn(const Turn& t, const Eigen::Matrix3d& R_imu0_imu1, const Eigen::Vector3d& theta_cam);
  void fitVideoBias(double t1);
  // The offset the last sharp bias fit implied (s; NaN: none since its
  // frames were last cleared).
  double last_implied_offset_ = std::numeric_limits<double>::quiet_NaN();
  void clearVideoBias();
  VideoGyroBias video_bias_;
  std::optional<VideoGyroBias::Estimate> video_bias_estimate_;
  int bias_turns_since_fit_ = 0;
  double bias_applied_at_ = -std::numeric_limits<double>::infinity();  // IMU stamp of the last estimate used
  // The rotations in use, each from a stamp on (given ones: from -inf).
  std::vector<std::pair<double, Eigen::Quaterniond>> rotations_;
  const Eigen::Quaterniond* rotationAt(double t) const;  // nullptr: none at t
  CameraModel info_;
  std::map<uint32_t, Anchor> anchors_;
  uint32_t next_region_id_ = kAnchorRegionBase;
};

}  // namespace imt
