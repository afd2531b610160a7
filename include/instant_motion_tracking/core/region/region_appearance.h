// The look of a region: a small gray template of its box, matched by
// normalised cross-correlation (OpenCV's matchTemplate) around where the
// motion data puts the region, at three scales. The region tracker uses it to
// correct slow drift, to notice that a region no longer looks like itself,
// and to find a lost region again (region_tracker.h).
//
// The template has a fixed pixel size for the region's life: the box scaled
// so its longer side is `size` px (never enlarged: a small box keeps its own
// pixels). It is the look at placement, blended with later looks only on
// confident frames, so it follows slow changes of view and light without
// taking on what drifted into the box.
//
// Usage:
//   imt::RegionAppearance a;
//   if (imt::RegionAppearance::create(gray, box, 40, &a)) {
//     imt::AppearanceMatch m = a.match(next_gray, predicted_box, 0.35);
//     if (m.found && m.score > 0.6) use(m.box);
//     a.blend(next_gray, final_box, 0.1);
//   }
// Threading: plain value type; const methods may run concurrently.
#pragma once

#include <opencv2/core.hpp>

#include <cmath>
#include <vector>

namespace imt {

// The best match of a template in a search window.
struct AppearanceMatch {
  bool found = false;        // false: no window to search (the box left the image, or too small)
  cv::Rect2d box;            // the best-matching box (px)
  double score = -1;         // its normalised cross-correlation, -1 .. 1
  double score_at_box = -1;  // the same at the box searched around (no shift, same scale)
};

class RegionAppearance {
 public:
  // The look of `box` turned by `angle` (rad) in `gray` (CV_8UC1), scaled to
  // `size` px along its longer side (at most 1:1). False when the box is
  // mostly outside the image, smaller than 4 px, or flat (no contrast to match).
  static bool create(const cv::Mat& gray, const cv::Rect2d& box, int size, RegionAppearance* out, double angle = 0);

  bool valid() const { return !templ_.empty(); }
  // Scales searched: a tracked region's (its size is known within a few
  // percent) and a lost one's (its size changed unseen while it was lost).
  static const std::vector<double>& trackedScales();
  static const std::vector<double>& lostScales();
  // Searches `gray` around `box`: shifts up to `margin` times the box's
  // sides either way, at the box's size times each of `scales` (a scale
  // other than 1 must beat 1 by 0.01 to win). `angle` (rad): the region is
  // turned in the image by this much about the box's centre since its look
  // was taken (x toward y); the search runs along its turned axes and the
  // match's box is the unturned rect about the matched centre.
  AppearanceMatch match(const cv::Mat& gray, const cv::Rect2d& box, double margin,
                        const std::vector<double>& scales = trackedScales(), double angle = 0) const;
  // The look of `box` turned by `angle` in `gray` blended in with weight `rate` (0 .. 1).
  void blend(const cv::Mat& gray, const cv::Rect2d& box, double rate, double angle = 0);
  // Matches over the whole image at the size of `box` times each of
  // `scales` (anywhere), turned by `angle`: finding a region that was lost.
  // Coarse to fine: one search with the template shrunk to 12 px at the
  // box's size, then the whole template at each scale close around its best.
  AppearanceMatch matchAnywhere(const cv::Mat& gray, const cv::Rect2d& box,
                                const std::vector<double>& scales = lostScales(), double angle = 0) const;
  // A lost region's search around its last place, shifts up to `margin`
  // times the box's sides either way along its turned axes, coarse to fine
  // as matchAnywhere(): one search with the template shrunk to 12 px at the
  // box's size, then the whole template at each of `scales` close around
  // the best place (`score_at_box` is that place's, not `box`'s).
  AppearanceMatch matchWide(const cv::Mat& gray, const cv::Rect2d& box, double margin,
                            const std::vector<double>& scales = lostScales(), double angle = 0) const;
  // The correlation of the look with `box` turned by `angle` in `gray`, as
  // it stands (no search); -1 when too little of it is in the image.
  double scoreAt(const cv::Mat& gray, const cv::Rect2d& box, double angle = 0) const;
  // Turns this small are read as none (the template's corners move by under
  // a fifth of a pixel): the cheaper axis-aligned sampling.
  static bool unturned(double angle) { return std::abs(angle) < 0.005; }

 private:
  // The coarse-to-fine search of matchAnywhere() and matchWide() within
  // `area` (at least `min_inside` of it in the image), read along the
  // region's turned axes about the area's centre when `along_axes`.
  AppearanceMatch matchCoarse(const cv::Mat& gray, const cv::Rect2d& box, const cv::Rect2d& area,
                              double min_inside, bool along_axes, const std::vector<double>& scales,
                              double angle) const;
  cv::Mat templ_;  // CV_32F, fixed size for the region's life
};

}  // namespace imt
