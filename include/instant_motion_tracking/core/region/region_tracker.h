// Region tracking on motion data alone (paper 3.2).
//
// A region is a box whose motion is fitted, frame to frame, to the motion
// vectors of the features inside it (dilated) by IRLS with weights
// w_i = prior_i / error_i: the prior favours the features that supported the
// region last frame (its implicit appearance, kept as feature IDs) and those
// near its centre, and disfavours those it has seen moving with the camera
// while it moved on its own (the background at the edges of its box, kept
// as feature IDs while they stay near it); the error is the feature's
// residual against the current fit. A scale that the motion analysis's
// background features and its moving ones give together but neither alone
// is two motions in one box (a wall patch a card slides off), not a zoom:
// the region is then fitted as a translation.
//
// Own features (when the frames' images are given): each region also tracks
// up to `region_features` corners of its own, found inside its box and
// followed with pyramidal LK at a resolution that fits the box (full
// resolution inside small boxes), so a small or plain-textured target still
// has motion vectors where the motion analysis's uniform grid gave it few.
// They join the same fit, in both time directions.
//
// Shape (when the frame's image is given with the box): a box whose sides lie
// on the frame's edges holds a rectangle (a poster, a screen), as drawn or
// turned (the turned rectangle whose corners touch the box's sides, when the
// edges run one way turned): the region is that rectangle, turned as found,
// and its reported extent is the turned rectangle's (else a hedge between a
// rectangle's and an ellipse's: what fills the box is unknown).
//
// Appearance (when the frames' images are given): each region keeps a small
// template of its look (region_appearance.h), taken at placement and blended
// with later looks on confident frames (and on half matches, above
// `appearance_lost_score`, while many features carry it: a tilting target's
// look changes faster than its strong matches would teach it). After the
// motion step the template is matched around the new box: a clearly better
// match nearby corrects slow drift (fully when the motion step had no
// support of its own: featureless, coasting, or no camera model); a region
// that stops looking like itself for `appearance_lost_frames` frames is
// lost; and a lost region is searched for around its last place and, every
// `reacquire_interval` frames, over the whole frame, and becomes `tracked`
// again on a strong match (its `reason` says so on that frame). The look
// costs far more than the motion step: with more regions than
// `appearance_budget`, each region's look is checked on
// its turn only (every ceil(regions / budget) frames, staggered by id),
// whether the features carry it or it is in doubt, taking on that frame the
// nudges and template updates of the frames it skipped (its patience before
// `lost` counts those frames too, rounded up to whole checks; one in doubt
// is searched for wider, up to twice, the longer since its last check); a
// lost region's searches around its last place between its whole-frame ones
// also come on its turns. A region its features carry weakly also asks a
// correlation filter that tells it from its surround (region_filter.h,
// `appearance_filter`): a clear find places it where the template did not,
// keeps it seen, and checks the features' scale (findByFilter()). Without
// images the tracker runs on motion data alone, as the paper's.
//
// A step works in either time direction: forward (frame k-1 -> k) and
// backward (k -> k-1) use the same fit on reversed correspondences, which is
// what lets the region manager (region_manager.h, over motion_cache.h) track
// regions added in the past and seek to any cached stamp.
//
// Usage:
//   imt::RegionTracker tracker(options, image_size);
//   imt::RegionState s = imt::RegionState::start(7, box, stamp);
//   s = tracker.step(s, motion_data_of_next_frame, imt::Direction::kForward);
// Threading: const methods only; one tracker may serve many threads.
#pragma once

#include "instant_motion_tracking/core/region/region_appearance.h"
#include "instant_motion_tracking/core/region/region_filter.h"
#include "instant_motion_tracking/core/region/region_tracker_options.h"
#include "instant_motion_tracking/core/types.h"

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <set>
#include <string>
#include <vector>

