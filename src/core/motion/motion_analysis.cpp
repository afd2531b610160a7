// Motion analysis (paper 3.1): input checks and resets, downscaling to the
// analysis resolution, feature tracking (FeatureTracker), camera motion
// (CameraMotionEstimator) with temporal priors, and the per-feature
// foreground/background classification, packed as MotionData in
// full-resolution pixels (origin at the top-left corner of the top-left pixel).
#include "instant_motion_tracking/core/motion/motion_analysis.h"

#include "instant_motion_tracking/core/motion/camera_motion_estimator.h"
#include "instant_motion_tracking/core/motion/feature_tracker.h"

#include "area_resize.h"
#include "option_checker.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace imt {
namespace {

// Frames smaller than this (either side, px) are not analysed: there is no
// room for a Lucas-Kanade window and a corner neighbourhood.
constexpr int kMinSide = 16;

// Per-feature state carried to the next frame (aligned with the tracks).
struct FeatureState {
  float bg_weight = 1.f;
  float rx = 0.f, ry = 0.f;  // smoothed residual (full-res px)
  bool has_residual = false;
};

}  // namespace

struct MotionAnalyzer::Impl {
  explicit Impl(const MotionAnalysisOptions& o) : options(o), tracker(o), estimator(o) {}

  void resetTracks() {
    tracker.reset();
    state.clear();
    has_frame = false;
    last_interval = 0;
    has_H = false;
  }

  MotionAnalysisOptions options;
  FeatureTracker tracker;
  CameraMotionEstimator estimator;
  cv::Size size;
  double last_stamp = 0;
  double last_interval = 0;  // s between the last two frames (0: none yet)
  bool has_frame = false;
  std::string last_reset;
  Eigen::Matrix3d last_H = Eigen::Matrix3d::Identity();
  bool has_H = false;
  cv::Mat small, halves[2];
  AreaResize area;  // what is left after the halvings
  std::vector<FeatureState> state, next_state;
  // Scratch.
  std::vector<cv::Point2f> prev_px, cur_px;
  std::vector<float> prior;
  std::vector<int> moving;  // track indices with age >= 1, in prev_px/cur_px order
  std::vector<float> cell_bg_sum;
  std::vector<int> cell_bg_n;
  Diagnostics diagnostics;
};

MotionAnalyzer::MotionAnalyzer(const MotionAnalysisOptions& options) : impl_(new Impl(validated(options))) {}
MotionAnalyzer::~MotionAnalyzer() = default;
MotionAnalyzer::MotionAnalyzer(MotionAnalyzer&&) noexcept = default;
MotionAnalyzer& MotionAnalyzer::operator=(MotionAnalyzer&&) noexcept = default;

void MotionAnalyzer::reset() { impl_->resetTracks(); }
const std::string& MotionAnalyzer::lastReset() const { return impl_->last_reset; }
const MotionAnalysisOptions& MotionAnalyzer::options() const { return impl_->options; }
const MotionAnalyzer::Diagnostics& MotionAnalyzer::diagnostics() const {
  return impl_->diagnostics;
}

