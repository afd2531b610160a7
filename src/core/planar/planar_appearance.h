// Internal to the core library (not installed): the image side of the planar
// targets' appearance alignment (planar_target.cpp). The target's appearance
// at placement is kept as a pyramid of rectified templates; these functions
// sample a frame on such a template's grid, find what covers the target in
// it, and search a window for it.
//
// Pixel conventions: "our" pixels have centres at +0.5 (docs/conventions.md);
// templates and image pyramid levels use OpenCV's (centres at integers).
#pragma once

#include "instant_motion_tracking/core/camera_model.h"

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

namespace imt {
namespace planar_detail {

// Template pixel of pyramid level `level` (OpenCV: centres at integers) ->
// target plane point (X, Y, 1), for a level-0 template of `px_per_m`. pyrDown
// keeps OpenCV pixel coordinates proportional (level-l pixel u is level-0
// pixel 2^l u).
Eigen::Matrix3d templateToPlane(double px_per_m, int level, double w, double h);

// Our pixel (centres at +0.5, docs/conventions.md) of the full image -> OpenCV
// pixel of image pyramid level `level` (see templateToPlane on pyrDown).
Eigen::Matrix3d toPyramidPixel(int level);

// A bound (px) on how far the map `M` (a grid pixel to a pixel, as
// warpPerspective with WARP_INVERSE_MAP takes it) moves any pixel of a grid
// of `size` along x or y; infinite when part of the grid goes to the horizon.
double displacementBound(const cv::Matx33d& M, cv::Size size);
// Whether warping a grid of `size` by `warp` with INTER_NEAREST leaves every
// pixel where it was.
bool movesNoPixel(const cv::Matx33d& warp, cv::Size size);
cv::Matx33d toMatx(const Eigen::Matrix3d& M);

// The pyramid level at which an image seen `ratio` image pixels per template
// pixel is sampled about 1:1.
int imageLevelFor(double ratio);

// Level `level` of the image pyramid of `gray` (each level pyrDown of the one
// below) sampled on a grid of `size` through `M` (grid pixel, OpenCV -> our
// pixel of the full image), as CV_32F, and the mask of samples that fell
// inside the image. Only the part of the image under the grid (with a margin
// for the filters) is reduced, so the cost follows the target's size on
// screen rather than the frame's. With a distorting `lens`, M maps to ideal
// pinhole pixels and each grid pixel is looked up where the lens shows it
// (lens->distort(M g)): the template then lives on the undistorted plane, so
// the alignment's homography stays exact through the lens (remap instead of
// warpPerspective; without distortion, or lens == nullptr, the plain warp).
void sampleImage(const cv::Mat& gray, int level, const Eigen::Matrix3d& M, cv::Size size,
                 cv::Mat* out, cv::Mat* valid, const CameraModel* lens = nullptr);

// The pixels of `valid` where `aligned` (the frame on the template grid)
// shows the template, i.e. without what covers it (an occluder, a
// reflection). The photometric change is a gain and an offset, fitted to the
// better half of the pixels (trimmed least squares: robust to up to half the
// target covered). A pixel is an outlier when it is farther from that than
// `k_sigma` times its expected error: the noise level, and on the template's
// edges what a misalignment by `shift` px adds (`grad`: the template's
// gradient magnitude). Where outliers are dense (more than half of a window
// ~1/8 of the template) the template is taken as covered; isolated ones are
// noise, not occluders. After an alignment (`shift` at most 1 px) a textured
// part of the template is also taken as covered where its correlation with
// `aligned` over such a window is low: a textured occluder passes the
// residual test where the tolerance for misalignment is large, but does not
// correlate with what it hides. `whole_windows` (optional,
// TemplateWindows::of(tpl)) spares computing the template's side of that
// correlation again when `valid` is 255 everywhere.
struct TemplateWindows;
cv::Mat unoccludedPixels(const cv::Mat& tpl, const cv::Mat& grad, const cv::Mat& aligned,
                         const cv::Mat& valid, double k_sigma, double shift,
                         const TemplateWindows* whole_windows = nullptr);

// The template's side of unoccludedPixels' local correlation, over its
// windows of valid pixels: their share of the window (at least 1e-3), where
// it is most of the window (`seen`, CV_8U 255), and the template's mean and
// variance there.
struct TemplateWindows {
  cv::Mat n, seen, mean, var;                     // CV_32F but `seen`
  static TemplateWindows of(const cv::Mat& tpl);  // every pixel of `tpl` valid
};

// A template (pyramid level) prepared for alignEcc once: smoothed as
// findTransformECC smooths both images (5x5 Gaussian), its gradients (central
// differences), and its pixel grid in normalised coordinates (centre 0, half
// the long side 1) in which the warp is parametrised.
struct EccTemplate {
  cv::Mat smoothed, gx, gy;  // CV_32F
  cv::Mat xn, yn;            // CV_32F: (x - cx) / s, (y - cy) / s
  double cx = 0, cy = 0, s = 1;
  static EccTemplate from(const cv::Mat& tpl);  // tpl: CV_32F
};

// Aligns the template `t` with `image` (CV_32F, the frame on the template's
// grid; `image_valid` CV_8U, 255 where it shows the frame) by the enhanced
// correlation coefficient (ECC), as findTransformECC does and with the same
// meaning of its arguments and result: `warp` (updated) maps a template pixel
// to where it is in `image`; only the template pixels in `mask` (CV_8U, 255)
// count, eroded by the smoothing's reach as findTransformECC erodes it; a
// homography or (`affine`) an affine map; iterations stop as `criteria`
// says; `*rho` is the correlation before the last update. Unlike
// findTransformECC the update is inverse compositional (Baker and Matthews):
// the Jacobian lives on the template, so per alignment the mask's sums are
// computed once and an iteration warps the frame once, where
// findTransformECC warps the frame and both its gradients and rebuilds the
// Jacobian and Hessian. The mask stays on the template grid (a template pixel
// the warp takes off `image_valid` leaves it). False when it did not
// converge (too few pixels, or the images are not correlated).
bool alignEcc(const EccTemplate& t, const cv::Mat& image, const cv::Mat& image_valid, const cv::Mat& mask,
              bool affine, const cv::TermCriteria& criteria, Eigen::Matrix3d* warp, double* rho);

// Gradient magnitude of `im` (intensity per pixel).
cv::Mat gradientMagnitude(const cv::Mat& im);

// The short side (px) of the template level a search matches at, at least.
constexpr int kMinSearchSide = 24;

// What searchTemplate found.
struct SearchMatch {
  cv::Point2d shift;   // template px; the best match's offset from the window's centre
  double score = -1;   // that match's score (normalised correlation, -1..1)
  double second = -1;  // the best score away from it (a second candidate)
  int tiles = 0;       // textured tiles that took part
  cv::Mat seen;        // CV_8U on the template: 255 but on textured tiles that do not match there
};

// Where `tpl` (CV_32F, `mask`: 255 where it is known) best matches `window`
// (the frame on the template's grid, widened by `margin` px on every side),
// over shifts of up to `margin` px. The template is cut into tiles of about
// half its short side, each matched on its own (normalised correlation), and
// a shift scores the mean of its better half of tiles: a part of the target
// covered by something else neither counts nor drags the match. The second
// score is the best one farther than half a tile from the best (a repeated
// pattern, or no clear match at all, scores about as well there).
SearchMatch searchTemplate(const cv::Mat& tpl, const cv::Mat& mask, const cv::Mat& window,
                           int margin);

}  // namespace planar_detail
}  // namespace imt