namespace imt {

struct OwnFeature;

enum class RegionStatus : uint8_t { kTracked, kFeatureless, kOutOfView, kLost };
// "tracked", "featureless", "out_of_view", "lost" (the CSV spelling).
const char* regionStatusName(RegionStatus s);

enum class Direction { kForward, kBackward };

// The tracking state of one region at one frame.
struct RegionState {
  uint32_t id = 0;
  double stamp = 0;
  cv::Rect2d box;                  // x, y, width, height (px) of the region before its turn (`angle`); meaningless when lost
  double angle = 0;                // rad; how far the region has turned in the image since it was given, about
                                   // the box's centre (x toward y: clockwise as seen)
  RegionStatus status = RegionStatus::kTracked;
  double confidence = 0;           // 0 .. 1
  Eigen::Vector2d velocity = Eigen::Vector2d::Zero();  // px/frame of the box centre, in the tracking direction
  Eigen::Vector2d object_velocity = Eigen::Vector2d::Zero();  // px/frame relative to the background (camera) motion
  double scale_rate = 0;  // log size change per frame, smoothed as velocity is (a coasting region goes on at it, fading: kUnseenMotionFade in region_tracker.cpp)
  // Its box was seen to be a rectangle's when it was given (its sides on the
  // frame's edges, region_shape.h), turned by `placed_angle` then: its extent
  // is the turned rectangle's, not the hedged one.
  bool rectangle = false;
  double placed_angle = 0;
  double placed_aspect = 0;  // width / height of the box it was given (0: unknown); its look's
  double support = 0;              // reference inlier count (slowly decaying maximum)
  std::vector<uint32_t> inliers;   // feature IDs that support the region (sorted)
  std::vector<uint32_t> outliers;  // feature IDs inside it that move differently (sorted)
  std::vector<uint32_t> background;  // feature IDs near it seen moving with the camera while it moved on its own (sorted)
  cv::Point2d inlier_centroid;     // px
  cv::Size2d inlier_extent;        // px; 3.3 standard deviations of the inliers in x and y (0 without inliers)
  int coast_frames = 0;            // consecutive frames predicted without support
  double frame_interval = 0;       // s; the "frame" of the velocities (the usual interval; 0 until known)
  std::string reason;              // why the region is lost, or how it was re-acquired on this frame
  RegionAppearance appearance;     // its look (invalid without images, or for a flat box)
  RegionAppearance first_appearance;  // its look at placement (checks the template's updates)
  RegionFilter filter;             // its discriminative look (appearance_filter; invalid without it)
  double filter_peak = 0;          // the filter's usual peak when sure (0: not yet)
  cv::Size2d filter_size;          // px; the size its filter last checked the box's at (findByFilter(); at placement, re-acquisition)
  int filter_unlearned = 0;        // frames since its filter last learned
  int filter_wait = 0;             // look turns until its filter's next (kFilterBudget); -1: not yet given its turns
  double appearance_score = -1;    // NCC of the look at this frame's box (-1: not checked)
  int appearance_misses = 0;       // consecutive checks it did not look like itself
  int stretch_run = 0;             // tries in a row its look matched better stretched (> 0: wider, < 0: taller)
  int size_run = 0;                // the same, larger (> 0) or smaller (< 0) at the same aspect
  int stretch_wait = -1;           // strong look checks until its look next tries the box's shape; -1: not yet
                                   // staggered (by id)
  cv::Size2d look_size;            // px; its box's size when its look was last confirmed (a lost region whose
                                   // box drifted beyond 1.1x of it is searched at that size too)
  int lost_frames = 0;             // frames since it was lost
  int found_frames = -1;           // frames since it was found again by its look (-1: never, or more than
                                   // RegionTracker::kFoundSizeFrames ago)
  int look_wait = 0;               // frames until its look's next turn (appearance_budget); -1: not yet given its turns
  int look_age = 0;                // frames since its look was last checked
  std::vector<cv::Point2f> own_points;  // its own features at this frame (px), see region_features.h
  std::vector<uint32_t> own_ids;        // their ids (from kOwnFeatureIdBase)
  uint32_t next_own_id = 0;

  static RegionState start(uint32_t id, const cv::Rect2d& box, double stamp);
  // The axis-aligned box around the region as seen: `box` turned by `angle`
  // (what the outputs report; the box given when it has not turned since).
  cv::Rect2d extent() const;
  // The state with its direction of travel reversed (velocities negated).
  RegionState reversed() const;
};

// Says when a region is lost and when it is tracked again, once per change,
// from its states in frame order (the live nodelet logs it, track_bag notes
// it). Not thread-safe.
class RegionLossLog {
 public:
  // "region <id> lost at stamp <s>: <reason>", "region <id> tracked again
  // at stamp <s>: <reason>", or "" when `s` changes nothing.
  std::string update(const RegionState& s);
  void forget(uint32_t id) { lost_.erase(id); }  // a removed region
  void clear() { lost_.clear(); }

