// Grid-spread corner features tracked frame to frame with pyramidal
// Lucas-Kanade (part of the motion analysis, paper 3.1).
//
// Each frame: one image pyramid is built (and kept as the next frame's
// "previous" pyramid); every feature is tracked forward, starting from its own
// last velocity; a subset is verified by tracking back (new tracks, tracks
// with a large patch error or acceleration, and every track at least every
// `fb_check_interval` frames); lost features are dropped and, every
// `detect_interval` frames (at once when too few survive), minimum-eigenvalue
// corners are detected only in the grid cells that lack features.
//
// Works at analysis resolution in OpenCV's pixel convention (pixel centres at
// integer coordinates); MotionAnalyzer maps the positions to full resolution.
//
// Usage:
//   imt::FeatureTracker tracker(options);
//   tracker.track(gray_small);                    // every frame, same size
//   for (const imt::FeatureTrack& f : tracker.tracks()) { ... f.prev -> f.cur ... }
// Threading: not thread-safe; one tracker per image stream.
#pragma once

#include "instant_motion_tracking/core/options.h"

#include <opencv2/core.hpp>

#include <cstdint>
#include <vector>

namespace imt {

// One feature path in the current frame.
struct FeatureTrack {
  uint32_t id = 0;      // unique over the tracker's life (also across reset())
  cv::Point2f prev;     // position in the previous frame (== cur when age == 0)
  cv::Point2f cur;      // position in the current frame
  uint16_t age = 0;     // frames tracked; 0 = detected in this frame (no motion yet)
  int prev_index = -1;  // index of this track in the previous frame's tracks(), -1 when new
  // LK's patch error of the step into `cur` (the mean absolute grey-level
  // difference over its window at the tracking resolution); 0 when new.
  float patch_error = 0;
};

class FeatureTracker {
 public:
  // What the last track() call did (for tests, benchmarks and logs).
  struct Stats {
    int tracked = 0;     // features tracked from the previous frame and kept
    int lost_lk = 0;     // dropped: LK failed or left the frame
    int lost_fb = 0;     // dropped: forward-backward check failed
    int fb_checked = 0;  // tracks that were tracked back
    int pruned = 0;      // dropped: too many in their grid cell
    int detected = 0;    // new features
    bool detection_ran = false;
  };

  explicit FeatureTracker(const MotionAnalysisOptions& options);

  // Tracks the features into `image` (CV_8UC1; the same size on every call
  // until reset()) and refills under-filled grid cells. `interval_ratio` is
  // this frame's time since the previous one over the previous frame's: each
  // track's predicted position (its last motion) is scaled by it, so dropped
  // frames (ratio 2, 3, ...) do not leave fast features beyond LK's reach.
  void track(const cv::Mat& image, double interval_ratio = 1.0);
  // Forgets the features and the previous frame; IDs keep counting up.
  void reset();

  const std::vector<FeatureTrack>& tracks() const { return tracks_; }
  const Stats& stats() const { return stats_; }
  int gridCell(const cv::Point2f& p) const;  // cell index of an analysis-resolution position

 private:
  void trackForward(float interval_ratio);
  void verifyBackward();
  void pruneCrowdedCells();
  void detect(const cv::Mat& image);

  MotionAnalysisOptions options_;
  int levels_ = 0;  // pyramid levels actually used (fewer for small frames)
  cv::Size size_;
  std::vector<cv::Mat> prev_pyr_, cur_pyr_;
  std::vector<FeatureTrack> tracks_;
  uint32_t next_id_ = 1;
  int64_t frame_ = 0;
  int frames_since_detect_ = 0;
  Stats stats_;
  std::vector<int> cell_backoff_;  // detections to skip per cell after it yielded nothing

  // Scratch buffers kept between frames to avoid reallocations.
  std::vector<cv::Point2f> pts_prev_, pts_cur_, pts_back_, guesses_;
  std::vector<uchar> status_;
  std::vector<float> err_;
  std::vector<int> check_idx_;
  std::vector<FeatureTrack> next_tracks_;
  std::vector<std::vector<int>> cell_members_;
  std::vector<char> drop_;
  cv::Mat eig_;
};

}  // namespace imt
