// PlanarTargetTracker's appearance alignment (see planar_target.h): the
// target's look at placement, rectified onto its plane, aligned with each
// frame by ECC, and searched for when the alignment lost it.
#include "instant_motion_tracking/core/planar/planar_target.h"

#include "planar_appearance.h"
#include "planar_internal.h"

#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace imt {

using namespace planar_detail;

Eigen::Matrix3d PlanarTargetTracker::planeToImage() const {
  const Eigen::Matrix3d K =
      (Eigen::Matrix3d() << k_.fx, 0, k_.cx, 0, k_.fy, k_.cy, 0, 0, 1).finished();
  Eigen::Matrix3d Rt;
  Rt.col(0) = state_.T_cam_target.linear().col(0);
  Rt.col(1) = state_.T_cam_target.linear().col(1);
  Rt.col(2) = state_.T_cam_target.translation();
  return K * Rt;
}

// The target's look at placement: the frame resampled onto the target plane
// at about the resolution it was seen with (at most template_size px).
bool PlanarTargetTracker::captureAppearance(const cv::Mat& gray, const cv::Mat& picture) {
  if (picture.empty() && (gray.empty() || gray.type() != CV_8UC1)) return false;
  const double w = state_.width_m, h = state_.height_m;
  const double seen = longestEdge(state_.corners);
  // From the frame no finer than it sees the target; a picture is sharp at
  // any size (the alignment picks the level the frame needs).
  // (A picture smaller than template_size is kept at its own size: a look at
  // placement found again, cut from a frame.)
  const double long_px = std::min<double>(
      options_.template_size, picture.empty() ? seen : std::max(picture.cols, picture.rows));
  const int W = std::max(16, static_cast<int>(std::lround(long_px * w / std::max(w, h))));
  const int H = std::max(16, static_cast<int>(std::lround(long_px * h / std::max(w, h))));
  auto a = std::make_shared<Appearance>();
  a->px_per_m = W / w;
  cv::Mat tpl, valid;
  if (picture.empty()) {
    const int li = imageLevelFor(seen / long_px);
    sampleImage(gray, li, planeToImage() * templateToPlane(a->px_per_m, 0, w, h), cv::Size(W, H), &tpl, &valid,
                &k_);
  } else {
    // Its corners are the target's: stretched to the target's proportions.
    cv::resize(picture, tpl, cv::Size(W, H), 0, 0, cv::INTER_AREA);
    tpl.convertTo(tpl, CV_32F);
    valid = cv::Mat(tpl.size(), CV_8U, cv::Scalar(255));
  }
  cv::Scalar mean, stddev;
  cv::meanStdDev(tpl, mean, stddev, valid);
  if (cv::countNonZero(valid) < 0.5 * W * H || stddev[0] < 2.0)
    return false;  // mostly unseen, or featureless
  a->levels.push_back(tpl);
  a->masks.push_back(valid);
  while (std::min(a->levels.back().cols, a->levels.back().rows) >= 48 && a->levels.size() < 5) {
    cv::Mat down, mask;
    cv::pyrDown(a->levels.back(), down);
    cv::resize(a->masks.back(), mask, down.size(), 0, 0, cv::INTER_NEAREST);
    cv::erode(mask, mask, cv::Mat());
    a->levels.push_back(down);
    a->masks.push_back(mask);
  }
  for (const cv::Mat& l : a->levels) {
    a->gradients.push_back(gradientMagnitude(l));
    a->windows.push_back(TemplateWindows::of(l));
    a->ecc.push_back(EccTemplate::from(l));
  }
  appearance_ = std::move(a);
  return true;
}

cv::Mat PlanarTargetTracker::lookAtPlacement() const {
  if (!appearance_ || appearance_->levels.empty()) return cv::Mat();
  const cv::Mat& level = appearance_->levels[0];
  const cv::Mat& seen = appearance_->masks[0];
  if (cv::countNonZero(seen) < 0.99 * seen.total()) return cv::Mat();  // not seen whole
  cv::Mat look;
  level.convertTo(look, CV_8U);
  look.setTo(cv::mean(look, seen), ~seen);
  return look;
}

