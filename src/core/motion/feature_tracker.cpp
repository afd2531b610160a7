#include "instant_motion_tracking/core/motion/feature_tracker.h"
#include "instant_motion_tracking/core/types.h"
#include "motion/min_eigenvalues.h"

#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cmath>
#include <limits>

namespace imt {
namespace {

// A track whose acceleration differs from the median acceleration of all
// tracks by more than this (analysis px per frame^2) is verified by tracking
// back. Well above the LK noise (~0.05 px); shake moves all tracks alike, so
// mostly slips, occlusions and independently moving objects trigger it.
constexpr float kAccelerationGate = 1.0f;
// A track whose LK patch error exceeds this multiple of the frame's median is
// verified too (occlusions and lighting jumps raise the patch error).
constexpr float kPatchErrorGate = 2.0f;
// LK stops iterating once an update is smaller than this (analysis px).
constexpr double kLkEpsilon = 0.01;
// Detection rounds a grid cell is skipped after it yielded no corner.
constexpr int kEmptyCellBackoff = 3;

float dist2(const cv::Point2f& a, const cv::Point2f& b) {
  const cv::Point2f d = a - b;
  return d.x * d.x + d.y * d.y;
}

}  // namespace

FeatureTracker::FeatureTracker(const MotionAnalysisOptions& options) : options_(options) {}

void FeatureTracker::reset() {
  tracks_.clear();
  prev_pyr_.clear();
  cur_pyr_.clear();
  size_ = cv::Size();
  frames_since_detect_ = 0;
  cell_backoff_.clear();
  stats_ = Stats();
}

int FeatureTracker::gridCell(const cv::Point2f& p) const {
  const int cx = std::clamp(static_cast<int>(p.x * options_.grid_cols / std::max(1, size_.width)),
                            0, options_.grid_cols - 1);
  const int cy = std::clamp(static_cast<int>(p.y * options_.grid_rows / std::max(1, size_.height)),
                            0, options_.grid_rows - 1);
  return cy * options_.grid_cols + cx;
}

void FeatureTracker::track(const cv::Mat& image, double interval_ratio) {
  CV_Assert(image.type() == CV_8UC1 && !image.empty());
  stats_ = Stats();
  ++frame_;
  if (image.size() != size_) {
    reset();
    size_ = image.size();
  }
  const cv::Size win(options_.lk_window, options_.lk_window);
  // Level 0 is copied (tryReuseInputImage = false): the caller may reuse its
  // buffer for the next frame while this pyramid serves as the previous one.
  levels_ = cv::buildOpticalFlowPyramid(image, cur_pyr_, win, options_.lk_levels,
                                        /*withDerivatives=*/true, cv::BORDER_REFLECT_101,
                                        cv::BORDER_CONSTANT,
                                        /*tryReuseInputImage=*/false);
  if (!prev_pyr_.empty() && !tracks_.empty()) {
    trackForward(static_cast<float>(boundedIntervalRatio(interval_ratio)));
    verifyBackward();
  } else {
    tracks_.clear();
  }
  pruneCrowdedCells();
  detect(image);
  std::swap(prev_pyr_, cur_pyr_);
}

void FeatureTracker::trackForward(float interval_ratio) {
  const size_t n = tracks_.size();
  pts_prev_.resize(n);
  pts_cur_.resize(n);
  // Initial guess: each track's own last velocity; new tracks take the median
  // velocity of the others (robust to foreground). Both scaled to this
  // frame's interval.
  std::vector<float> vx, vy;
  vx.reserve(n);
  vy.reserve(n);
  for (const FeatureTrack& t : tracks_) {
    if (t.age > 0) {
      vx.push_back(t.cur.x - t.prev.x);
      vy.push_back(t.cur.y - t.prev.y);
    }
  }
  cv::Point2f median_v(0, 0);
  if (!vx.empty()) {
    std::nth_element(vx.begin(), vx.begin() + vx.size() / 2, vx.end());
    std::nth_element(vy.begin(), vy.begin() + vy.size() / 2, vy.end());
    median_v = cv::Point2f(vx[vx.size() / 2], vy[vy.size() / 2]);
  }
  const float max_x = size_.width - 1.f, max_y = size_.height - 1.f;
  for (size_t i = 0; i < n; ++i) {
    const FeatureTrack& t = tracks_[i];
    pts_prev_[i] = t.cur;
    const cv::Point2f v = interval_ratio * (t.age > 0 ? t.cur - t.prev : median_v);
    pts_cur_[i] =
        cv::Point2f(std::clamp(t.cur.x + v.x, 0.f, max_x), std::clamp(t.cur.y + v.y, 0.f, max_y));
  }
  guesses_ = pts_cur_;
  const cv::Size win(options_.lk_window, options_.lk_window);
  const cv::TermCriteria crit(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                              options_.lk_iterations, kLkEpsilon);
  cv::calcOpticalFlowPyrLK(prev_pyr_, cur_pyr_, pts_prev_, pts_cur_, status_, err_, win, levels_,
                           crit, cv::OPTFLOW_USE_INITIAL_FLOW);

  // Median patch error of the successful tracks, for the suspicion gate.
  std::vector<float> errs;
  errs.reserve(n);
  for (size_t i = 0; i < n; ++i)
    if (status_[i]) errs.push_back(err_[i]);
  float err_gate = std::numeric_limits<float>::max();
  if (!errs.empty()) {
    std::nth_element(errs.begin(), errs.begin() + errs.size() / 2, errs.end());
    err_gate = kPatchErrorGate * errs[errs.size() / 2];
  }

  // The crowd's acceleration (median over tracks with a velocity): camera
  // shake accelerates every track alike and is no reason for suspicion.
  vx.clear();
  vy.clear();
  for (size_t i = 0; i < n; ++i) {
    if (!status_[i] || tracks_[i].age == 0) continue;
    vx.push_back(pts_cur_[i].x - guesses_[i].x);
    vy.push_back(pts_cur_[i].y - guesses_[i].y);
  }
  cv::Point2f median_a(0, 0);
  if (!vx.empty()) {
    std::nth_element(vx.begin(), vx.begin() + vx.size() / 2, vx.end());
    std::nth_element(vy.begin(), vy.begin() + vy.size() / 2, vy.end());
    median_a = cv::Point2f(vx[vx.size() / 2], vy[vy.size() / 2]);
  }

  next_tracks_.clear();
  check_idx_.clear();
  const int interval = options_.fb_check_interval;
  for (size_t i = 0; i < n; ++i) {
    const cv::Point2f& p = pts_cur_[i];
    const bool inside = p.x >= 0.f && p.y >= 0.f && p.x <= max_x && p.y <= max_y;
    if (!status_[i] || !inside || !std::isfinite(p.x) || !std::isfinite(p.y)) {
      ++stats_.lost_lk;
      continue;
    }
    const FeatureTrack& t = tracks_[i];
    FeatureTrack nt;
    nt.id = t.id;
    nt.prev = t.cur;
    nt.cur = p;
    nt.age =
        t.age == std::numeric_limits<uint16_t>::max() ? t.age : static_cast<uint16_t>(t.age + 1);
    nt.prev_index = static_cast<int>(i);
    nt.patch_error = std::isfinite(err_[i]) ? err_[i] : 0.f;
    const bool suspicious =
        t.age == 0 || (t.id + frame_) % interval == 0 || err_[i] > err_gate ||
        dist2(p, guesses_[i] + median_a) > kAccelerationGate * kAccelerationGate;
    if (suspicious) check_idx_.push_back(static_cast<int>(next_tracks_.size()));
    next_tracks_.push_back(nt);
  }
  tracks_.swap(next_tracks_);
}

void FeatureTracker::verifyBackward() {
  const size_t m = check_idx_.size();
  stats_.fb_checked = static_cast<int>(m);
  if (m > 0) {
    pts_cur_.resize(m);
    pts_back_.resize(m);
    // Tracked back from where the forward guess's displacement undone puts
    // it: near the previous position when the forward match is right, so a
    // long (fast or dropped-frame) jump is checked as reliably as a short one.
    for (size_t k = 0; k < m; ++k) {
      const FeatureTrack& t = tracks_[check_idx_[k]];
      pts_cur_[k] = t.cur;
      const cv::Point2f guess_shift = t.prev_index >= 0 ? guesses_[t.prev_index] - t.prev : cv::Point2f();
      pts_back_[k] = t.cur - guess_shift;
    }
    const cv::Size win(options_.lk_window, options_.lk_window);
    const cv::TermCriteria crit(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                options_.lk_iterations, kLkEpsilon);
    cv::calcOpticalFlowPyrLK(cur_pyr_, prev_pyr_, pts_cur_, pts_back_, status_, err_, win, levels_,
                             crit, cv::OPTFLOW_USE_INITIAL_FLOW);
    const float max_err2 = static_cast<float>(options_.fb_max_error * options_.fb_max_error);
    drop_.assign(tracks_.size(), 0);
    for (size_t k = 0; k < m; ++k) {
      const FeatureTrack& t = tracks_[check_idx_[k]];
      if (!status_[k] || !(dist2(pts_back_[k], t.prev) <= max_err2)) drop_[check_idx_[k]] = 1;
    }
    size_t w = 0;
    for (size_t i = 0; i < tracks_.size(); ++i) {
      if (drop_[i]) {
        ++stats_.lost_fb;
        continue;
      }
      tracks_[w++] = tracks_[i];
    }
    tracks_.resize(w);
  }
  stats_.tracked = static_cast<int>(tracks_.size());
}

void FeatureTracker::pruneCrowdedCells() {
  if (tracks_.empty()) return;
  // Tracks that converge (zoom out, features dragged along an occluding edge)
  // are thinned: of two closer than half the minimum distance the younger
  // goes, and no grid cell keeps more than twice its share.
  const int cells = options_.grid_cols * options_.grid_rows;
  const int share = (options_.max_features + cells - 1) / cells;
  std::vector<std::vector<int>>& members = cell_members_;
  members.resize(cells);
  for (std::vector<int>& m : members) m.clear();
  for (size_t i = 0; i < tracks_.size(); ++i)
    members[gridCell(tracks_[i].cur)].push_back(static_cast<int>(i));
  std::vector<char>& drop = drop_;
  drop.assign(tracks_.size(), 0);
  const float close2 = static_cast<float>(0.25 * options_.min_distance * options_.min_distance);
  const auto older = [&](int a, int b) {
    return tracks_[a].age > tracks_[b].age || (tracks_[a].age == tracks_[b].age && a < b);
  };
  for (int c = 0; c < cells; ++c) {
    std::vector<int>& mem = members[c];
    std::sort(mem.begin(), mem.end(), older);
    int kept = 0;
    for (size_t a = 0; a < mem.size(); ++a) {
      const int ia = mem[a];
      bool crowded = kept >= 2 * share;
      for (size_t b = 0; b < a && !crowded; ++b)
        if (!drop[mem[b]] && dist2(tracks_[ia].cur, tracks_[mem[b]].cur) < close2) crowded = true;
      if (crowded) {
        drop[ia] = 1;
        ++stats_.pruned;
      } else {
        ++kept;
      }
    }
  }
  if (stats_.pruned == 0) return;
  size_t w = 0;
  for (size_t i = 0; i < tracks_.size(); ++i)
    if (!drop[i]) tracks_[w++] = tracks_[i];
  tracks_.resize(w);
}

void FeatureTracker::detect(const cv::Mat& image) {
  const int cells = options_.grid_cols * options_.grid_rows;
  const int total = static_cast<int>(tracks_.size());
  ++frames_since_detect_;
  const bool starved = total < options_.redetect_fraction * options_.max_features;
  if (!starved && frames_since_detect_ < options_.detect_interval) return;
  if (total >= options_.max_features) return;
  frames_since_detect_ = 0;
  stats_.detection_ran = true;
  if (static_cast<int>(cell_backoff_.size()) != cells) cell_backoff_.assign(cells, 0);

  const int share = (options_.max_features + cells - 1) / cells;
  std::vector<int> count(cells, 0);
  for (const FeatureTrack& t : tracks_) ++count[gridCell(t.cur)];

  // Corners closer to the border than half the LK window would be tracked
  // with a reflected border; keep them out.
  const int margin = std::max(2, options_.lk_window / 2);
  const cv::Rect inner(margin, margin, size_.width - 2 * margin, size_.height - 2 * margin);
  if (inner.width < 3 || inner.height < 3) return;
  const float min_d2 = static_cast<float>(options_.min_distance * options_.min_distance);
  const int min_d = static_cast<int>(std::ceil(options_.min_distance));
  int budget = options_.max_features - total;

  struct Candidate {
    float response;
    cv::Point2f p;
  };
  std::vector<Candidate> cand;
  std::vector<cv::Point2f> near;
  for (int c = 0; c < cells && budget > 0; ++c) {
    if (count[c] * 2 > share) continue;  // at least half full: leave it
    if (cell_backoff_[c] > 0) {
      --cell_backoff_[c];
      continue;
    }
    const int gx = c % options_.grid_cols, gy = c / options_.grid_cols;
    const cv::Rect cell(
        gx * size_.width / options_.grid_cols, gy * size_.height / options_.grid_rows,
        (gx + 1) * size_.width / options_.grid_cols - gx * size_.width / options_.grid_cols,
        (gy + 1) * size_.height / options_.grid_rows - gy * size_.height / options_.grid_rows);
    const cv::Rect roi = cell & inner;
    if (roi.width < 1 || roi.height < 1) continue;
    // One pixel of context around the cell so that its border pixels can be
    // tested as local maxima.
    const cv::Rect ext = cv::Rect(roi.x - 1, roi.y - 1, roi.width + 2, roi.height + 2) &
                         cv::Rect(0, 0, size_.width, size_.height);
    // cv::cornerMinEigenVal(image(ext), eig_, 3, 3), a third of its time
    // on cells this small (min_eigenvalues.h).
    thread_local MinEigenvalues corner_map;
    if (!corner_map.apply(image, ext, &eig_)) continue;
    double cell_max = 0;
    cv::minMaxLoc(eig_, nullptr, &cell_max);
    const float thresh =
        static_cast<float>(std::max(options_.min_eigenvalue, options_.quality_level * cell_max));
    cand.clear();
    // The cell's pixels with all eight neighbours in the map, row by row
    // (the candidates in the same order as ever: the sort below is not
    // stable), the bounds kept out of the loop.
    const int x_lo = std::max(1, roi.x - ext.x), x_hi = std::min(eig_.cols - 1, roi.br().x - ext.x);
    const int y_lo = std::max(1, roi.y - ext.y), y_hi = std::min(eig_.rows - 1, roi.br().y - ext.y);
    for (int ey = y_lo; ey < y_hi; ++ey) {
      const float* r0 = eig_.ptr<float>(ey - 1);
      const float* r1 = eig_.ptr<float>(ey);
      const float* r2 = eig_.ptr<float>(ey + 1);
      for (int ex = x_lo; ex < x_hi; ++ex) {
        const float v = r1[ex];
        if (v < thresh) continue;
        if (v < r1[ex - 1] || v < r1[ex + 1] || v < r0[ex - 1] || v < r0[ex] || v < r0[ex + 1] ||
            v < r2[ex - 1] || v < r2[ex] || v < r2[ex + 1])
          continue;
        cand.push_back(
            {v, cv::Point2f(static_cast<float>(ex + ext.x), static_cast<float>(ey + ext.y))});
      }
    }
    if (cand.empty()) {
      cell_backoff_[c] = kEmptyCellBackoff;
      continue;
    }
    std::sort(cand.begin(), cand.end(),
              [](const Candidate& a, const Candidate& b) { return a.response > b.response; });
    const cv::Rect reach(roi.x - min_d, roi.y - min_d, roi.width + 2 * min_d,
                         roi.height + 2 * min_d);
    near.clear();
    for (const FeatureTrack& t : tracks_)
      if (reach.contains(cv::Point(static_cast<int>(t.cur.x), static_cast<int>(t.cur.y))))
        near.push_back(t.cur);
    const size_t existing = near.size();
    int want = share - count[c];
    for (const Candidate& k : cand) {
      if (want <= 0 || budget <= 0) break;
      bool free = true;
      for (const cv::Point2f& q : near)
        if (dist2(k.p, q) < min_d2) {
          free = false;
          break;
        }
      if (!free) continue;
      near.push_back(k.p);
      FeatureTrack t;
      t.id = next_id_++;
      if (next_id_ == 0) next_id_ = 1;  // 0 is never an ID
      t.prev = t.cur = k.p;
      t.age = 0;
      t.prev_index = -1;
      tracks_.push_back(t);
      --want;
      --budget;
      ++stats_.detected;
    }
    if (near.size() == existing) cell_backoff_[c] = kEmptyCellBackoff;
  }
}

}  // namespace imt