 private:
  std::set<uint32_t> lost_;
};

// The whole-frame pyramids of a region step's two frames, for the region's
// own features (RegionTracker::step()).
struct FramePyramids {
  const std::vector<cv::Mat>* state_image = nullptr;
  const std::vector<cv::Mat>* image = nullptr;
};

class RegionTracker {
 public:
  // `regions`: how many regions share the frames (the look's turns,
  // appearance_budget).
  RegionTracker(const RegionTrackerOptions& options, cv::Size image_size, size_t regions = 1)
      : options_(options),
        image_size_(image_size),
        regions_(regions),
        look_interval_(lookInterval(options, regions)),
        filter_interval_(filterInterval(options, regions)) {}
  // Frames between the turns of a firmly carried region's look check when
  // `regions` share the frames: ceil(regions / appearance_budget), at least 1.
  static int lookInterval(const RegionTrackerOptions& options, size_t regions);
  // Look turns between a region's filter asks (findByFilter()): the regions
  // checked per frame (appearance_budget) over kFilterBudget, rounded up.
  static int filterInterval(const RegionTrackerOptions& options, size_t regions);
  static constexpr int kFilterBudget = 2;

  // Advances `state` by one frame. Forward: `md` is the motion data of the
  // next frame (it describes previous -> md). Backward: `md` is the motion
  // data of the state's own frame, and the result belongs to the frame
  // before it (`prev_stamp`). `image`: the gray frame the result belongs to
  // (CV_8UC1, the motion data's size), or empty for motion data alone.
  // `state_image`: the gray frame of `state` (with `image`, the region's own
  // features are tracked between the two). `pyramids`: the two frames'
  // whole-frame pyramids for those features, shared by many regions
  // (RegionManager), or none (each region builds its own crops').
  RegionState step(const RegionState& state, const MotionData& md, Direction dir, double prev_stamp = 0,
                   const cv::Mat& image = cv::Mat(), const cv::Mat& state_image = cv::Mat(),
                   const FramePyramids& pyramids = FramePyramids()) const;
  // Takes the region's look and its own features from `image`, the frame of
  // its box, whose motion data `md` has features of its own (no-op without
  // an image; no look when appearance is off or the box is flat).
  void initFromImage(RegionState* state, const cv::Mat& image, const MotionData& md) const;
  // Ids of the regions' own features start here (the motion analysis's are below).
  static constexpr uint32_t kOwnFeatureIdBase = 0x80000000u;
  // The turn (rad) at which the reported extent takes half of a region's
  // turn (RegionState::extent()): about twice the look's turn step.
  static constexpr double kReportedTurn = 0.1;

  const RegionTrackerOptions& options() const { return options_; }
  cv::Size imageSize() const { return image_size_; }
  size_t regions() const { return regions_; }

