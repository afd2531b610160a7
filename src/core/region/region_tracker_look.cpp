// The parts of the region tracker that read the frames' pixels: the region's
// own features topped up, its look taken and checked after each motion step,
// a lost region searched for (region_tracker.h); and the log of regions lost
// and tracked again.
#include "instant_motion_tracking/core/region/region_tracker.h"

#include "region_features.h"
#include "region_geometry.h"
#include "region_shape.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <vector>

namespace imt {
namespace {

// The searches a region lost for `n` frames makes on that frame (interval
// I = reacquire_interval): around its last place on every frame and over the
// whole frame every I frames, for the first 2 I frames (an occluder passing,
// a short turn away); then both every I frames up to 30 I (5 s at 30 frames/s
// with I = 5), then every 4 I. A region lost for good thus costs a search
// every 4 I frames, not every frame. `k` counts the whole-frame searches
// (which look they use alternates with it). I = 0: around its last place on
// every frame, never over the whole frame.
struct LostSearch {
  bool local = false, whole = false;
  int k = 0;
};
LostSearch lostSearchAt(int n, int interval) {
  LostSearch s;
  if (interval <= 0) {
    s.local = true;
    return s;
  }
  const int i = interval, m = n - 1;
  if (m < 30 * i) {
    s.whole = m % i == 0;
    s.local = n <= 2 * i || s.whole;
    s.k = m / i;
  } else {
    s.whole = s.local = (m - 30 * i) % (4 * i) == 0;
    s.k = 30 + (m - 30 * i) / (4 * i);
  }
  return s;
}

// The sizes, relative to its box, a lost region's look at placement is
// searched for at over the whole frame, in turn (reacquire()).
constexpr double kLostCoarseSizes[3] = {1.0, 1.0 / 1.2, 1.2};

}  // namespace

int RegionTracker::lookInterval(const RegionTrackerOptions& options, size_t regions) {
  if (options.appearance_budget <= 0 || regions <= static_cast<size_t>(options.appearance_budget)) return 1;
  return static_cast<int>((regions + options.appearance_budget - 1) / options.appearance_budget);
}

int RegionTracker::filterInterval(const RegionTrackerOptions& options, size_t regions) {
  const size_t per_frame = options.appearance_budget <= 0
                               ? regions
                               : std::min(regions, static_cast<size_t>(options.appearance_budget));
  return std::max(1, static_cast<int>((per_frame + kFilterBudget - 1) / kFilterBudget));
}

double RegionTracker::lookGain(const RegionState& state, bool motion_weak, double motion_confidence) const {
  if (motion_weak) return 1.0;
  return 1 - std::pow(1 - options_.appearance_gain * (1 - motion_confidence), state.look_age + 1);
}

double RegionTracker::lookConfidence(double score) const {
  return std::clamp((score - options_.appearance_lost_score) / (1.0 - options_.appearance_lost_score), 0.0, 1.0);
}

std::string RegionLossLog::update(const RegionState& s) {
  const bool lost = s.status == RegionStatus::kLost;
  if (lost ? !lost_.insert(s.id).second : !lost_.erase(s.id)) return "";
  char stamp[32];
  std::snprintf(stamp, sizeof(stamp), "%.6f", s.stamp);
  return "region " + std::to_string(s.id) + (lost ? " lost" : " tracked again") + " at stamp " + stamp + ": " +
         s.reason;
}

void RegionTracker::addOwnFeatures(RegionState* state, const cv::Mat& image, int motion_features) const {
  // Only what the motion analysis does not give: a region it covers well
  // gets none (its features are spread for the camera motion, not for the
  // region, and a small box gets few or none).
  const int want = options_.region_features - motion_features - static_cast<int>(state->own_points.size());
  // Top up only below 3/4 of the target: detecting costs more than tracking.
  if (want <= options_.region_features / 4) return;
  // In the inner part of the box: a box drawn round an object holds some
  // background at its edges, which moves otherwise.
  const cv::Rect2d& b = state->box;
  const cv::Rect2d inner(b.x + 0.15 * b.width, b.y + 0.15 * b.height, 0.7 * b.width, 0.7 * b.height);
  for (const cv::Point2f& p :
       detectOwnFeatures(image, inner, want, state->own_points, options_.region_feature_px)) {
    state->own_points.push_back(p);
    state->own_ids.push_back(kOwnFeatureIdBase + (state->next_own_id++ & (kOwnFeatureIdBase - 1)));
  }
}

void RegionTracker::initFromImage(RegionState* state, const cv::Mat& image, const MotionData& md) const {
  if (!usable(image)) return;
  // A rectangle (its sides on the frame's edges) is tracked as one: turned
  // as found, its look and own features taken along its axes.
  const PlacedShape shape = placedShape(image, state->box);
  if (shape.rectangle) {
    state->rectangle = true;
    state->box = shape.box;
    state->angle = state->placed_angle = shape.angle;
    state->placed_aspect = shape.box.width / shape.box.height;
  }
  if (options_.region_features > 0) {
    const int in_box = static_cast<int>(std::count_if(md.features.begin(), md.features.end(), [&](const FeatureMotion& f) {
      return state->box.contains(cv::Point2d(f.x, f.y));
    }));
    addOwnFeatures(state, image, in_box);
  }
  if (options_.appearance &&
      RegionAppearance::create(image, state->box, options_.appearance_size, &state->appearance, state->angle))
    state->first_appearance = state->appearance;
  if (options_.appearance && options_.appearance_filter) RegionFilter::create(image, state->box, &state->filter);
  state->filter_size = state->box.size();
  // Its turns among the others' (appearance_budget) are staggered by id on
  // its first step, among the regions sharing that frame.
  state->look_wait = -1;
  state->filter_wait = -1;
}

void RegionTracker::lookTurn(const RegionState& state, RegionState* next, bool motion_weak,
                             const cv::Mat& image) const {
  // The filter costs about ten times the template's check: with more
  // regions than kFilterBudget, each asks its filter on every
  // filter_interval_-th turn only (staggered by id). Its verdict counts on
  // the turn it was asked on only.
  const int wait = state.filter_wait < 0 ? static_cast<int>(state.id % filter_interval_) : state.filter_wait;
  const bool filter_turn = options_.appearance_filter && (wait <= 0 || wait >= filter_interval_);
  next->filter_wait = filter_turn ? filter_interval_ - 1 : wait - 1;
  const FilterFind find = filter_turn ? findByFilter(state, next, motion_weak, image) : FilterFind();
  const cv::Point2d motion_centre = (next->box.tl() + next->box.br()) / 2;
  checkAppearance(state, next, motion_weak, image, find.sure);
  // The template's clear match is to the pixel, the filter's to its cells:
  // the filter moves a region the template did not. Nor one that keeps
  // still against the background (the camera's motion carries it, fitted
  // on all the frame's features) while its template matches it strongly
  // where it is: the filter's cells would only jitter it, and the jitter
  // added up (an anchor's patch on a wall drifted 2 px in 6 s).
  const double size = std::sqrt(next->box.area());
  const bool held = !motion_weak && next->object_velocity.norm() < kFilterStillShare * size &&
                    next->appearance_score >= options_.reacquire_score;
  if (motion_centre == (next->box.tl() + next->box.br()) / 2 && !held) {
    next->box.x += find.move.x;
    next->box.y += find.move.y;
  }
  if (filter_turn) learnFilter(next, image, find);
  next->look_age = 0;
}

RegionTracker::FilterFind RegionTracker::findByFilter(const RegionState& state, RegionState* next,
                                                     bool motion_weak, const cv::Mat& image) const {
  if (!state.filter.valid() || next->status == RegionStatus::kLost || next->status == RegionStatus::kOutOfView)
    return {};
  // Where many features carry the region, they place it more precisely
  // than the filter's 4 px cells (the window's, scaled), and the filter is
  // not asked: it costs about ten times the template's check.
  const double motion_confidence =
      motion_weak ? 0.0 : std::min(1.0, next->inliers.size() / options_.confidence_inliers);
  if (motion_confidence >= kFilterFirmlyCarried) return {};
  FilterMatch m = state.filter.locate(image, next->box);
  // The features' scale, checked: once the box's size has drifted
  // kFilterSizeCheck or more from the size its filter last checked, the
  // filter is asked at that size too, and that size is kept back when its
  // peak is clearly the higher (by kFilterSizeMargin). The few features of
  // a region in doubt make a noisy scale: a walker's box grew twice his
  // size in 25 frames on swinging legs (Human3).
  if (state.filter_size.area() > 0 &&
      region_geometry::sizeOff(next->box.size(), state.filter_size) > std::log(kFilterSizeCheck)) {
    const cv::Rect2d checked = region_geometry::withSize(next->box, state.filter_size);
    const FilterMatch at_checked = state.filter.locate(image, checked);
    if (at_checked.found && at_checked.peak > (1 + kFilterSizeMargin) * m.peak) {
      next->box = checked;
      m = at_checked;
    }
    if (m.found) next->filter_size = next->box.size();
  }
  if (!m.found) return {};
  FilterFind find;
  find.psr = m.psr;
  // Sure: a clear peak, and not much weaker than its usual one (an occluder
  // sliding over the region still gives a clear peak somewhere, a weak one).
  find.sure = m.psr >= kFilterSurePsr && m.peak >= kFilterSurePeak * state.filter_peak;
  if (!find.sure) return find;
  next->filter_peak = state.filter_peak > 0 ? (1 - kFilterPeakRate) * state.filter_peak + kFilterPeakRate * m.peak
                                            : m.peak;
  if (motion_weak) {
    // Seen where it is, as when the look moves it.
    next->coast_frames = 0;
    if (next->status == RegionStatus::kFeatureless) next->status = RegionStatus::kTracked;
  }
  find.move = kFilterGain * lookGain(state, motion_weak, motion_confidence) * m.shift;
  return find;
}

void RegionTracker::learnFilter(RegionState* next, const cv::Mat& image, const FilterFind& find) const {
  // Only on a clear find: a filter that learned an occluder would follow it.
  if (!next->filter.valid() || !find.sure || find.psr < kFilterLearnPsr ||
      next->status == RegionStatus::kLost || next->status == RegionStatus::kOutOfView)
    return;
  // Every kFilterLearnEvery frames or more (the frames between its turns
  // counted), at the rate of kFilterLearnEvery frames: learning costs as
  // much as finding.
  if (next->filter_unlearned < kFilterLearnEvery) return;
  next->filter.learn(image, next->box, 1 - std::pow(1 - kFilterRate, std::min(next->filter_unlearned, kFilterLearnEvery)));
  next->filter_unlearned = 0;
}

void RegionTracker::checkAppearance(const RegionState& state, RegionState* next, bool motion_weak,
                                    const cv::Mat& image, bool filter_sure) const {
  const RegionTrackerOptions& o = options_;
  if (next->status == RegionStatus::kLost || next->status == RegionStatus::kOutOfView) {
    next->appearance_score = -1;
    next->stretch_run = next->size_run = 0;
    return;
  }
  // A region in doubt is searched for wider, the wider the longer since its
  // last check (with appearance_budget, its turns come every few frames):
  // up to twice as wide, as after 4 frames.
  const double reach = std::min(2.0, std::sqrt(state.look_age + 1.0));
  const double margin = motion_weak ? 2 * o.appearance_margin * reach : o.appearance_margin;
  // Where the features carry the region they measure its scale, and the
  // look's sizes are not used (below): its own size only, a third the cost.
  static const std::vector<double> own_size = {1.0};
  const auto& scales = motion_weak ? RegionAppearance::trackedScales() : own_size;
  // With more regions than appearance_budget, a region in doubt, searched
  // up to twice as wide on its turns, is searched coarse to fine (as a lost
  // one is), and the prediction's own score read apart: the full search
  // there cost 100 regions on `cards` 13 ms a frame instead of 10. With
  // fewer, in full: coarse to fine every frame took car1 from 0.736 to
  // 0.691 (its one coarse peak, found at the box's own size, is refined).
  const bool coarse = motion_weak && look_interval_ > 1;
  AppearanceMatch m = coarse ? state.appearance.matchWide(image, next->box, margin, scales, next->angle)
                             : state.appearance.match(image, next->box, margin, scales, next->angle);
  if (coarse && m.found) {
    m.score_at_box = state.appearance.scoreAt(image, next->box, next->angle);
    m.found = m.score_at_box > -0.5;  // -1: the box mostly out of the image, as a window would be
  }
  if (!m.found) {
    next->appearance_score = -1;
    return;
  }
  double score = m.score_at_box;
  // How firmly the features carry the region (1: confidence_inliers or more).
  const double motion_confidence = motion_weak ? 0.0 : std::min(1.0, next->inliers.size() / o.confidence_inliers);
  // The box's aspect, and its size where the features carry it weakly:
  // tried on every kLookStretchEvery-th strong check (a target turns
  // broadside over seconds; a try costs two matches close around the box,
  // five when the look at placement is asked too, and as many for the
  // size). Before the turn: its tries are held against m.score, taken at
  // this turn.
  if (m.score < o.reacquire_score || motion_weak) {
    next->stretch_run = next->size_run = 0;
  } else if (next->stretch_wait < 0) {
    next->stretch_wait = static_cast<int>(next->id % kLookStretchEvery);
  } else if (next->stretch_wait > 0) {
    --next->stretch_wait;
  } else {
    next->stretch_wait = kLookStretchEvery - 1;
    reshapeByLook(next, m, motion_confidence, image);
  }
  // The look's own turn: the template a step either way of the region's
  // turn, matched close around the best place. The motion gives the turn
  // of the background where the region is; the look says whether the
  // region turned with it (a car on the road ahead does not roll with the
  // road's perspective), where it knows the region well (a strong match:
  // a walker's look changes with every step, and turns as often).
  if (m.score >= o.reacquire_score) turnByLook(state, next, m, motion_weak, motion_confidence, image);
  // A clearly better look nearby: move toward it (all the way when the motion
  // data had nothing to say about the region itself).
  if (m.score >= o.appearance_accept && m.score > m.score_at_box + o.appearance_gap) {
    // The motion fit is precise where many features carry it: the look
    // only nudges such a region, and moves one the features do not hold.
    // A region checked on its turn only (appearance_budget) takes the
    // nudges of the frames it was not checked on as well (and its template
    // their updates, below).
    const double k = lookGain(state, motion_weak, motion_confidence);
    const cv::Point2d c0 = (next->box.tl() + next->box.br()) / 2, c1 = (m.box.tl() + m.box.br()) / 2;
    const cv::Point2d c = c0 + k * (c1 - c0);
    // Sizes from a 5% scale search are coarse, and a perspective view often
    // matches a smaller box best: they count only when the features cannot
    // measure the scale, and then at half speed.
    const double ks = motion_weak ? 0.5 : 0.0;
    const double w = next->box.width + ks * (m.box.width - next->box.width);
    const double h = next->box.height + ks * (m.box.height - next->box.height);
    next->box = cv::Rect2d(c.x - w / 2, c.y - h / 2, w, h);
    score = m.score;
    if (motion_weak) {
      // Seen where it is: no longer coasting blind, nor merely carried by the camera.
      next->coast_frames = 0;
      next->status = RegionStatus::kTracked;
    }
  }
  next->appearance_score = score;
  // The template learns this frame's look (the frames since its last check
  // counted as well).
  const auto learnLook = [&] {
    next->appearance.blend(image, next->box, 1 - std::pow(1 - o.appearance_update, state.look_age + 1), next->angle);
    next->look_size = next->box.size();
  };
  if (score >= o.appearance_accept) {
    // Before its template learns this view at the box's size.
    if (next->found_frames >= 0) checkFoundSize(next, image);
    next->appearance_misses = 0;
    next->confidence = std::max(next->confidence, lookConfidence(score));
    // Confident frames teach the template the region's current look, when
    // the look at placement agrees on where the region is (else the
    // template would learn whatever drifted into the box).
    if (!motion_weak || score >= o.reacquire_score) {
      // A region the features carry firmly may change its look (turn, tilt)
      // beyond the first look's recognition: the features vouch for it (and
      // the first look is not asked).
      const auto firstAgrees = [&] {
        const AppearanceMatch first = state.first_appearance.match(image, next->box, 0.1, scales, next->angle);
        const cv::Point2d d = (first.box.tl() + first.box.br()) / 2 - (next->box.tl() + next->box.br()) / 2;
        const double tolerance = 0.015 * std::max(next->box.width, next->box.height);
        return first.found && first.score >= o.appearance_lost_score && std::hypot(d.x, d.y) <= tolerance;
      };
      if (motion_confidence >= kFirmlyCarried || firstAgrees()) learnLook();
    }
  } else if (score >= o.appearance_lost_score && !motion_weak && motion_confidence >= kFirmlyCarried) {
    // A region the features carry firmly, whose look changes (a card
    // tilting away) faster than its strong matches could teach the
    // template: the features vouch for it, and the template learns this
    // view too, before it stops recognising the region at all.
    learnLook();
  } else if (score < o.appearance_lost_score && !filter_sure) {
    // It looks wrong. Lost after appearance_lost_frames of that while few
    // features carry it, three times as long while many do (a turning or
    // tilting target changes its look while its features hold it).
    next->appearance_misses = state.appearance_misses + 1;
    next->confidence *= 0.5;
    // Counted in checks: with many regions (appearance_budget) a region's
    // look is checked every look_interval_ frames, and as many frames pass.
    const int patience = motion_confidence >= 0.5 ? 3 * o.appearance_lost_frames : o.appearance_lost_frames;
    const int checks = (patience + look_interval_ - 1) / look_interval_;
    if (o.appearance_lost_frames > 0 && next->appearance_misses >= checks) {
      next->status = RegionStatus::kLost;
      next->confidence = 0;
      next->reason = "no longer looks like itself (correlation below " + std::to_string(o.appearance_lost_score) +
                     (look_interval_ == 1 ? " for " + std::to_string(patience) + " frames)"
                                          : " on " + std::to_string(checks) + " checks, one every " +
                                                std::to_string(look_interval_) + " frames)");
    }
  }
}

void RegionTracker::turnByLook(const RegionState& state, RegionState* next, const AppearanceMatch& m,
                               bool motion_weak, double motion_confidence, const cv::Mat& image) const {
  const double step = kLookTurnStep;
  const cv::Rect2d at = m.box;  // the look's best place at the region's turn
  const AppearanceMatch minus = state.appearance.match(image, at, kLookTurnMargin, {1.0}, next->angle - step);
  const AppearanceMatch plus = state.appearance.match(image, at, kLookTurnMargin, {1.0}, next->angle + step);
  if (!minus.found || !plus.found) return;
  // The turn the three scores peak at (a parabola through them), within a
  // step either way; a turn must beat the region's by 0.01, as a scale must.
  const double s0 = m.score, sm = minus.score, sp = plus.score;
  const double d = std::max(sm, sp) > s0 + 0.01 ? (sp > sm ? step : -step)
                                                : step * region_geometry::peakOffset(sm, s0, sp);
  if (d == 0) return;
  // As far as the look moves a region's place.
  next->angle = std::remainder(next->angle + lookGain(state, motion_weak, motion_confidence) * d, 2 * M_PI);
}

void RegionTracker::reshapeByLook(RegionState* next, const AppearanceMatch& m, double motion_confidence,
                                  const cv::Mat& image) const {
  const double step = kLookStretchStep;
  const double aspect = next->box.width / next->box.height;
  if (!(aspect > 0)) return;
  const cv::Rect2d at = region_geometry::withAspect(m.box, aspect);
  const auto stretched = [&](const cv::Rect2d& b, double k) { return region_geometry::withAspect(b, aspect * k); };
  const auto sized = [](const cv::Rect2d& b, double k) { return region_geometry::withSize(b, b.size() * k); };
  // Which way `look` matches better with the box reshaped by a step either
  // way (`reshape(box, k)`, k = e^-step, e^step) than as it is (0: neither,
  // or it no longer knows the region). Only a reshape that matches better
  // than the box as it is: on a rigid target the look's peak is flat around
  // the box's shape, and the noise of a parabola through it would set the
  // box adrift. `at_box`: the look's score at the box's shape, measured on
  // first need and kept for the other reshape (both leave `at` as it is).
  const auto way = [&](const RegionAppearance& look, std::optional<double>& at_box, const auto& reshape) {
    const auto score = [&](double k) {
      const AppearanceMatch a = look.match(image, reshape(at, k), kLookTurnMargin, {1.0}, next->angle);
      return a.found ? a.score : -1.0;
    };
    if (!at_box) at_box = score(1.0);
    const double s0 = *at_box;
    const double sm = score(std::exp(-step)), sp = score(std::exp(step));
    if (std::max(sm, sp) < options_.reacquire_score || !(std::max(sm, sp) > s0)) return 0;
    return sp > sm ? 1 : -1;
  };
  // The latest look sees a reshape while it is learning it; the look at
  // placement, once the latest has taken it in (it learns each frame's
  // view at the box's shape).
  std::optional<double> latest_at_box = m.score, first_at_box;
  const auto ask = [&](const auto& reshape) {
    const int dir = way(next->appearance, latest_at_box, reshape);
    return dir == 0 && next->first_appearance.valid() ? way(next->first_appearance, first_at_box, reshape) : dir;
  };
  const auto runOf = [](int dir, int run) { return dir == 0 ? 0 : (dir > 0) == (run > 0) ? run + dir : dir; };
  const int stretch = ask(stretched);
  next->stretch_run = runOf(stretch, next->stretch_run);
  // Its size only where the features carry it weakly: a target turning
  // away (POT's V24_7, 47 degrees) matches a smaller template best, and
  // its features measure its scale better than that.
  const int grow = motion_confidence < kFirmlyCarried ? ask(sized) : 0;
  next->size_run = runOf(grow, next->size_run);
  const double gain = kLookStretchGain * step;
  if (std::abs(next->size_run) >= kLookStretchRun) next->box = sized(next->box, std::exp(gain * grow));
  if (std::abs(next->stretch_run) >= kLookStretchRun) {
    double a = aspect * std::exp(gain * stretch);
    // Within a factor 2 of the aspect it was given.
    if (next->placed_aspect > 0) a = std::clamp(a, 0.5 * next->placed_aspect, 2.0 * next->placed_aspect);
    next->box = region_geometry::withAspect(next->box, a);
  }
}

void RegionTracker::checkFoundSize(RegionState* next, const cv::Mat& image) const {
  // The look at placement, at the aspect it was taken at: the latest look
  // learns each frame's view at the box's size, and would agree with it.
  // A match at the box's own size (within 1%, the aspect's rounding) leaves
  // it as it is.
  const RegionAppearance& look = next->first_appearance.valid() ? next->first_appearance : next->appearance;
  static const std::vector<double> sizes = {1.0, 1.05, 1.1};
  const cv::Rect2d at = region_geometry::withAspect(next->box, next->placed_aspect);
  const AppearanceMatch m = look.match(image, at, kLookTurnMargin, sizes, next->angle);
  if (!m.found || !(at.area() > 0)) return;
  const double k = std::sqrt(m.box.area() / at.area());
  if (!(k > 0) || !std::isfinite(k)) return;
  if (std::abs(std::log(k)) < 0.01) return;
  next->box = region_geometry::withSize(next->box, next->box.size() * k);
}

void RegionTracker::reacquire(RegionState* next, const cv::Mat& image) const {
  const RegionTrackerOptions& o = options_;
  next->lost_frames += 1;
  // Around its last place with its latest look; over the whole frame with
  // its latest look and its look at placement in turn (the latest may have
  // taken on what covered it), the look at placement also tried around its
  // last place then. Its size changed unseen while it was lost: the wider
  // scale range. When: lostSearchAt(); when more regions than
  // appearance_budget share the frames, the searches around its last place
  // between the whole-frame ones come on its turns only (staggered by id).
  LostSearch when = lostSearchAt(next->lost_frames, o.reacquire_interval);
  when.local = when.whole || (when.local && (next->lost_frames + next->id) % look_interval_ == 0);
  if (!when.local) return;
  const auto& scales = RegionAppearance::lostScales();
  const double angle = next->angle;  // the last turn it was seen at
  auto search = [&](const cv::Rect2d& box) {
    AppearanceMatch m = next->appearance.matchWide(image, box, 1.0, scales, angle);
    if (when.whole && (!m.found || m.score < o.reacquire_score)) {
      const bool first = when.k % 2 == 1 && next->first_appearance.valid();
      // The look at placement, at the aspect it was taken at.
      const cv::Rect2d placed_box = region_geometry::withAspect(box, next->placed_aspect);
      if (first) {
        const AppearanceMatch f = next->first_appearance.matchWide(image, placed_box, 1.0, scales, angle);
        if (f.found && f.score > m.score) m = f;
      }
      if (!m.found || m.score < o.reacquire_score) {
        // The look at placement (every other whole-frame search) at the
        // box's size, then 1.2 times smaller, then larger, in turn over
        // those searches: its size may have changed unseen while it was lost, and
        // the coarse search misses a target 1.2 times off (region_hidden,
        // seed 3: a card back from behind a panel 18% smaller than its box
        // was found 40 frames late). The latest look keeps the box's size.
        const double size = first ? kLostCoarseSizes[(when.k / 2) % 3] : 1.0;
        const AppearanceMatch a =
            first ? next->first_appearance.matchAnywhere(
                        image, region_geometry::withSize(placed_box, placed_box.size() * size), scales, angle)
                  : next->appearance.matchAnywhere(image, box, scales, angle);
        if (a.found && a.score > m.score) m = a;
      }
    }
    return m;
  };
  AppearanceMatch m = search(next->box);
  // Also at the size its look was last confirmed at, when the box drifted
  // more than 1.1x from it: a region that drifted onto what covered it may
  // have grown or shrunk with that before it was lost (the coarse search
  // reads the frame at the box's own size, so it misses a target 1.2x off).
  // Only when the search at the box found nothing: searching both and
  // keeping the better found region_hidden later among 99 others.
  const cv::Rect2d look_box = region_geometry::withSize(next->box, next->look_size);
  if (region_geometry::sizeOff(look_box.size(), next->box.size()) > std::log(1.1) &&
      (!m.found || m.score < o.reacquire_score)) {
    const AppearanceMatch at_look = search(look_box);
    if (at_look.found && at_look.score > m.score) m = at_look;
  }
  if (!m.found || m.score < o.reacquire_score) return;
  char why[96];
  std::snprintf(why, sizeof(why), "re-acquired by its appearance (correlation %.2f) after %d frames lost", m.score,
                next->lost_frames);
  const RegionAppearance look = next->appearance, first = next->first_appearance;
  const RegionFilter filter = next->filter;
  const double interval = next->frame_interval, placed_aspect = next->placed_aspect;
  const double placed_angle = next->placed_angle;
  const bool rectangle = next->rectangle;
  *next = RegionState::start(next->id, m.box, next->stamp);
  next->angle = angle;
  next->placed_aspect = placed_aspect;
  next->placed_angle = placed_angle;
  next->rectangle = rectangle;
  next->appearance = look;
  next->first_appearance = first;
  next->filter = filter;
  next->filter_size = m.box.size();
  next->frame_interval = interval;
  next->found_frames = 0;
  next->appearance_score = m.score;
  next->confidence = lookConfidence(m.score);
  next->status = region_geometry::fractionInside(next->box, image_size_) < o.out_of_view_fraction
                     ? RegionStatus::kOutOfView
                     : RegionStatus::kTracked;
  next->reason = why;
}

}  // namespace imt
