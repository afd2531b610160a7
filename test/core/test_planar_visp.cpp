// Planar target tracking on ViSP's real handheld clips (../shared/data,
// skipped when absent). Neither clip has ground truth, so each test derives a
// reference from the images by a method that shares nothing with the tracker:
//  - mire-2 (a black square with four white dots on a box, 384x288, the first
//    frame motion-blurred): the dots' centres, each followed by its own local
//    threshold and connected component. The seeds below were read by eye on
//    frame 1; the centres were checked by eye, drawn on every 15th frame.
//  - cube (a tabletop of posters, a cube standing on it, 384x288): the
//    homography of frame 0 to each frame, from SIFT matches inside the target
//    fitted by RANSAC (the cube's matches are its outliers).
// The planar target is given at the first frame, through the whole pipeline
// (motion analysis, cache, planar manager), with the intrinsics of an assumed
// field of view as in the POT test.
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/planar/planar_target_manager.h"

#include "planar_real.h"
#include "scene_test_util.h"
#include "shared_data.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <optional>

namespace imt {
namespace {

std::string frameName(const std::string& dir, int f) {
  char name[64];
  std::snprintf(name, sizeof(name), "/img/image.%04d.png", f);
  return test::sharedDataDir() + "/" + dir + name;
}

// The homography from the unit square to a quad (TL, TR, BR, BL).
cv::Matx33d squareTo(const std::array<cv::Point2d, 4>& quad) {
  const std::vector<cv::Point2d> square = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  return cv::Matx33d(
      cv::findHomography(square, std::vector<cv::Point2d>(quad.begin(), quad.end())));
}

cv::Point2d mapPoint(const cv::Matx33d& H, const cv::Point2d& p) {
  const cv::Vec3d q = H * cv::Vec3d(p.x, p.y, 1);
  return {q[0] / q[2], q[1] / q[2]};
}

std::array<cv::Point2d, 4> mapQuad(const cv::Matx33d& H, const std::array<cv::Point2d, 4>& q) {
  return {mapPoint(H, q[0]), mapPoint(H, q[1]), mapPoint(H, q[2]), mapPoint(H, q[3])};
}

// A frame without a pose: counted as far off.
constexpr double kNoPose = 500;

// One white dot on a dark ground, followed from frame to frame: Otsu's
// threshold in a window around the prediction, the bright component nearest
// to it (of an area near the last one), the window moved onto the component
// until it lies inside, and the centre weighted by brightness.
class DotFollower {
 public:
  explicit DotFollower(cv::Point2d seed) : centre_(seed) {}

