// Image targets: planar targets found from their picture (issue 15 item 2).
// The detector on a known warp; the manager on the rendered poster (a
// picture the scene paints on its poster) that enters the view late, and
// that leaves and comes back; and on the POT-210 excerpt (skipped when
// absent), the picture cut from frame 1 by its ground-truth corners and the
// search started at frame 10, as the issue asks.
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/planar/image_target_detector.h"
#include "instant_motion_tracking/core/planar/planar_target_manager.h"
#include "instant_motion_tracking/sim/scene.h"

#include "../pot210.h"
#include "planar_real.h"
#include "scene_test_util.h"
#include "shared_data.h"

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdio>
#include <cstdlib>
#include <filesystem>

namespace imt {
namespace {

using test::cornerRms;
using test::median;

// The poster's picture: a procedural texture cut to the poster's 4:3.
cv::Mat posterPicture() { return proceduralTexture(1024, 7)(cv::Rect(0, 0, 1024, 768)).clone(); }

TEST(ImageTargetDetector, FindsThePictureUnderAKnownPerspective) {
  const cv::Mat picture = posterPicture();
  PlanarTargetOptions o;
  std::string err;
  auto d = ImageTargetDetector::create(picture, o, &err);
  ASSERT_TRUE(d) << err;
  // The picture seen at an angle, at about half its size, in a 640x480 frame
  // of another texture.
  const std::vector<cv::Point2f> from = {{0, 0}, {1024, 0}, {1024, 768}, {0, 768}};
  const std::vector<cv::Point2f> to = {{150, 110}, {470, 140}, {455, 380}, {140, 360}};
  const cv::Mat H = cv::getPerspectiveTransform(from, to);
  cv::Mat frame = proceduralTexture(640, 99)(cv::Rect(0, 0, 640, 480)).clone();
  cv::warpPerspective(picture, frame, H, frame.size(), cv::INTER_AREA, cv::BORDER_TRANSPARENT);
  ImageTargetDetector::Detection found;
  ASSERT_TRUE(d->detect(ImageTargetDetector::describeFrame(frame, o), &found));
  std::array<cv::Point2d, 4> truth;
  for (int i = 0; i < 4; ++i) truth[i] = to[i];
  // ORB keypoints are found to about a pixel at their pyramid level; fitted
  // over tens of inliers the corners come within a few pixels of the truth.
  EXPECT_LT(cornerRms(found.corners, truth), 3.0) << found.inliers << " inliers";
  EXPECT_GE(found.inliers, o.detect_min_inliers);
  // A frame without the picture: nothing found.
  const cv::Mat other = proceduralTexture(640, 123)(cv::Rect(0, 0, 640, 480)).clone();
  EXPECT_FALSE(d->detect(ImageTargetDetector::describeFrame(other, o), &found));
}

TEST(ImageTargetDetector, RefusesPicturesItCannotFind) {
  PlanarTargetOptions o;
  std::string err;
  EXPECT_FALSE(ImageTargetDetector::create(cv::Mat(), o, &err));
  EXPECT_NE(err.find("8-bit gray or colour"), std::string::npos) << err;
  EXPECT_FALSE(ImageTargetDetector::create(cv::Mat(20, 300, CV_8UC1, cv::Scalar(9)), o, &err));
  EXPECT_NE(err.find("at least 32x32"), std::string::npos) << err;
  EXPECT_FALSE(ImageTargetDetector::create(cv::Mat(300, 300, CV_8UC1, cv::Scalar(128)), o, &err));
  EXPECT_NE(err.find("too little texture"), std::string::npos) << err;
  EXPECT_FALSE(ImageTargetDetector::create(cv::Mat(300, 300, CV_32FC1, cv::Scalar(0.5)), o, &err));
}

// The rendered poster with `picture` painted on it, the camera panning it out
// of view and back (as PosterOutOfView).
std::unique_ptr<SceneGenerator> panningPoster(const std::string& picture_file) {
  SceneOptions o = test::preset("poster_orbit");
  o.trajectory = "pan";
  o.trajectory_amplitude = 2.5;
  o.duration = 12.0;
  o.brightness_amplitude = 0;
  for (ScenePlane& p : o.planes)
    if (p.kind == ScenePlane::Kind::kTarget) p.texture_file = picture_file;
  return test::make(o);
}

struct RenderedRun {
  int entered = -1;     // first frame the poster is >= half in view after the start
  int found = -1;       // first frame it is tracked
  std::vector<double> errors;  // corner RMS on tracked frames with the poster >= 40% in view
  int tracked_while_out = 0;   // tracked frames with no part of the poster in view
  int other_found = 0;         // frames the absent picture (when given) was not not_found
  int untracked_in_view = 0;   // frames after `found` with the poster >= 40% in view, not tracked
  int tracked_after_out = 0;   // tracked frames after it was wholly out of view (once found)
};

// Frames `start`.. of `scene` through the motion analysis; the image target
// added at `start`, and `absent` (a picture the scene does not show) beside
// it when given.
RenderedRun runRendered(const SceneGenerator& scene, int start, const cv::Mat& picture,
                        const cv::Mat& absent = cv::Mat()) {
  RenderedRun run;
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  MotionCache cache(0.0);
  cache.setImageBudget(size_t(1) << 30);
  PlanarTargetManager targets{PlanarTargetOptions(), &cache};
  std::string err;
  uint32_t id = 0, other = 0;
  const size_t n = absent.empty() ? 1 : 2;
  bool been_out = false;  // wholly out of view since it was found
  for (int i = start; i < scene.frameCount(); ++i) {
    std::string reset;
    const cv::Mat frame = scene.renderFrame(i);
    cache.push(analyzer.process(frame, scene.frameStamp(i)), &reset, frame);
    const FrameTruth truth = scene.frameTruth(i);
    const FrameTruth::Target& t = truth.targets.at(0);
    std::vector<PlanarTargetState> states;
    if (i == start) {
      EXPECT_TRUE(targets.addImage(0, 0, picture, t.width_m, t.height_m, scene.intrinsics(), &id, &err)) << err;
      if (n == 2) {
        EXPECT_TRUE(targets.addImage(0, 0, absent, t.width_m, t.height_m, scene.intrinsics(), &other, &err)) << err;
      }
      EXPECT_TRUE(targets.statesAt(0, {}, &states, &err)) << err;
    } else {
      states = targets.update();
    }
    if (states.size() != n) {
      ADD_FAILURE() << "frame " << i << ": " << states.size() << " states";
      return run;
    }
    const PlanarTargetState& s = states[0];
    if (n == 2) run.other_found += states[1].status != TargetStatus::kNotFound;
    if (run.entered < 0 && t.visible_fraction >= 0.5) run.entered = i;
    if (t.visible_fraction == 0 && run.found >= 0) been_out = true;
    if (s.status != TargetStatus::kTracked) {
      run.untracked_in_view += run.found >= 0 && t.visible_fraction >= 0.4;
      continue;
    }
    if (run.found < 0) run.found = i;
    run.tracked_after_out += been_out;
    if (t.visible_fraction == 0) ++run.tracked_while_out;
    if (t.visible_fraction >= 0.4) run.errors.push_back(cornerRms(s.corners, t.corners));
    if (std::getenv("IMT_TEST_TRACE"))
      std::printf("%d err %.2f visible %.2f cc %.3f\n", i, run.errors.empty() ? NAN : run.errors.back(),
                  t.visible_fraction, s.correlation);
  }
  return run;
}

class RenderedImageTarget : public ::testing::Test {
 protected:
  void SetUp() override {
    picture_ = posterPicture();
    dir_ = std::filesystem::temp_directory_path() / ("imt_image_target_" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir_);
    file_ = (dir_ / "poster.png").string();
    ASSERT_TRUE(cv::imwrite(file_, picture_));
    scene_ = panningPoster(file_);
    ASSERT_TRUE(scene_);
  }
  void TearDown() override { std::filesystem::remove_all(dir_); }