MotionData MotionAnalyzer::process(const cv::Mat& gray, double stamp) {
  Impl& s = *impl_;
  const MotionAnalysisOptions& o = s.options;
  s.last_reset.clear();
  s.diagnostics = Diagnostics();
  MotionData md;
  md.stamp = stamp;
  md.width = gray.cols;
  md.height = gray.rows;

  // --- input checks: bad frames reset and come out invalid, never throw ---
  std::string bad;
  if (gray.empty()) {
    bad = "empty image";
  } else if (gray.type() != CV_8UC1) {
    bad = "unsupported image type (expected 8-bit single channel)";
  } else if (gray.cols < kMinSide || gray.rows < kMinSide) {
    std::ostringstream os;
    os << "image too small (" << gray.cols << "x" << gray.rows << ")";
    bad = os.str();
  }
  if (!bad.empty()) {
    s.last_reset = bad;
    s.resetTracks();
    return md;
  }
  if (s.has_frame && gray.size() != s.size) {
    std::ostringstream os;
    os << "frame size changed (" << s.size.width << "x" << s.size.height << " -> " << gray.cols
       << "x" << gray.rows << ")";
    s.last_reset = os.str();
    s.resetTracks();
  } else if (s.has_frame && !(stamp > s.last_stamp)) {
    s.last_reset = "stamp did not increase";
    s.resetTracks();
  }
  // This frame's interval over the last one (> 1 after dropped frames).
  double interval_ratio = 1.0;
  if (s.has_frame) {
    const double interval = stamp - s.last_stamp;
    if (s.last_interval > 0) interval_ratio = interval / s.last_interval;
    s.last_interval = interval;
  }
  s.size = gray.size();
  s.last_stamp = stamp;
  s.has_frame = true;

  // --- analysis resolution (never upscaled) ---
  const int aw =
      (o.analysis_width > 0 && o.analysis_width < gray.cols) ? o.analysis_width : gray.cols;
  const int ah = aw == gray.cols
                     ? gray.rows
                     : std::max(std::min(gray.rows, kMinSide),
                                static_cast<int>(std::lround(gray.rows * double(aw) / gray.cols)));
  const cv::Mat* analysed = &gray;
  if (aw != gray.cols || ah != gray.rows) {
    // Exact halvings first: OpenCV's area resize is ~10x faster for a factor
    // of exactly 2 than for a general factor (1280x720 -> 320x180: 0.09 ms
    // for two halvings, 0.7 ms at once), and box filters compose, so the
    // result and the pixel mapping below are the same. The rest of the way
    // (480x640 -> 320x427: a factor of 1.5) by AreaResize, the same area
    // average in a fraction of OpenCV's time (area_resize.h).
    const cv::Mat* src = &gray;
    int k = 0;
    while (src->cols % 2 == 0 && src->rows % 2 == 0 && src->cols >= 2 * aw && src->rows >= 2 * ah) {
      cv::Mat& dst = s.halves[k++ % 2];
      cv::resize(*src, dst, cv::Size(src->cols / 2, src->rows / 2), 0, 0, cv::INTER_AREA);
      src = &dst;
    }
    if (src->cols != aw || src->rows != ah) {
      s.area.apply(*src, cv::Size(aw, ah), &s.small);
      src = &s.small;
    }
    analysed = src;
  }
  // Analysis pixel (centre at integer x) -> full-resolution position in our
  // convention: pixel i of the analysis frame covers [i, i+1) * scale.
  const float sx = static_cast<float>(gray.cols) / aw, sy = static_cast<float>(gray.rows) / ah;
  md.analysis_scale = std::max(sx, sy);
  auto toFull = [sx, sy](const cv::Point2f& p) {
    return cv::Point2f((p.x + 0.5f) * sx, (p.y + 0.5f) * sy);
  };

  s.tracker.track(*analysed, interval_ratio);
  const std::vector<FeatureTrack>& tracks = s.tracker.tracks();

  // --- camera motion from the tracked features, favouring last frame's background ---
  s.prev_px.clear();
  s.cur_px.clear();
  s.prior.clear();
  s.moving.clear();
  const float lambda = static_cast<float>(o.temporal_prior);
  for (size_t i = 0; i < tracks.size(); ++i) {
    const FeatureTrack& t = tracks[i];
    if (t.age == 0 || t.prev_index < 0) continue;
    s.prev_px.push_back(toFull(t.prev));
    s.cur_px.push_back(toFull(t.cur));
    const float bg =
        t.prev_index < static_cast<int>(s.state.size()) ? s.state[t.prev_index].bg_weight : 1.f;
    s.prior.push_back((1.f - lambda) + lambda * bg);
    s.moving.push_back(static_cast<int>(i));
  }
  s.diagnostics.tracking = s.tracker.stats();
  s.diagnostics.estimate = s.estimator.estimate(s.prev_px, s.cur_px, s.prior, gray.size(),
                                                s.has_H ? &s.last_H : nullptr);
  const CameraMotionEstimate& est = s.diagnostics.estimate;
  md.camera = est.motion;
  const bool valid = est.motion.model != MotionModel::kInvalid;
  s.has_H = valid;
  if (valid) s.last_H = est.motion.H;
  const Eigen::Matrix3d& H = md.camera.H;

  // --- foreground / background per feature ---
  const double diag = std::hypot(gray.cols, gray.rows);
  const float fg_scale = static_cast<float>(o.foreground_residual * diag);
  const float decay = static_cast<float>(o.residual_decay);
  s.next_state.assign(tracks.size(), FeatureState());
  md.features.resize(tracks.size());
  const int cells = o.grid_cols * o.grid_rows;
  s.cell_bg_sum.assign(cells, 0.f);
  s.cell_bg_n.assign(cells, 0);
  for (size_t k = 0; k < s.moving.size(); ++k) {
    const int i = s.moving[k];
    const FeatureTrack& t = tracks[i];
    const cv::Point2f& p = s.prev_px[k];
    const cv::Point2f& c = s.cur_px[k];
    const double w = H(2, 0) * p.x + H(2, 1) * p.y + H(2, 2);
    const float px = static_cast<float>((H(0, 0) * p.x + H(0, 1) * p.y + H(0, 2)) / w);
    const float py = static_cast<float>((H(1, 0) * p.x + H(1, 1) * p.y + H(1, 2)) / w);
    FeatureMotion& f = md.features[i];
    f.id = t.id;
    f.x = c.x;
    f.y = c.y;
    f.dx = c.x - px;
    f.dy = c.y - py;
    f.age = t.age;
    f.patch_error = t.patch_error;
    FeatureState& ns = s.next_state[i];
    if (valid) {
      // Accumulated residual (decaying sum): a slowly but steadily moving
      // object builds up r / (1 - decay), while zero-mean tracking noise
      // grows only by 1 / sqrt(1 - decay^2).
      const FeatureState* ps =
          t.prev_index < static_cast<int>(s.state.size()) ? &s.state[t.prev_index] : nullptr;
      if (ps && ps->has_residual) {
        ns.rx = decay * ps->rx + f.dx;
        ns.ry = decay * ps->ry + f.dy;
      } else {
        ns.rx = f.dx;
        ns.ry = f.dy;
      }
      ns.has_residual = true;
      const float e2 = (ns.rx * ns.rx + ns.ry * ns.ry) / (fg_scale * fg_scale);
      ns.bg_weight = 1.f / (1.f + e2);
    } else {
      ns.bg_weight = 1.f;  // no background model: nothing to compare with
    }
    f.bg_weight = ns.bg_weight;
    f.foreground = f.bg_weight < o.foreground_threshold;
    const int cell = s.tracker.gridCell(t.cur);
    s.cell_bg_sum[cell] += ns.bg_weight;
    ++s.cell_bg_n[cell];
  }
  // New features have no motion yet: they take their cell's background
  // weight (the grid prior), 1 where nothing is known.
  for (size_t i = 0; i < tracks.size(); ++i) {
    const FeatureTrack& t = tracks[i];
    if (t.age != 0 && t.prev_index >= 0) continue;
    FeatureMotion& f = md.features[i];
    const cv::Point2f c = toFull(t.cur);
    f.id = t.id;
    f.x = c.x;
    f.y = c.y;
    f.dx = f.dy = 0.f;
    f.age = 0;
    const int cell = s.tracker.gridCell(t.cur);
    f.bg_weight = s.cell_bg_n[cell] > 0 ? s.cell_bg_sum[cell] / s.cell_bg_n[cell] : 1.f;
    f.foreground = f.bg_weight < o.foreground_threshold;
    s.next_state[i].bg_weight = f.bg_weight;
  }
  s.state.swap(s.next_state);
  return md;
}

}  // namespace imt
