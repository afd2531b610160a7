#include "instant_motion_tracking/core/region/region_tracker.h"

#include "option_checker.h"
#include "region_features.h"
#include "region_fit.h"
#include "region_geometry.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>

namespace imt {
namespace {

using region_geometry::boxAt;
using region_geometry::centre;
using region_geometry::fractionInside;
using region_fit::applyH;
using region_fit::LocalMap;
using region_fit::LocalModel;
using region_fit::Vec;
using region_fit::fitModel;
using region_fit::moveBox;
using region_fit::scaleOnlyBetweenClasses;

// A region that loses its features coasts on its own motion (below) only
// when at least this fraction of its box is inside the image.
constexpr double kMinInsideToCoast = 0.75;

// What a region does unseen fades by this factor per usual frame interval:
// the own velocity of one out of view, the scale rate of one coasting. A
// rate measured over the few frames before its features went is not kept
// up for seconds (car1 backward from the middle: a shrink of 0.2% a frame,
// taken on by 54 coasting frames, left the box 12% too small).
constexpr double kUnseenMotionFade = 0.9;

// Inliers of each motion class (background, moving) a scale must be checked
// in before it is taken for two motions mixed: 3, the fewest a scale can be
// fitted to with a point to spare.
constexpr int kMinClassInliers = 3;

// A region's own feature counts as background in that check when it moved
// with the camera within this (px, one step; background weight 0.5 there).
// The motion analysis's weights build up over frames from 0.15 px a frame;
// a single step of LK at full resolution is noisier than that.
constexpr double kOwnBackgroundResidual = 0.75;

// The usual interval between frames after a step of `interval` s that spans
// `g` of the previous usual interval `usual`: learned from the first step,
// followed slowly through jitter and rate drift, kept over gaps (dropped
// frames), and taken at once when frames come faster.
double nextFrameInterval(double usual, double interval, double g) {
  if (!(interval > 0)) return usual;
  if (usual <= 0 || g < 0.67) return interval;
  if (g > 1.5) return usual;
  return 0.9 * usual + 0.1 * interval;
}

// The features' median patch error among those in `box` with a motion and a
// known error; 0 with fewer than kMinPatchErrors of them (a median of fewer
// is no scale).
constexpr size_t kMinPatchErrors = 5;
double medianPatchError(std::vector<FeatureMotion>::const_iterator begin,
                        std::vector<FeatureMotion>::const_iterator end, const cv::Rect2d& box) {
  std::vector<float> e;
  for (auto it = begin; it != end; ++it)
    if (it->age > 0 && knownPatchError(it->patch_error) > 0 && box.contains(cv::Point2d(it->x, it->y)))
      e.push_back(it->patch_error);
  if (e.size() < kMinPatchErrors) return 0;
  std::nth_element(e.begin(), e.begin() + e.size() / 2, e.end());
  return e[e.size() / 2];
}

bool contains(const std::vector<uint32_t>& sorted, uint32_t id) {
  return std::binary_search(sorted.begin(), sorted.end(), id);
}

}  // namespace

const char* regionStatusName(RegionStatus s) {
  switch (s) {
    case RegionStatus::kTracked: return "tracked";
    case RegionStatus::kFeatureless: return "featureless";
    case RegionStatus::kOutOfView: return "out_of_view";
    case RegionStatus::kLost: break;
  }
  return "lost";
}

RegionState RegionState::start(uint32_t id, const cv::Rect2d& box, double stamp) {
  RegionState s;
  s.id = id;
  s.box = box;
  s.stamp = stamp;
  s.inlier_centroid = cv::Point2d(box.x + box.width / 2, box.y + box.height / 2);
  s.placed_aspect = box.height > 0 ? box.width / box.height : 0;
  s.look_size = box.size();
  return s;
}

cv::Rect2d RegionState::extent() const {
  // A turn of a few degrees is not told from the turn's noise (the look
  // tries turns kLookTurnStep apart), and it costs: a square's extent grows
  // by 10% at 3 degrees. The extent takes the turn since the region was
  // given in smoothly: half of it at kReportedTurn, nine tenths at three
  // times that.
  constexpr double t2 = RegionTracker::kReportedTurn * RegionTracker::kReportedTurn;
  const double turn = std::remainder(angle - placed_angle, 2 * M_PI);
  const double a = placed_angle + turn * turn * turn / (turn * turn + t2);
  if (rectangle) return region_geometry::turnedExtent(box, a);
  return a == 0 ? box : region_geometry::reportedExtent(box, a);
}

RegionState RegionState::reversed() const {
  RegionState r = *this;
  r.velocity = -velocity;
  r.object_velocity = -object_velocity;
  return r;
}

std::string RegionTrackerOptions::validate() const {
  OptionChecker c("region_tracking");
  c.inRange("min_dilation", min_dilation, 0.0, 1.0);
  c.inRange("velocity_dilation", velocity_dilation, 0.0, 20.0);
  c.inRange("irls_iterations", irls_iterations, 1, 50);
  c.check(error_floor > 0 && error_floor <= 10, "error_floor", "must be in (0, 10]", error_floor);
  c.check(inlier_error > 0 && inlier_error <= 50, "inlier_error", "must be in (0, 50]", inlier_error);
  c.inRange("inlier_boost", inlier_boost, 1.0, 1000.0);
  c.check(outlier_cut > 0 && outlier_cut <= 1, "outlier_cut", "must be in (0, 1]", outlier_cut);
  c.atLeast("min_features", min_features, 1);
  c.atLeast("min_inliers_scale", min_inliers_scale, 3);
  c.atLeast("min_inliers_similarity", min_inliers_similarity, 3);
  c.check(max_scale_change >= 0 && max_scale_change < 1, "max_scale_change", "must be in [0, 1)", max_scale_change);
  c.check(max_rotation >= 0 && max_rotation < M_PI, "max_rotation", "must be in [0, pi)", max_rotation);
  c.check(velocity_blend >= 0 && velocity_blend < 1, "velocity_blend", "must be in [0, 1)", velocity_blend);
  c.inRange("occlusion_ratio", occlusion_ratio, 0.0, 1.0);
  c.atLeast("max_coast_frames", max_coast_frames, 0.0);
  c.inRange("out_of_view_fraction", out_of_view_fraction, 0.0, 1.0);
  c.check(lost_distance > 0, "lost_distance", "must be > 0", lost_distance);
  c.atLeast("confidence_inliers", confidence_inliers, 1.0);
  c.atLeast("fallback_min_features", fallback_min_features, 1);
  c.inRange("region_features", region_features, 0, 1000);
  c.inRange("region_feature_px", region_feature_px, 16, 1024);
  c.inRange("appearance_size", appearance_size, 8, 256);
  c.inRange("appearance_margin", appearance_margin, 0.0, 2.0);
  c.inRange("appearance_accept", appearance_accept, 0.0, 1.0);
  c.inRange("appearance_gain", appearance_gain, 0.0, 1.0);
  c.inRange("appearance_gap", appearance_gap, 0.0, 2.0);
  c.inRange("appearance_update", appearance_update, 0.0, 1.0);
  c.inRange("appearance_lost_score", appearance_lost_score, -1.0, 1.0);
  c.atLeast("appearance_lost_frames", appearance_lost_frames, 0);
  c.inRange("reacquire_score", reacquire_score, 0.0, 1.0);
  c.atLeast("reacquire_interval", reacquire_interval, 0);
  c.atLeast("appearance_budget", appearance_budget, 0);
  c.atLeast("max_regions", max_regions, 1);
  return c.error();
}

bool RegionTracker::usable(const cv::Mat& image) const {
  return !image.empty() && image.type() == CV_8UC1 && image.size() == image_size_;
}

RegionState RegionTracker::step(const RegionState& state, const MotionData& md, Direction dir, double prev_stamp,
                                const cv::Mat& image, const cv::Mat& state_image,
                                const FramePyramids& pyramids) const {
  std::vector<OwnFeature> own;
  const bool with_own = options_.region_features > 0 && usable(image) && usable(state_image);
  RegionState next =
      stepMotion(state, md, dir, prev_stamp, with_own ? state_image : cv::Mat(), image, pyramids, &own);
  if (next.found_frames >= 0 && ++next.found_frames > kFoundSizeFrames) next.found_frames = -1;
  next.filter_unlearned = state.filter_unlearned + 1;
  const bool use_look = options_.appearance && state.appearance.valid() && usable(image);
  if (use_look && state.status == RegionStatus::kLost) {
    reacquire(&next, image);
  } else if (use_look) {
    const bool camera_valid = md.camera.model != MotionModel::kInvalid;
    const bool weak = !camera_valid || next.coast_frames > 0 || next.status == RegionStatus::kFeatureless ||
                      static_cast<int>(next.inliers.size()) < options_.min_inliers_scale;
    // On its turn (every frame when the regions are within
    // appearance_budget), in doubt or not: a region in doubt checked on every
    // frame beyond the budget made 100 regions cost 20 times one (25 such
    // looks a frame on the `cards` scene).
    // (A wait longer than the interval is left from when more regions
    // shared the frames.)
    // (A region's first step: its turns staggered by id.)
    const int wait = state.look_wait < 0 ? static_cast<int>(state.id % look_interval_) : state.look_wait;
    const bool turn = wait <= 0 || wait >= look_interval_;
    next.look_wait = turn ? look_interval_ - 1 : wait - 1;
    if (turn) {
      lookTurn(state, &next, weak, image);
    } else {
      // Not its turn: the last check's score stands, for a region its
      // features carry (one in doubt may have moved off what was checked).
      next.look_age = state.look_age + 1;
      if (!weak) next.confidence = std::max(next.confidence, lookConfidence(state.appearance_score));
    }
  }
  // The region's own features go on with it: those still inside its box,
  // topped up with new corners there.
  next.own_points.clear();
  next.own_ids.clear();
  if (next.status == RegionStatus::kLost || next.status == RegionStatus::kOutOfView || !usable(image) ||
      options_.region_features <= 0)
    return next;
  const cv::Rect2d keep(next.box.x - 0.1 * next.box.width, next.box.y - 0.1 * next.box.height, 1.2 * next.box.width,
                        1.2 * next.box.height);
  for (const OwnFeature& f : own) {
    // Those that moved otherwise than the region are not its own.
    if (!keep.contains(cv::Point2d(f.to.x, f.to.y)) || contains(next.outliers, f.id)) continue;
    next.own_points.push_back(f.to);
    next.own_ids.push_back(f.id);
  }
  // New ones only where the region is seen as itself: not while it coasts
  // behind an occluder, nor when it does not look like itself, nor on a
  // frame its look was not checked on (an occluder may be coming over it).
  const bool seen = next.status == RegionStatus::kTracked && next.coast_frames == 0 &&
                    (next.appearance_score < -0.5 ||
                     (next.appearance_score >= options_.appearance_lost_score && next.look_age == 0));
  if (seen) {
    const auto motion = [](uint32_t id) { return id < kOwnFeatureIdBase; };
    addOwnFeatures(&next, image,
                   static_cast<int>(std::count_if(next.inliers.begin(), next.inliers.end(), motion) +
                                    std::count_if(next.outliers.begin(), next.outliers.end(), motion)));
  }
  return next;
}

RegionState RegionTracker::stepMotion(const RegionState& state, const MotionData& md, Direction dir,
                                      double prev_stamp, const cv::Mat& from_image, const cv::Mat& to_image,
                                      const FramePyramids& pyramids, std::vector<OwnFeature>* own) const {
  const RegionTrackerOptions& o = options_;
  RegionState next = state;
  next.stamp = dir == Direction::kForward ? md.stamp : prev_stamp;

  // Camera (background) motion in the tracking direction.
  const bool camera_valid = md.camera.model != MotionModel::kInvalid && md.camera.H.allFinite();
  const Eigen::Matrix3d H_fwd = camera_valid ? md.camera.H : Eigen::Matrix3d::Identity();
  const Eigen::Matrix3d H_inv = H_fwd.inverse();
  const Eigen::Matrix3d H_dir = dir == Direction::kForward ? H_fwd : H_inv;
  // The region turns with the background where it is, whatever else moves
  // it (a lost one too: it is searched for at that turn); its turn is
  // checked against its look (checkAppearance).
  next.angle = std::remainder(state.angle + LocalMap(state.box, H_dir).turn(), 2 * M_PI);
  if (state.status == RegionStatus::kLost) return next;
  next.reason.clear();

  // Frames dropped upstream: this step spans `g` of the region's usual
  // intervals, and its velocities (px per usual interval) are scaled by it.
  const double interval = std::abs(dir == Direction::kForward ? md.stamp - state.stamp : state.stamp - prev_stamp);
  const double g = boundedIntervalRatio(state.frame_interval > 0 ? interval / state.frame_interval : 1.0);
  next.frame_interval = nextFrameInterval(state.frame_interval, interval, g);
  const Eigen::Vector2d object_step = g * state.object_velocity;  // the region's own motion this step

  // Search area: the box dilated by the expected motion.
  const double L = std::max(image_size_.width, image_size_.height);
  const double diag = std::hypot(state.box.width, state.box.height);
  const double dil =
      std::max(o.min_dilation * L, std::min(diag / 4, o.velocity_dilation * g * state.velocity.norm()));
  const cv::Rect2d search(state.box.x - dil, state.box.y - dil, state.box.width + 2 * dil,
                          state.box.height + 2 * dil);
  const Eigen::Vector2d c = centre(state.box);
  // The region's motion = camera motion + its own: the fit below explains
  // what is left after moving everything by the camera model, so a region
  // with little support still inherits the camera's zoom (as far as it is
  // background, below) and rotation.
  const cv::Rect2d camera_box = moveBox(state.box, H_dir);
  const Eigen::Vector2d c_cam = centre(camera_box);
  const Eigen::Vector2d camera_shift = c_cam - c;

  // Motion vectors in the tracking direction, with their priors.
  std::vector<Vec> vecs;
  // Crop: with features sorted by x only those near the search area are
  // visited (src is the previous position going forward, up to max_shift
  // away in x from the current one).
  auto crop_begin = md.features.begin(), crop_end = md.features.end();
  if (md.sorted_by_x) {
    const double margin = dir == Direction::kForward ? md.max_shift + 1.0 : 1.0;
    crop_begin = std::lower_bound(md.features.begin(), md.features.end(), search.x - margin,
                             [](const FeatureMotion& f, double x) { return f.x < x; });
    crop_end = std::upper_bound(crop_begin, md.features.end(), search.br().x + margin,
                            [](double x, const FeatureMotion& f) { return x < f.x; });
  }
  // `weigh`: the feature's prior is divided by it (its position's error, in
  // image px per px it was measured at).
  auto addVec = [&](uint32_t id, const Eigen::Vector2d& src, const Eigen::Vector2d& dst, double weigh) {
    Vec v;
    v.id = id;
    v.src = src;
    v.dst = dst;
    if (!v.src.allFinite() || !v.dst.allFinite()) return;
    if (!search.contains(cv::Point2d(v.src.x(), v.src.y()))) return;
    v.in_box = state.box.contains(cv::Point2d(v.src.x(), v.src.y()));
    v.src_cam = applyH(H_dir, v.src);
    // Spatial prior: a Gaussian in box coordinates (both axes).
    const double ux = (v.src.x() - c.x()) / (0.5 * std::max(1.0, state.box.width));
    const double uy = (v.src.y() - c.y()) / (0.5 * std::max(1.0, state.box.height));
    v.prior = std::exp(-0.5 * (ux * ux + uy * uy) / (0.8 * 0.8));
    // Motion prior: agreement with the region's predicted motion (camera
    // motion at the point plus the region's own velocity). Stronger while
    // the region coasts through an occlusion.
    if (state.support > 0) {
      const Eigen::Vector2d expected = v.src_cam + object_step;
      const double sigma = std::max(2.0, 0.5 * object_step.norm());
      const double m = (v.dst - expected).squaredNorm() / (2 * sigma * sigma);
      const double floor = state.coast_frames > 0 ? 0.05 : 0.3;
      v.prior *= floor + (1 - floor) * std::exp(-m);
    }
    if (contains(state.inliers, id)) v.prior *= o.inlier_boost;
    // An outlier last frame, or background seen as such (below): the cut
    // once, not twice for both.
    if (contains(state.outliers, id) || contains(state.background, id)) v.prior *= o.outlier_cut;
    v.prior /= weigh;
    v.weight = v.prior;
    vecs.push_back(v);
  };
  // 1 when unknown or nonsense (below 1: finer than the image itself); at
  // most 64 (an analysis width of 60 px reading 3840: beyond that the
  // features' weights would vanish against the region's own corners).
  const double motion_scale =
      std::isfinite(md.analysis_scale) && md.analysis_scale > 1 ? std::min<double>(md.analysis_scale, 64) : 1.0;
  // How well each feature's LK window matched (its patch error) against the
  // region's own features: a window straddling the region's edge and what
  // moves behind it (the wall a card uncovers, the road behind a followed
  // car or a walker) moves partly with each, steadily lags the region and
  // stretches its fit toward the background; it matches 2-3 times worse
  // than the region's own (measured on region_midstart). The prior is
  // weighed by a Cauchy weight at the scale of the median error in the box,
  // 1 / (1 + (e / median)^2): the median feature keeps half, one at three
  // times it a tenth. Without enough errors in the box (or none known, 0),
  // no weighing.
  const double error_scale = medianPatchError(crop_begin, crop_end, state.box);
  for (auto fit = crop_begin; fit != crop_end; ++fit) {
    const FeatureMotion& f = *fit;
    if (f.age == 0) continue;  // just detected: no motion measured yet
    const double q = error_scale > 0 ? knownPatchError(f.patch_error) / error_scale : 0.0;
    const double match_weigh = 1 + q * q;
    const Eigen::Vector2d cur(f.x, f.y);
    const Eigen::Vector2d prev = applyH(H_inv, cur - Eigen::Vector2d(f.dx, f.dy));
    const size_t before = vecs.size();
    // Measured at the analysis resolution: off by up to a pixel there,
    // analysis_scale pixels here. The weights are 1 / error, as the robust
    // fit's are; a region's own features are tracked at full resolution.
    if (dir == Direction::kForward) addVec(f.id, prev, cur, motion_scale * match_weigh);
    else addVec(f.id, cur, prev, motion_scale * match_weigh);
    // Read with care (types.h): an infinite weight would make a region's
    // zoom, raised to its inliers' mean weight, infinite.
    if (vecs.size() != before) vecs.back().bg = knownBackgroundWeight(f.bg_weight);
  }
  // The region's own features, tracked from its frame into the next.
  if (!from_image.empty() && !to_image.empty() && !state.own_points.empty()) {
    *own = trackOwnFeatures(from_image, to_image, state.own_points, state.own_ids, state.box, H_dir, object_step,
                            o.region_feature_px, pyramids.state_image, pyramids.image);
    for (const OwnFeature& f : *own)
      addVec(f.id, Eigen::Vector2d(f.from.x, f.from.y), Eigen::Vector2d(f.to.x, f.to.y), 1.0);
  }
  const int in_box = static_cast<int>(std::count_if(vecs.begin(), vecs.end(), [](const Vec& v) { return v.in_box; }));
  const double frac_inside = fractionInside(state.box, image_size_);

  // Camera-only prediction (static region), plus the region's own motion
  // decaying, for featureless and out-of-view regions.
  auto predictWithCamera = [&](RegionStatus status) {
    cv::Rect2d b = camera_box;
    next.object_velocity = Eigen::Vector2d::Zero();
    if (status == RegionStatus::kOutOfView) {
      // A moving region keeps going, slowing down (kUnseenMotionFade).
      next.object_velocity = std::pow(kUnseenMotionFade, g) * state.object_velocity;
      b.x += g * next.object_velocity.x();
      b.y += g * next.object_velocity.y();
    }
    next.box = b;
    next.status = status;
    next.velocity = (centre(b) - c) / g;
    next.confidence = status == RegionStatus::kFeatureless ? 0.5 : 0.3;
    next.inliers.clear();
    next.outliers.clear();
    next.inlier_centroid = cv::Point2d(centre(b).x(), centre(b).y());
    next.inlier_extent = cv::Size2d();
    next.coast_frames = 0;
    return next;
  };

  auto markLostIfFarOut = [&](RegionState& s) {
    const Eigen::Vector2d cc = centre(s.box);
    const double size = std::max(s.box.width, s.box.height);
    const double dx = std::max({0.0, -cc.x(), cc.x() - image_size_.width});
    const double dy = std::max({0.0, -cc.y(), cc.y() - image_size_.height});
    if (std::hypot(dx, dy) > o.lost_distance * size) {
      s.status = RegionStatus::kLost;
      s.reason = "left the image by more than " + std::to_string(o.lost_distance) + " box sizes";
      s.confidence = 0;
    }
  };

  // Coast on the prediction (camera motion + own velocity), keeping the old
  // support: it may reappear when the occluder has passed.
  auto coast = [&]() {
    if (state.coast_frames >= o.max_coast_frames) {
      next.status = RegionStatus::kLost;
      next.reason = "occluded for more than " + std::to_string(static_cast<int>(o.max_coast_frames)) +
                    " frames";
      next.confidence = 0;
      return next;
    }
    // Where the camera puts it; its size goes on changing as it did, not as
    // the background does (a car followed by a car keeps its size while the
    // road grows), ever more slowly (kUnseenMotionFade).
    const double s = std::exp(g * state.scale_rate);
    next.scale_rate = std::pow(kUnseenMotionFade, g) * state.scale_rate;
    next.box = boxAt(centre(camera_box), s * state.box.width, s * state.box.height);
    next.box.x += object_step.x();
    next.box.y += object_step.y();
    next.velocity = (centre(next.box) - c) / g;
    next.coast_frames = state.coast_frames + 1;
    next.confidence = state.confidence * 0.9;
    next.status = fractionInside(next.box, image_size_) < o.out_of_view_fraction ? RegionStatus::kOutOfView
                                                                                 : RegionStatus::kTracked;
    markLostIfFarOut(next);
    return next;
  };

  if (in_box < o.min_features) {
    const RegionStatus st =
        frac_inside < o.out_of_view_fraction ? RegionStatus::kOutOfView : RegionStatus::kFeatureless;
    // A region that had support and is still mostly in view lost its
    // features all at once (covered, blurred, or a jump LK could not follow):
    // it coasts on its own motion like an occluded one rather than stopping
    // dead with the background. (Leaving the image takes the features along:
    // that is no reason to trust its last own motion.)
    // Its own motion was measured once min_features carried it (a small
    // target's few features: a walker's 3 to 5 at 320 px).
    if (frac_inside >= kMinInsideToCoast && state.support >= o.min_features) return coast();
    RegionState s = predictWithCamera(st);
    markLostIfFarOut(s);
    return s;
  }

  // A feature in the box supports the model when its residual is under
  // inlier_error plus a tenth of the model's own motion.
  const auto inlierThreshold = [&](const LocalModel& m) { return o.inlier_error + 0.1 * m.t.norm(); };
  // IRLS: w_i = prior_i / error_i, fitting the highest model the inliers support.
  LocalModel model;
  const auto irls = [&](int max_dof) {
    int dof = 2;
    for (int it = 0; it < o.irls_iterations; ++it) {
      if (!fitModel(vecs, c_cam, dof, &model)) {
        dof = 2;
        fitModel(vecs, c_cam, dof, &model);
      }
      int n_in = 0;
      const double thr = inlierThreshold(model);
      for (Vec& v : vecs) {
        v.error = (v.dst - model.apply(v.src_cam)).norm();
        v.weight = v.prior / std::max(v.error, o.error_floor);
        if (v.in_box && v.error < thr) ++n_in;
      }
      dof = std::min(max_dof, n_in >= o.min_inliers_similarity ? 4 : n_in >= o.min_inliers_scale ? 3 : 2);
    }
  };
  irls(4);
  // A scale seen only between the background's features and the moving
  // ones is two motions mixed (region_fit.h): the region keeps to one of
  // them by a translation fit, made afresh from the priors.
  // (Without a camera model "with the camera" means only "still": the
  // region's own corners then carry no class.)
  if (scaleOnlyBetweenClasses(vecs, model, inlierThreshold(model), kMinClassInliers,
                              camera_valid ? kOwnBackgroundResidual : 0.0)) {
    for (Vec& v : vecs) v.weight = v.prior;
    irls(2);
  }
  // The model again from the inliers alone: the features that fit it
  // worse still pull on it through their IRLS weights, most on its scale
  // (the wall around a card, at the edges of its search area).
  if (model.dof >= 3) {
    const double thr = inlierThreshold(model);
    std::vector<Vec> in;
    for (const Vec& v : vecs)
      if (v.in_box && v.error < thr) in.push_back(v);
    LocalModel refit;
    if (static_cast<int>(in.size()) >= o.min_inliers_scale && fitModel(in, c_cam, model.dof, &refit)) model = refit;
  }
  // Degree checks: fall back when scale or rotation leave their bounds.
  // The bounds are per usual frame interval: a step over g intervals may
  // scale and rotate g times as much.
  const double max_scale = g * o.max_scale_change, max_rotation = g * o.max_rotation;
  if (model.dof >= 3 && (std::abs(model.scale() - 1) > max_scale || std::abs(model.rotation()) > max_rotation)) {
    fitModel(vecs, c_cam, model.dof == 4 ? 3 : 2, &model);
    if (model.dof == 3 && std::abs(model.scale() - 1) > max_scale) fitModel(vecs, c_cam, 2, &model);
  }

  // Inliers and outliers from the final residuals.
  const double thr = inlierThreshold(model);
  std::vector<uint32_t> inliers, outliers;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  int continued = 0;
  double bg_sum = 0;  // the inliers' background weights (motion-analysis features only)
  int n_bg = 0;
  for (Vec& v : vecs) {
    v.error = (v.dst - model.apply(v.src_cam)).norm();
    if (!v.in_box) continue;
    if (v.error < thr) {
      inliers.push_back(v.id);
      centroid += v.dst;
      if (contains(state.inliers, v.id)) ++continued;
      if (v.bg >= 0) {
        bg_sum += v.bg;
        ++n_bg;
      }
    } else {
      outliers.push_back(v.id);
    }
  }

  // Occlusion: the fit rests on features that never supported the region
  // and disagrees with its predicted motion: another object covers it.
  const Eigen::Vector2d fitted_shift = model.apply(c_cam) - c;
  const Eigen::Vector2d predicted_shift = camera_shift + object_step;
  const bool conflicting = (fitted_shift - predicted_shift).norm() > std::max(3.0, 0.5 * object_step.norm());
  const double n_fit = static_cast<double>(inliers.size());
  // Support collapsed (most of the region hidden): a fit on the few
  // features left is not trusted either.
  const bool supported = state.support >= o.min_features;
  const bool collapsed = supported && n_fit < std::max<double>(o.min_features, 0.2 * state.support);
  if (collapsed || (supported && continued < o.occlusion_ratio * std::max(1.0, n_fit) && conflicting))
    return coast();

  std::sort(inliers.begin(), inliers.end());
  std::sort(outliers.begin(), outliers.end());
  // Background seen as such: features near it that moved with the camera
  // while the region clearly moved on its own (by more than twice
  // inlier_error against the camera). They keep their low prior (as an
  // outlier's) while they stay near it, also after the region slows down:
  // a card turning back moves with the wall for a few frames, and the wall
  // at the edges of its box would otherwise become its support and pull it
  // back with the wall. (Released as they fit it again, it lost a target
  // that came back from behind a panel.)
  {
    // Not on its first step (no motion of its own measured yet, and nothing
    // to tell a wrong fit by), nor without a camera model (then "with the
    // camera" would only mean "still in the image").
    const bool distinct =
        camera_valid && state.support > 0 && (fitted_shift - camera_shift).norm() > 2 * o.inlier_error;
    std::vector<uint32_t> background;
    for (const Vec& v : vecs)
      if (contains(state.background, v.id) ||
          (distinct && v.error >= thr && (v.dst - v.src_cam).norm() < o.inlier_error))
        background.push_back(v.id);
    std::sort(background.begin(), background.end());
    next.background = std::move(background);
  }
  next.box = moveBox(camera_box, model);
  // Without a scale of its own (a translation fit), the region takes the
  // camera's zoom only as far as its inliers are background (the motion
  // analysis's weights): a car followed by a car keeps its size while the
  // road around it grows; a patch on the wall zooms with the wall. Without
  // such inliers (its own features only) it takes the camera's.
  if (model.dof == 2 && n_bg > 0) {
    const double zoom = std::pow(camera_box.width / state.box.width, bg_sum / n_bg);
    next.box = boxAt(centre(next.box), zoom * state.box.width, zoom * state.box.height);
  }
  const Eigen::Vector2d shift = centre(next.box) - c;
  const bool first = state.support == 0;
  const double blend = first ? 0.0 : o.velocity_blend;
  next.velocity = blend * state.velocity + (1 - blend) * shift / g;
  next.object_velocity = blend * state.object_velocity + (1 - blend) * (shift - camera_shift) / g;
  next.scale_rate = blend * state.scale_rate + (1 - blend) * std::log(next.box.width / state.box.width) / g;
  if (!inliers.empty()) centroid /= static_cast<double>(inliers.size());
  else centroid = centre(next.box);
  next.inlier_centroid = cv::Point2d(centroid.x(), centroid.y());
  Eigen::Vector2d var = Eigen::Vector2d::Zero();
  for (const Vec& v : vecs)
    if (v.in_box && v.error < thr) var += (v.dst - centroid).cwiseAbs2();
  if (!inliers.empty()) var /= static_cast<double>(inliers.size());
  next.inlier_extent = cv::Size2d(3.3 * std::sqrt(var.x()), 3.3 * std::sqrt(var.y()));
  next.inliers = std::move(inliers);
  next.outliers = std::move(outliers);
  next.support = std::max(static_cast<double>(next.inliers.size()), 0.98 * state.support);
  next.coast_frames = 0;
  next.confidence = std::min(1.0, next.inliers.size() / o.confidence_inliers);
  next.status = fractionInside(next.box, image_size_) < o.out_of_view_fraction ? RegionStatus::kOutOfView
                                                                               : RegionStatus::kTracked;
  markLostIfFarOut(next);
  return next;
}

}  // namespace imt