// Aligns the appearance at placement with `gray` by ECC (alignEcc: the
// correlation findTransformECC maximises, a homography on the rectified
// target, coarse to fine),
// starting from the plane-to-image homography `*G` (updated). Whatever covers
// part of the target (an occluder) is masked out: after each alignment the
// template pixels the frame does not explain are found (unoccludedPixels) and,
// when they changed, the alignment is redone from the same start without
// them, so an occluder cannot drag the target. With less than half of the
// target seen the alignment is affine, not a homography: the part left (a
// strip beside an occluder) does not constrain the perspective, which then
// swung the far corners by many px. `seen` (optional, on the
// template, e.g. from search()) excludes parts known to be covered from the
// start: with much of the target covered, the photometric fit behind
// unoccludedPixels may take the occluder for the target. False when the
// alignment failed; else `*cc` (ECC correlation) and `*visible` (fraction of the target
// in view seen uncovered) say how well it fits.
bool PlanarTargetTracker::align(const cv::Mat& gray, Eigen::Matrix3d* G, double* cc,
                                double* visible, const cv::Mat& seen) const {
  const Appearance& a = *appearance_;
  const double w = state_.width_m, h = state_.height_m;
  const double r0 = longestEdge(state_.corners) /
                    std::max(a.levels[0].cols, a.levels[0].rows);  // image px per template px
  const int top = static_cast<int>(a.levels.size()) - 1;
  const int lt = r0 >= 1 ? 0 : std::min(top, static_cast<int>(std::lround(std::log2(1 / r0))));
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS,
                                  options_.refine_iterations, options_.refine_epsilon);
  cv::Mat keep;  // template pixels (current level) not covered by anything
  *cc = 0;
  *visible = 0;
  for (int l = std::min(top, lt + 1); l >= lt; --l) {
    const int li = imageLevelFor(r0 * (1 << l));
    const Eigen::Matrix3d A = templateToPlane(a.px_per_m, l, w, h);
    const cv::Mat& tpl = a.levels[l];
    cv::Mat warped, valid;
    sampleImage(gray, li, *G * A, tpl.size(), &warped, &valid, &k_);
    cv::bitwise_and(valid, a.masks[l], valid);
    const int n_valid = cv::countNonZero(valid);
    if (n_valid < 0.25 * valid.total()) return false;  // mostly outside the frame
    cv::Mat seen_here;  // the part a search saw uncovered, at this level
    if (!seen.empty()) {
      cv::resize(seen, seen_here, tpl.size(), 0, 0, cv::INTER_NEAREST);
      cv::bitwise_and(valid, seen_here, valid);
    }
    if (keep.empty()) {  // what covers the target where it is predicted
      keep = unoccludedPixels(tpl, a.gradients[l], warped, valid, options_.refine_outlier_sigma,
                              2.0, &a.windows[l]);
    } else {
      cv::resize(keep, keep, tpl.size(), 0, 0, cv::INTER_NEAREST);
      cv::bitwise_and(keep, valid, keep);
    }
    Eigen::Matrix3d C;
    for (int round = 0; round < 3; ++round) {
      C.setIdentity();
      const int kept = cv::countNonZero(keep);
      if (kept < 0.1 * valid.total())
        return false;  // hardly anything left to align
      // Less than half the target seen: its perspective is not constrained
      // by the part left (a strip beside an occluder), an affine map is.
      const bool affine = kept < 0.5 * n_valid;
      if (!alignEcc(a.ecc[l], warped, valid, keep, affine, criteria, &C, cc))
        return false;  // did not converge (uncorrelated images)
      const cv::Matx33d warp = toMatx(C);
      cv::Mat aligned, aligned_valid;
      cv::warpPerspective(warped, aligned, warp, tpl.size(),
                          cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
      if (movesNoPixel(warp, tpl.size())) {  // the nearest-pixel warp of `valid` is `valid`
        aligned_valid = valid;
      } else {
        cv::warpPerspective(valid, aligned_valid, warp, tpl.size(),
                            cv::INTER_NEAREST | cv::WARP_INVERSE_MAP);
        cv::bitwise_and(aligned_valid, valid, aligned_valid);
      }
      const cv::Mat now = unoccludedPixels(tpl, a.gradients[l], aligned, aligned_valid,
                                           options_.refine_outlier_sigma, 0.5, &a.windows[l]);
      // Realigned only when a real part of the target turned out covered.
      const int newly_covered = cv::countNonZero(keep & ~now);
      keep = now;
      if (newly_covered < 0.05 * n_valid) break;
    }
    *visible = static_cast<double>(cv::countNonZero(keep)) / n_valid;
    if (!C.allFinite()) return false;
    *G = *G * A * C * A.inverse();
  }
  return true;
}