  cv::Mat picture_;
  std::filesystem::path dir_;
  std::string file_;
  std::unique_ptr<SceneGenerator> scene_;
};

// Given while the poster is out of view: not_found until it enters, then
// found within the 0.5 s and tracked as any target.
TEST_F(RenderedImageTarget, FoundSoonAfterItEntersTheView) {
  int out = -1;
  for (int i = 0; i < scene_->frameCount() && out < 0; ++i)
    if (scene_->frameTruth(i).targets.at(0).visible_fraction == 0) out = i;
  ASSERT_GE(out, 0) << "the scene should take the poster out of view";
  const RenderedRun run = runRendered(*scene_, out, picture_);
  ASSERT_GE(run.entered, 0) << "and bring it back";
  ASSERT_GE(run.found, 0) << "never found";
  const double latency = (run.found - run.entered) / scene_->options().fps;
  std::printf("image target entering the view: half in view at frame %d, found at %d (%.2f s); corner error "
              "median %.3f px, worst %.2f px over %zu frames\n",
              run.entered, run.found, latency, median(run.errors),
              run.errors.empty() ? NAN : *std::max_element(run.errors.begin(), run.errors.end()),
              run.errors.size());
  EXPECT_LE(latency, 0.5);  // the goal
  EXPECT_EQ(run.tracked_while_out, 0);
  ASSERT_GT(run.errors.size(), 30u);
  // Once found it is aligned with its picture every frame: measured 0.019 px
  // median (0.15 px when the template was the frame at detection, which
  // kept the detection's error). 0.1 px: five times that, still 10x under
  // the drift-free bar of 1 px.
  EXPECT_LE(median(run.errors), 0.1);
}

// Given in view: found by the first search (its answer taken detect_interval
// frames later), predicted while out of view, tracked again once back;
// beside it another image target whose picture the scene does not show is
// never found.
TEST_F(RenderedImageTarget, FoundAtOnceAndAgainAfterLeaving) {
  const cv::Mat absent = proceduralTexture(1024, 8)(cv::Rect(0, 0, 1024, 768)).clone();
  const RenderedRun run = runRendered(*scene_, 0, picture_, absent);
  EXPECT_EQ(run.other_found, 0);
  ASSERT_EQ(run.found, PlanarTargetOptions().detect_interval) << "the poster is in view when given";
  int out = -1;
  for (int i = 0; i < scene_->frameCount() && out < 0; ++i)
    if (scene_->frameTruth(i).targets.at(0).visible_fraction == 0) out = i;
  ASSERT_GE(out, 0) << "the scene should take the poster out of view";
  std::printf("image target given in view: corner error median %.3f px over %zu frames, last %.3f px; "
              "%d frames in view not tracked, %d tracked after it was out\n",
              median(run.errors), run.errors.size(), run.errors.empty() ? NAN : run.errors.back(),
              run.untracked_in_view, run.tracked_after_out);
  EXPECT_EQ(run.tracked_while_out, 0);
  // Once found, tracked on every frame with 40% of it or more in view
  // (measured: all), and tracked again once back (measured 237 frames after
  // its time wholly out of view; over 100 is most of the clip's rest).
  EXPECT_EQ(run.untracked_in_view, 0);
  EXPECT_GT(run.tracked_after_out, 100);
  ASSERT_GT(run.errors.size(), 100u);
  // Measured 0.020 px median, last 0.12 px; the median's bar as above, the
  // last frame's the drift-free 1 px of PosterOutOfView.
  EXPECT_LE(median(run.errors), 0.1);
  EXPECT_LE(run.errors.back(), 1.0);
}

// POT-210: the picture is frame 1 cut by its ground-truth corners
// (rectified to their mean side lengths); the search starts at frame 10.
struct PotImageResult {
  int found = -1;
  double precision = 0, median_error = 0, worst = 0;
  int scored = 0;
};

PotImageResult runPotImage(const std::string& seq, int frames) {
  PotImageResult res;
  test::PotSequence pot;
  EXPECT_TRUE(pot.load(test::sharedDataDir() + "/pot210_excerpt", seq, frames)) << seq;
  if (pot.frames() != frames) return res;
  const std::array<cv::Point2d, 4> c1 = pot.corners(1);
  const double w = (cv::norm(c1[1] - c1[0]) + cv::norm(c1[2] - c1[3])) / 2;
  const double h = (cv::norm(c1[3] - c1[0]) + cv::norm(c1[2] - c1[1])) / 2;
  const std::vector<cv::Point2f> quad(c1.begin(), c1.end());
  const std::vector<cv::Point2f> rect = {{0, 0}, {float(w), 0}, {float(w), float(h)}, {0, float(h)}};
  cv::Mat picture;
  cv::warpPerspective(pot.gray(1), picture, cv::getPerspectiveTransform(quad, rect),
                      cv::Size(int(std::lround(w)), int(std::lround(h))), cv::INTER_AREA);
  MotionAnalyzer analyzer{MotionAnalysisOptions()};
  MotionCache cache(0.0);
  cache.setImageBudget(size_t(1) << 30);
  PlanarTargetManager targets{PlanarTargetOptions(), &cache};
  std::vector<double> errors;
  uint32_t id = 0;
  std::string err;
  constexpr int kStart = 10;
  for (int f = 1; f <= frames; ++f) {
    const cv::Mat gray = pot.gray(f);
    cache.push(analyzer.process(gray, f / 30.0), &err, gray);
    if (f < kStart) continue;
    std::vector<PlanarTargetState> states;
    if (f == kStart) {
      const CameraModel k = CameraModel::fromFieldOfView(gray.cols, gray.rows, 60.0);
      EXPECT_TRUE(targets.addImage(0, 0, picture, 1.0, h / w, k, &id, &err)) << err;
      EXPECT_TRUE(targets.statesAt(0, {id}, &states, &err)) << err;
    } else {
      states = targets.update();
    }
    if (states.size() != 1) {
      ADD_FAILURE() << seq << ": " << states.size() << " target states at frame " << f << ", not 1";
      return res;
    }
    if (states[0].status == TargetStatus::kTracked && res.found < 0) res.found = f;
    if (!pot.scored(f) || res.found < 0) continue;
    errors.push_back(cornerRms(states[0].corners, pot.corners(f)));
  }
  res.scored = static_cast<int>(errors.size());
  res.precision = test::precisionAt(errors, 5.0);
  res.median_error = median(errors);
  res.worst = errors.empty() ? NAN : *std::max_element(errors.begin(), errors.end());
  std::printf("POT %s image target: found at frame %d (search from %d); P@5 %.2f over %d frames, median %.2f px, "
              "worst %.2f px\n",
              seq.c_str(), res.found, kStart, res.precision, res.scored, res.median_error, res.worst);
  return res;
}

class Pot210ImageTarget : public ::testing::TestWithParam<std::pair<const char*, int>> {
 protected:
  void SetUp() override {
    if (!test::pathExists(test::sharedDataDir() + "/pot210_excerpt/annotation"))
      GTEST_SKIP() << "POT-210 excerpt not found under " << test::sharedDataDir();
  }
};

TEST_P(Pot210ImageTarget, FoundWithinHalfASecondAndTracked) {
  const PotImageResult r = runPotImage(GetParam().first, GetParam().second);
  ASSERT_GE(r.found, 10);
  EXPECT_LE((r.found - 10) / 30.0, 0.5);  // the goal (POT's phone videos: 30 frames/s)
  EXPECT_GT(r.scored, 15);
  // The P@5 goal for these clips given by their corners holds for
  // the picture too (a count: no tolerance under 1.0). Measured: V25_2
  // median 1.84 px, worst 2.66; V24_7 2.34 / 3.90 (the hand-annotated
  // corners' own noise is ~2 px).
  EXPECT_EQ(r.precision, 1.0);
}

INSTANTIATE_TEST_SUITE_P(Sequences, Pot210ImageTarget,
                         ::testing::Values(std::make_pair("V25_2", 50), std::make_pair("V24_7", 110)),
                         [](const auto& info) { return std::string(info.param.first); });

}  // namespace
}  // namespace imt