  // False (the centre kept) when no component of the dot's kind is found.
  bool update(const cv::Mat& gray) {
    cv::Point2d at = centre_ + velocity_;
    for (int attempt = 0; attempt < 4; ++attempt) {
      const cv::Rect win = cv::Rect(static_cast<int>(std::lround(at.x)) - kRadius,
                                    static_cast<int>(std::lround(at.y)) - kRadius, 2 * kRadius + 1,
                                    2 * kRadius + 1) &
                           cv::Rect(0, 0, gray.cols, gray.rows);
      if (win.area() < kRadius * kRadius) return false;
      const cv::Mat roi = gray(win);
      cv::Mat bw, labels, stats, centres;
      const double t = cv::threshold(roi, bw, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
      const int n = cv::connectedComponentsWithStats(bw, labels, stats, centres, 8);
      int best = -1;
      double best_distance = 1e9;
      for (int i = 1; i < n; ++i) {
        const double a = stats.at<int>(i, cv::CC_STAT_AREA);
        if (area_ > 0 && (a < 0.4 * area_ || a > 2.5 * area_)) continue;
        const cv::Point2d c(centres.at<double>(i, 0) + win.x, centres.at<double>(i, 1) + win.y);
        if (cv::norm(c - at) < best_distance) best_distance = cv::norm(c - at), best = i;
      }
      if (best < 0) return false;
      const cv::Rect box(
          stats.at<int>(best, cv::CC_STAT_LEFT), stats.at<int>(best, cv::CC_STAT_TOP),
          stats.at<int>(best, cv::CC_STAT_WIDTH), stats.at<int>(best, cv::CC_STAT_HEIGHT));
      if (box.x == 0 || box.y == 0 || box.br().x == win.width || box.br().y == win.height) {
        at = {centres.at<double>(best, 0) + win.x, centres.at<double>(best, 1) + win.y};
        continue;  // cut by the window: look again around it
      }
      cv::Mat mask = labels == best;
      cv::dilate(mask, mask, cv::Mat());  // the blurred rim counts, by its brightness
      double sw = 0, sx = 0, sy = 0;
      for (int y = 0; y < roi.rows; ++y)
        for (int x = 0; x < roi.cols; ++x) {
          if (!mask.at<uchar>(y, x)) continue;
          const double w = std::max(0.0, roi.at<uchar>(y, x) - 0.5 * t);
          sw += w, sx += w * x, sy += w * y;
        }
      const cv::Point2d c(sx / sw + win.x, sy / sw + win.y);
      if (area_ > 0) velocity_ = c - centre_;
      centre_ = c;
      area_ = stats.at<int>(best, cv::CC_STAT_AREA);
      return true;
    }
    return false;
  }
  cv::Point2d centre() const { return centre_; }

 private:
  static constexpr int kRadius = 15;  // px; the dots are ~15 px across, move up to ~10 px a frame
  cv::Point2d centre_, velocity_;
  double area_ = 0;
};

// Runs the whole pipeline over frames first..last of a clip with a planar
// target given at `first` by its corners, and hands each frame's state (empty
// when the target gave none), the first's included, to `score`.
template <typename Score>
void trackClip(const std::string& dir, int first, int last,
               const std::array<cv::Point2d, 4>& corners, const CameraModel& k, Score score) {
  MotionAnalyzer analyzer(MotionAnalysisOptions{});
  MotionCache cache(0.0);
  cache.setImageBudget(size_t(1) << 28);
  PlanarTargetManager targets(PlanarTargetOptions{}, &cache);
  for (int f = first; f <= last; ++f) {
    const cv::Mat gray = cv::imread(frameName(dir, f), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(gray.empty()) << frameName(dir, f);
    std::string err;
    cache.push(analyzer.process(gray, (f - first) / 25.0), &err, gray);
    if (f == first) {
      const double aspect = test::rectifiedAspect(corners, k);
      ASSERT_GT(aspect, 0);
      uint32_t id = 0;
      ASSERT_TRUE(targets.add(0, 0, corners, 1.0, aspect, k, &id, &err)) << err;
    }
    std::vector<PlanarTargetState> states;
    if (f == first)
      EXPECT_TRUE(targets.statesAt(0, {}, &states, &err)) << err;
    else
      states = targets.update();
    score(f, states.empty() ? std::nullopt : std::optional<PlanarTargetState>(states[0]));
  }
}

struct Errors {
  std::vector<double> px;
  void print(const char* what) {
    std::sort(px.begin(), px.end());
    std::printf("%s: %zu frames, P@5 %.2f, P@2 %.2f, median %.2f px, worst %.2f px\n", what,
                px.size(), test::precisionAt(px, 5), test::precisionAt(px, 2),
                px.empty() ? 0 : px[px.size() / 2], px.empty() ? 0 : px.back());
  }
  double median() const { return px.empty() ? 1e9 : px[px.size() / 2]; }
  double worst() const { return px.empty() ? 1e9 : px.back(); }
};

bool haveClip(const std::string& dir) {
  return test::pathExists(test::sharedDataDir() + "/" + dir + "/img");
}

// The focal length (px) under which a quad (TL, TR, BR, BL) is the view of a
// rectangle, with the principal point at the image centre and square pixels:
// the homography H from the unit square is K [r1, r2, t] up to scale, and
// r1 . r2 = 0 gives f^2 = -(h11 h12 + h21 h22) / (h31 h32). 0 where the quad
// says nothing (a fronto-parallel view) or contradicts a rectangle.
double focalOfRectangle(const std::array<cv::Point2d, 4>& quad, cv::Size image) {
  std::array<cv::Point2d, 4> centred = quad;
  for (cv::Point2d& p : centred)
    p -= cv::Point2d(0.5 * (image.width - 1), 0.5 * (image.height - 1));
  const cv::Matx33d H = squareTo(centred);
  const double f2 = -(H(0, 0) * H(0, 1) + H(1, 0) * H(1, 1)) / (H(2, 0) * H(2, 1));
  return std::isfinite(f2) && f2 > 0 ? std::sqrt(f2) : 0;
}

// mire-2: the target is the black square around the dots, given as the dots'
// quad widened by a fifth of its side each way (in the target's plane) at
// frame `start`, and scored by where its pose puts the four dots against their
// followed centres (RMS of the four distances) on every later frame to 150.
// The clip has no intrinsics, and a rigid rectangle's pose cannot reproduce a
// quad under a wrong focal length (under the 60 degree default the target's
// own quad is about 3 px off at once), so the focal length is the median over the
// clip of the one the dots' rectangle implies (577-614 px, a field of view of
// about 36 degrees).
Errors trackMire2(int start) {
  const std::string dir = "visp_mire2_planar_target";
  const int last = 150;
  Errors errors;
  // The reference: the dots' centres in every frame.
  std::array<DotFollower, 4> dots = {DotFollower({85, 178}), DotFollower({215, 166}),
                                     DotFollower({242, 246}), DotFollower({93, 265})};
  std::vector<std::array<cv::Point2d, 4>> reference(last + 1);
  std::vector<double> focals;
  cv::Size size;
  for (int f = 1; f <= last; ++f) {
    const cv::Mat gray = cv::imread(frameName(dir, f), cv::IMREAD_GRAYSCALE);
    EXPECT_FALSE(gray.empty()) << frameName(dir, f);
    if (gray.empty()) return errors;
    size = gray.size();
    for (int i = 0; i < 4; ++i) {
      EXPECT_TRUE(dots[i].update(gray)) << "the reference lost dot " << i << " at frame " << f;
      reference[f][i] = dots[i].centre();
    }
    if (const double focal = focalOfRectangle(reference[f], size); focal > 0)
      focals.push_back(focal);
  }
  EXPECT_GT(focals.size(), size_t(last / 2));
  if (focals.empty()) return errors;
  std::nth_element(focals.begin(), focals.begin() + focals.size() / 2, focals.end());
  const double focal = focals[focals.size() / 2];
  std::printf("mire-2: focal length of the dots' rectangle %.1f px (%.1f deg across)\n", focal,
              2 * std::atan(0.5 * size.width / focal) * 180 / M_PI);

  // The dots in the target's unit square, and the target's corners.
  constexpr double kMargin = 0.2;
  std::array<cv::Point2d, 4> dots_in_target, corners;
  const cv::Matx33d H = squareTo(reference[start]);
  for (int i = 0; i < 4; ++i) {
    const cv::Point2d unit(i == 1 || i == 2, i >= 2);  // TL, TR, BR, BL
    dots_in_target[i] = (unit + cv::Point2d(kMargin, kMargin)) / (1 + 2 * kMargin);
    corners[i] = mapPoint(H, unit * (1 + 2 * kMargin) - cv::Point2d(kMargin, kMargin));
  }
  CameraModel k = CameraModel::fromFieldOfView(size.width, size.height, 60);
  k.fx = k.fy = focal;
  trackClip(dir, start, last, corners, k, [&](int f, const std::optional<PlanarTargetState>& s) {
    if (f == start) return;
    errors.px.push_back(
        s && s->hasPose()
            ? test::cornerRms(mapQuad(squareTo(s->corners), dots_in_target), reference[f])
            : kNoPose);
    if (std::getenv("IMT_TEST_TRACE"))
      std::printf("%d err %.2f cc %.3f st %d\n", f, errors.px.back(), s ? s->correlation : 0.0,
                  s ? static_cast<int>(s->status) : -1);
  });
  char what[64];
  std::snprintf(what, sizeof(what), "ViSP mire-2 from frame %d, dots by the pose", start);
  errors.print(what);
  EXPECT_EQ(errors.px.size(), size_t(last - start));
  return errors;
}

// From the clip's first frame, which is motion-blurred (the dots smeared over
// ~10 px): the target's look is the blurred one, and the sharp frames after
// it align to it ~1 px off (frames 2-3, as blurred, within 0.1 px).
// Measured: P@5 1.00, median 1.01 px, worst 2.06 px. Bars: every frame within
// 5 px (POT's precision threshold) and a median of 1.5 px, half a pixel over
// the measurement for another CPU's rounding.
TEST(VispPlanar, Mire2FromItsBlurredFirstFrame) {
  if (!haveClip("visp_mire2_planar_target"))
    GTEST_SKIP() << "visp_mire2_planar_target not found under " << test::sharedDataDir();
  const Errors e = trackMire2(1);
  EXPECT_LT(e.worst(), 5.0);
  EXPECT_LT(e.median(), 1.5);
}

// From frame 10, sharp: measured median 0.09 px, worst 0.23 px. The bars
// (0.3 / 0.6 px) are about three times the measurement: sub-pixel tracking on
// real video is the claim, and the dots' reference itself is good to about a
// tenth of a pixel: the tracker and it, which share nothing, agree to 0.09 px.
TEST(VispPlanar, Mire2FromASharpFrame) {
  if (!haveClip("visp_mire2_planar_target"))
    GTEST_SKIP() << "visp_mire2_planar_target not found under " << test::sharedDataDir();
  const Errors e = trackMire2(10);
  EXPECT_LT(e.median(), 0.3);
  EXPECT_LT(e.worst(), 0.6);
}

// The homography of frame `from` to frame `to` of a clip, from SIFT matches
// inside `quad` of frame `from` (ratio test 0.75), fitted by RANSAC (2 px) and
// refined on the inliers; empty when fewer than 20 inliers. `rms` gets the
// inliers' residual.
cv::Matx33d siftHomography(const cv::Mat& from, const cv::Mat& to,
                           const std::array<cv::Point2d, 4>& quad, int* inliers, double* rms) {
  cv::Ptr<cv::SIFT> sift = cv::SIFT::create(2000);
  cv::Mat mask = cv::Mat::zeros(from.size(), CV_8U);
  std::vector<cv::Point> polygon;
  for (const cv::Point2d& p : quad) polygon.emplace_back(cvRound(p.x), cvRound(p.y));
  cv::fillConvexPoly(mask, polygon, 255);
  std::vector<cv::KeyPoint> k0, k1;
  cv::Mat d0, d1;
  sift->detectAndCompute(from, mask, k0, d0);
  sift->detectAndCompute(to, cv::noArray(), k1, d1);
  std::vector<std::vector<cv::DMatch>> knn;
  cv::BFMatcher(cv::NORM_L2).knnMatch(d0, d1, knn, 2);
  std::vector<cv::Point2f> a, b;
  for (const auto& m : knn)
    if (m.size() == 2 && m[0].distance < 0.75 * m[1].distance)
      a.push_back(k0[m[0].queryIdx].pt), b.push_back(k1[m[0].trainIdx].pt);
  *inliers = 0;
  if (a.size() < 20) return cv::Matx33d::zeros();
  cv::Mat in;
  const cv::Mat H = cv::findHomography(a, b, cv::RANSAC, 2.0, in, 5000, 0.999);
  if (H.empty()) return cv::Matx33d::zeros();
  double sq = 0;
  for (size_t i = 0; i < a.size(); ++i)
    if (in.at<uchar>(static_cast<int>(i))) {
      sq += std::pow(cv::norm(mapPoint(cv::Matx33d(H), a[i]) - cv::Point2d(b[i])), 2);
      ++*inliers;
    }
  *rms = std::sqrt(sq / std::max(1, *inliers));
  return *inliers >= 20 ? cv::Matx33d(H) : cv::Matx33d::zeros();
}

// cube: a tabletop of posters seen by a moving camera, a cube standing on it.
// The target is a quad of the table given at frame 0 beside the cube; as the
// camera moves, the cube comes in front of up to about a third of it (frames
// ~45-79, a textured occluder off the plane). Reference: SIFT homographies
// from frame 0 inside the quad (the cube's matches are RANSAC's outliers).
// Score: where the tracker carries the quad's corners from frame 0 against
// where the reference does (RMS of the four); the tracker's carry is its own
// corners' homography at a frame after that of its corners at frame 0, so a
// quad that is no rectangle's view under the assumed intrinsics is not held
// against it.
TEST(VispPlanar, CubeTabletopPastTheCube) {
  if (!haveClip("visp_cube_planar_scene"))
    GTEST_SKIP() << "visp_cube_planar_scene not found under " << test::sharedDataDir();
  const std::string dir = "visp_cube_planar_scene";
  const int last = 79;
  const std::array<cv::Point2d, 4> quad = {cv::Point2d(255, 25), cv::Point2d(375, 25),
                                           cv::Point2d(375, 140), cv::Point2d(255, 140)};
  const cv::Mat first = cv::imread(frameName(dir, 0), cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(first.empty());
  std::vector<cv::Matx33d> reference(last + 1);
  for (int f = 0; f <= last; ++f) {
    const cv::Mat gray = cv::imread(frameName(dir, f), cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(gray.empty());
    int inliers = 0;
    double rms = 0;
    reference[f] = siftHomography(first, gray, quad, &inliers, &rms);
    ASSERT_NE(reference[f](2, 2), 0) << "no reference at frame " << f;
    // The reference's own fit: 0.1-0.55 px over 90-300 inliers (measured).
    EXPECT_LT(rms, 1.0) << "frame " << f;
  }
  // Without intrinsics (the 60 degree default, as a user without camera_info
  // runs it) and with the mire-2 clip's focal length (the same kind of ViSP
  // camera, 384x288; 36 degrees across): the tracker's rigid pose can follow
  // a plane's homographies only as far as the focal length is right, and
  // this clip's errors are smallest about there (median 0.30 / 0.19 / 0.13 /
  // 0.21 / 0.36 px at 30 / 33 / 36 / 40 / 45 degrees).
  for (const double fov : {60.0, 36.1}) {
    const CameraModel k = CameraModel::fromFieldOfView(first.cols, first.rows, fov);
    cv::Matx33d G0_inv;
    Errors errors;
    trackClip(dir, 0, last, quad, k, [&](int f, const std::optional<PlanarTargetState>& s) {
      if (f == 0) {
        ASSERT_TRUE(s.has_value());
        G0_inv = squareTo(s->corners).inv();
        return;
      }
      errors.px.push_back(s && s->hasPose()
                              ? test::cornerRms(mapQuad(squareTo(s->corners) * G0_inv, quad),
                                                mapQuad(reference[f], quad))
                              : kNoPose);
      if (std::getenv("IMT_TEST_TRACE"))
        std::printf("%d err %.2f cc %.3f st %d visible %.2f\n", f, errors.px.back(),
                    s ? s->correlation : 0.0, s ? static_cast<int>(s->status) : -1,
                    s ? s->visible : 0.0);
    });
    char what[80];
    std::snprintf(what, sizeof(what), "ViSP cube, tabletop quad past the cube, %.0f deg", fov);
    errors.print(what);
    ASSERT_EQ(errors.px.size(), size_t(last));
    if (fov == 60.0) {
      // Measured: median 0.71 px, worst 3.32 px (the focal length's misfit
      // grows with the view's change). Bars: POT's 5 px on every frame, and
      // the median at 1 px.
      EXPECT_LT(errors.worst(), 5.0);
      EXPECT_LT(errors.median(), 1.0);
    } else {
      // Measured: median 0.13 px; worst 1.06 px at frame 64, the cube over
      // ~16% of the quad (correlation 0.965). Bars about twice those: under
      // the cube's crossing it must stay within 2 px.
      EXPECT_LT(errors.median(), 0.3);
      EXPECT_LT(errors.worst(), 2.0);
    }
  }
}

}  // namespace
}  // namespace imt