// Looks for the appearance at placement in a window around where the
// plane-to-image homography `*G` puts it (re-acquisition after the target
// was lost to an occluder or drifted beyond ECC's reach): the frame is
// resampled on the grid of a coarse template level widened by
// refine_search_range of the target's size on each side, and searchTemplate
// finds the shift. True with `*G` moved there and `*seen` the part of the
// template that matched (searchTemplate), when the best match is strong and
// clearly better than any other (a repeated pattern or a target not in the
// window gives no answer).
bool PlanarTargetTracker::search(const cv::Mat& gray, Eigen::Matrix3d* G, cv::Mat* seen) const {
  const Appearance& a = *appearance_;
  const double w = state_.width_m, h = state_.height_m;
  const double r0 = longestEdge(state_.corners) / std::max(a.levels[0].cols, a.levels[0].rows);
  const int top = static_cast<int>(a.levels.size()) - 1;
  const int lt = r0 >= 1 ? 0 : std::min(top, static_cast<int>(std::lround(std::log2(1 / r0))));
  int ls = lt;  // the coarsest level still about kMinSearchSide px on its short side
  while (ls < top && std::min(a.levels[ls + 1].cols, a.levels[ls + 1].rows) >= kMinSearchSide) ++ls;
  const cv::Mat& tpl = a.levels[ls];
  const int margin =
      static_cast<int>(std::ceil(options_.refine_search_range * std::max(tpl.cols, tpl.rows)));
  const Eigen::Matrix3d A = templateToPlane(a.px_per_m, ls, w, h);
  Eigen::Matrix3d widen = Eigen::Matrix3d::Identity();
  widen(0, 2) = widen(1, 2) = -margin;
  cv::Mat window, valid;
  sampleImage(gray, imageLevelFor(r0 * (1 << ls)), *G * A * widen,
              cv::Size(tpl.cols + 2 * margin, tpl.rows + 2 * margin), &window, &valid, &k_);
  const SearchMatch m = searchTemplate(tpl, a.masks[ls], window, margin);
  if (!(m.score >= options_.refine_search_min_score) ||
      !(m.score - m.second >= options_.refine_search_margin))
    return false;
  Eigen::Matrix3d S = Eigen::Matrix3d::Identity();
  S(0, 2) = m.shift.x;
  S(1, 2) = m.shift.y;
  *G = *G * A * S * A.inverse();
  *seen = m.seen;
  return true;
}