 private:
  bool usable(const cv::Mat& image) const;
  // The confidence a look's correlation `score` gives (0 at
  // appearance_lost_score, 1 at a perfect match).
  double lookConfidence(double score) const;
  // How far the look moves a region toward what it saw (its place, its
  // turn): all the way when the motion step had no support of its own,
  // else appearance_gain times (1 - the features' confidence), taken for
  // every frame since the look was last checked (appearance_budget).
  double lookGain(const RegionState& state, bool motion_weak, double motion_confidence) const;
  // The motion step; with both images, the region's own features are tracked
  // too (`own`: those that were) and join the fit.
  RegionState stepMotion(const RegionState& state, const MotionData& md, Direction dir, double prev_stamp,
                         const cv::Mat& from_image, const cv::Mat& to_image, const FramePyramids& pyramids,
                         std::vector<OwnFeature>* own) const;
  // Tops the region's own features up to region_features, counting the
  // `motion_features` the motion analysis has inside its box.
  void addOwnFeatures(RegionState* state, const cv::Mat& image, int motion_features) const;
  // The appearance check after the motion step (`motion_weak`: the step had
  // no support of its own), and the search for a lost region.
  // `filter_sure`: its filter found it on this turn (FilterFind), and its
  // look does not count against it.
  void checkAppearance(const RegionState& state, RegionState* next, bool motion_weak, const cv::Mat& image,
                       bool filter_sure) const;
  // A region's look turn: its filter (on the filter's turn), then its
  // template's check, then the filter's move and learning; `next`'s look_age
  // restarts.
  void lookTurn(const RegionState& state, RegionState* next, bool motion_weak, const cv::Mat& image) const;
  // What a region's filter said on its turn: whether its find was sure,
  // the move it asks of the box (zero unless sure), and the find's
  // peak-to-sidelobe ratio (0: not asked, or nothing found).
  struct FilterFind {
    bool sure = false;
    cv::Point2d move;
    double psr = 0;
  };
  // The filter's correction of the region's place after the motion step,
  // where its features carry it weakly (region_filter.h): on a sure find,
  // kFilterGain times as far as the look moves it
  // (lookGain()), applied by step() when the template's check did not move
  // it (its clear match is to the pixel). A region found so is seen (not
  // coasting), and is not lost by its template's look (a walker's template
  // stops matching him within a few steps). After the look's check,
  // learnFilter() teaches it the region's place. It also checks the
  // features' scale against the size it last checked (filter_size), and
  // may set the box back to that size.
  FilterFind findByFilter(const RegionState& state, RegionState* next, bool motion_weak, const cv::Mat& image) const;
  void learnFilter(RegionState* next, const cv::Mat& image, const FilterFind& find) const;
  // A sure find: a peak-to-sidelobe ratio of kFilterSurePsr or more, and a
  // peak of at least kFilterSurePeak times its usual (a running mean over
  // sure finds, kFilterPeakRate a find). It learns only from finds with a
  // ratio of kFilterLearnPsr, at kFilterRate a frame (CSR-DCF's). It moves
  // regions whose motion confidence is under kFilterFirmlyCarried.
  // Measured on the real sequences and the presets: docs/benchmarks.md,
  // "A discriminative look".
  static constexpr double kFilterSurePsr = 6.0;
  static constexpr double kFilterSurePeak = 0.4;
  static constexpr double kFilterPeakRate = 0.1;
  static constexpr double kFilterLearnPsr = 8.0;
  static constexpr double kFilterRate = 0.02;
  static constexpr int kFilterLearnEvery = 2;
  static constexpr double kFilterGain = 0.5;
  static constexpr double kFilterFirmlyCarried = 0.5;
  // The size drift (a factor, either way) at which the filter checks the
  // features' scale, and the margin by which the size it last checked must
  // peak higher to be kept back ("The features' scale checked by the
  // filter" in docs/benchmarks.md).
  static constexpr double kFilterSizeCheck = 1.05;
  static constexpr double kFilterSizeMargin = 0.03;
  // The speed against the background (a fraction of the box's size, the
  // geometric mean of its sides, per frame) under which a region its
  // template matches strongly is held where its motion put it (lookTurn()).
  static constexpr double kFilterStillShare = 0.0025;
  void reacquire(RegionState* next, const cv::Mat& image) const;
  // The look's correction of the region's turn, around its best match `m`.
  void turnByLook(const RegionState& state, RegionState* next, const AppearanceMatch& m, bool motion_weak,
                  double motion_confidence, const cv::Mat& image) const;
  // The turns the look tries either way of the region's (rad), and the
  // reach of those matches around its best place (a fraction of its sides).
  static constexpr double kLookTurnStep = 0.05;
  static constexpr double kLookTurnMargin = 0.05;
  // The look's correction of the box's aspect (width / height at the same
  // area), around its best match `m`: the features' fit has one scale for
  // both sides, so only the look sees a target turn broadside. And of its
  // size, where the features carry it weakly (`motion_confidence` under
  // kFirmlyCarried): a few features' scale is noisy, and a region found
  // again takes its size from a coarse search.
  void reshapeByLook(RegionState* next, const AppearanceMatch& m, double motion_confidence,
                     const cv::Mat& image) const;
  // A region found again by its look, on its look checks for
  // kFoundSizeFrames frames after (found_frames), however firmly its
  // features carry it: its box grown by 5% or 10% where its look at
  // placement matches that better. Found while still partly hidden, it
  // matched a smaller box best, and its features keep whatever size it
  // has (region_hidden among 99 others, seeds 6-8: 10% too small for the
  // rest of the run). Only larger: a perspective view often matches a
  // smaller box best, and shrinking too cost seed 1 0.05.
  void checkFoundSize(RegionState* next, const cv::Mat& image) const;
  static constexpr int kFoundSizeFrames = 30;
  // The aspects and sizes the look tries either way (log: at the same area
  // each side about 2.5%, at the same aspect 5%), and how much of that step
  // a try that counts takes (1.5% of the aspect or size).
  static constexpr double kLookStretchStep = 0.05;
  static constexpr double kLookStretchGain = 0.3;
  static constexpr int kLookStretchRun = 3;    // tries in a row before it counts
  static constexpr int kLookStretchEvery = 3;  // a try every this many strong look checks (staggered by id)
  // The motion confidence at which the features carry a region firmly: its
  // look learns without the look at placement's consent (and on half
  // matches, from appearance_lost_score), and its size is theirs alone.
  static constexpr double kFirmlyCarried = 0.75;

  RegionTrackerOptions options_;
  cv::Size image_size_;
  size_t regions_ = 1;     // the regions sharing the frames
  int look_interval_ = 1;  // lookInterval() for them
  int filter_interval_ = 1;  // filterInterval() for them
};

}  // namespace imt
