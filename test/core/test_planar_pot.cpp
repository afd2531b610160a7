// Planar target tracking on real video: the POT-210 excerpt in
// ../shared/data/pot210_excerpt (skipped when absent). The target is
// initialised from the official frame-1 corners; its physical size is unknown,
// so it is given with the aspect ratio of the frame-1 quad and the intrinsics
// come from the default field of view (the pose is then correct up to that
// assumption, the corners are what POT scores). Score: precision at 5 px of
// the alignment error (RMS of the four corner distances) on the annotated,
// unflagged frames, as the POT evaluation does.
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/planar/planar_target_manager.h"

#include "../pot210.h"
#include "planar_real.h"
#include "scene_test_util.h"
#include "shared_data.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>

namespace imt {
namespace {

// Assumed horizontal field of view of the phone videos (POT gives no
// intrinsics).
constexpr double kFieldOfViewDeg = 60.0;

struct PotResult {
  double precision = 0;
  int scored = 0;
  double fps = 0;
  double median_error = 0;
  double max_error = 0;
};

PotResult runPot(const std::string& seq, int frames, const std::string& model) {
  test::PotSequence pot;
  PotResult res;
  EXPECT_TRUE(pot.load(test::sharedDataDir() + "/pot210_excerpt", seq, frames)) << seq;
  if (pot.frames() != frames) return res;
  MotionAnalysisOptions mo;
  MotionAnalyzer analyzer(mo);
  MotionCache cache(0.0);
  cache.setImageBudget(size_t(1) << 30);  // the appearance alignment uses every frame
  PlanarTargetOptions po;
  po.model = model;
  PlanarTargetManager targets(po, &cache);
  const std::array<cv::Point2d, 4> c0 = pot.corners(1);
  double seconds = 0, tracking_seconds = 0;  // wall time: analysis + tracking; tracking alone
  double cpu_seconds = 0,
         cpu_tracking_seconds = 0;  // the same in CPU time (all threads): stable on a busy machine
  std::vector<double> errors;
  uint32_t id = 0;
  for (int f = 1; f <= frames; ++f) {
    const cv::Mat gray = pot.gray(f);
    EXPECT_FALSE(gray.empty()) << seq << " frame " << f;
    if (gray.empty()) return res;
    const auto t0 = std::chrono::steady_clock::now();
    const std::clock_t cpu0 = std::clock();
    std::string err;
    cache.push(analyzer.process(gray, f / 30.0), &err, gray);
    const auto t1 = std::chrono::steady_clock::now();
    const std::clock_t cpu1 = std::clock();
    std::vector<PlanarTargetState> states;
    if (f == 1) {
      const CameraModel k = CameraModel::fromFieldOfView(gray.cols, gray.rows, kFieldOfViewDeg);
      const double aspect = test::rectifiedAspect(c0, k);
      EXPECT_GT(aspect, 0);
      EXPECT_TRUE(targets.add(0, 0, c0, 1.0, aspect, k, &id, &err)) << err;
    } else {
      states = targets.update();
    }
    const auto t2 = std::chrono::steady_clock::now();
    seconds += std::chrono::duration<double>(t2 - t0).count();
    tracking_seconds += std::chrono::duration<double>(t2 - t1).count();
    const std::clock_t cpu2 = std::clock();
    cpu_seconds += static_cast<double>(cpu2 - cpu0) / CLOCKS_PER_SEC;
    cpu_tracking_seconds += static_cast<double>(cpu2 - cpu1) / CLOCKS_PER_SEC;
    if (f == 1 || !pot.scored(f) || states.empty()) continue;
    errors.push_back(test::cornerRms(states[0].corners, pot.corners(f)));
    if (std::getenv("IMT_TEST_TRACE"))  // per-frame trace for tuning
      std::printf("%d err %.2f cc %.3f visible %.2f pts %d rms %.2f st %d\n", f, errors.back(),
                  states[0].correlation, states[0].visible, states[0].points, states[0].rms_error,
                  static_cast<int>(states[0].status));
  }
  res.scored = static_cast<int>(errors.size());
  res.precision = test::precisionAt(errors, 5.0);
  res.fps = frames / seconds;
  std::sort(errors.begin(), errors.end());
  res.median_error = errors.empty() ? 0 : errors[errors.size() / 2];
  res.max_error = errors.empty() ? 0 : errors.back();
  std::printf(
      "POT %s (%s): P@5 %.2f over %d frames, alignment error median %.2f px, worst %.2f px; %.0f "
      "frames/s "
      "(planar tracking alone %.1f ms/frame; CPU time %.0f frames/s, tracking %.1f ms/frame)\n",
      seq.c_str(), model.c_str(), res.precision, res.scored, res.median_error, res.max_error,
      res.fps, 1000 * tracking_seconds / frames, frames / cpu_seconds,
      1000 * cpu_tracking_seconds / frames);
  return res;
}

class Pot210 : public ::testing::TestWithParam<std::pair<const char*, int>> {
 protected:
  void SetUp() override {
    if (!test::pathExists(test::sharedDataDir() + "/pot210_excerpt/annotation"))
      GTEST_SKIP() << "POT-210 excerpt not found under " << test::sharedDataDir();
  }
};

// The bar: every scored frame within 5 px (P@5 = 1.0) on both
// sequences. The bar has no tolerance below 1.0 because the POT precision is a
// count: one frame over 5 px is a lost frame. The margin is thin on V24_7,
// measured with the defaults: frames 96-110 are the hard ones (a card covers
// most of the target under motion blur; frame 98 is at 4.2 px from the
// camera-motion prediction, 106 at 3.3 px after re-acquisition), the median is
// 2.33 px, the worst 4.21 px; V25_2: median 2.00 px, worst 2.88 px.
// IMT_TEST_TRACE=1 prints every frame.
TEST_P(Pot210, Perspective) {
  const PotResult r = runPot(GetParam().first, GetParam().second, "perspective");
  EXPECT_EQ(r.scored, GetParam().first == std::string("V25_2") ? 25 : 52);
  EXPECT_EQ(r.precision, 1.0);
}

INSTANTIATE_TEST_SUITE_P(Sequences, Pot210,
                         ::testing::Values(std::make_pair("V25_2", 50),
                                           std::make_pair("V24_7", 110)),
                         [](const auto& info) { return std::string(info.param.first); });

}  // namespace
}  // namespace imt