// Aligns the appearance at placement with `gray` (align()), from the current
// pose or, when that fails or fits loosely or the target was not aligned on
// the last frame, from where a search (search()) finds it, then fits the
// rigid pose to the aligned plane. The alignment is used only when enough of
// the target is seen, it correlates well and it moves the target by a
// plausible amount from where it started: a target aligned on the last frame
// moves little from where the features or the camera motion put it (the
// longer it went unaligned, the farther), and an alignment started at a
// search's unambiguous match (anywhere in the search window) moves as little
// from that match.
bool PlanarTargetTracker::refine(const cv::Mat& gray) {
  state_.correlation = 0;
  state_.visible = 0;
  if (gray.empty() || gray.type() != CV_8UC1) return false;
  if (!appearance_) {
    captureAppearance(gray);
    return false;
  }
  const double w = state_.width_m, h = state_.height_m;
  const double seen = longestEdge(state_.corners);
  const double allowed =
      std::min(options_.refine_max_correction, options_.refine_max_step * (1 + frames_unaligned_)) *
          seen +
      1.0;
  const Eigen::Matrix3d G0 = planeToImage();
  // How far the aligned plane `G` moves the target's corners from `from`.
  const auto correction = [&](const Eigen::Matrix3d& G, const Eigen::Matrix3d& from) {
    double c = 0;
    for (const Eigen::Vector3d& p : targetCorners(w, h)) {
      const Eigen::Vector3d a = G * Eigen::Vector3d(p.x(), p.y(), 1);
      const Eigen::Vector3d b = from * Eigen::Vector3d(p.x(), p.y(), 1);
      if (!(a.z() > 0) || !(b.z() > 0)) return 1e18;
      c = std::max(c, (a.head<2>() / a.z() - b.head<2>() / b.z()).norm());
    }
    return c;
  };
  const auto usable = [&](const Eigen::Matrix3d& G, const Eigen::Matrix3d& from, double cc,
                          double visible) {
    return cc >= options_.refine_min_correlation && visible >= options_.refine_min_visible &&
           correction(G, from) <= allowed;
  };
  Eigen::Matrix3d G = G0;
  double cc = 0, visible = 0;
  bool ok = false;
  // A target aligned on the last frame: from where it is now.
  if (frames_unaligned_ == 0) ok = align(gray, &G, &cc, &visible) && usable(G, G0, cc, visible);
  // Otherwise, or when that failed or fits only loosely (something covering
  // the target may have dragged it), from where a search finds it (anywhere
  // in its window), without the part the search saw covered; the alignment
  // then only refines what the search found. The better fit is kept.
  cv::Mat seen_by_search;
  Eigen::Matrix3d G_found = G0;
  if ((!ok || cc < options_.refine_search_below) && options_.refine_search_range > 0 &&
      search(gray, &G_found, &seen_by_search)) {
    Eigen::Matrix3d G_s = G_found;
    double cc_s = 0, visible_s = 0;
    if (align(gray, &G_s, &cc_s, &visible_s, seen_by_search) &&
        usable(G_s, G_found, cc_s, visible_s) && (!ok || cc_s > cc)) {
      G = G_s;
      cc = cc_s;
      visible = visible_s;
      ok = true;
    }
  }
  // No clear match: from where it is now, as far as a step allows.
  if (!ok && frames_unaligned_ > 0) {
    G = G0;
    ok = align(gray, &G, &cc, &visible) && usable(G, G0, cc, visible);
  }
  if (!ok) return false;
  // The aligned plane, seen through a grid of points, gives the rigid pose.
  std::vector<PlaneObservation> grid;
  for (int i = 0; i <= 4; ++i) {
    for (int j = 0; j <= 4; ++j) {
      const Eigen::Vector2d xy((i / 4.0 - 0.5) * w, (j / 4.0 - 0.5) * h);
      const Eigen::Vector3d p = G * Eigen::Vector3d(xy.x(), xy.y(), 1);
      if (!(p.z() > 0)) return false;
      grid.push_back({0, xy, p.head<2>() / p.z()});
    }
  }
  Eigen::Isometry3d T = state_.T_cam_target;
  if (!fitPose(grid, k_, 0, options_.max_iterations, &T)) return false;
  state_.T_cam_target = T;
  state_.correlation = cc;
  state_.visible = visible;
  return true;
}

}  // namespace imt
