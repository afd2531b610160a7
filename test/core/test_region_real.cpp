// Region tracking on real video: every sequence with box ground truth in
// ../shared/data (VOT2015 car1, UAV123 boat1, OTB Human3, POT-210 V25_2 and
// V24_7; test/box_sequence.h), skipped when the data is absent. The whole
// pipeline runs as live (a TrackingSession, default options): the region is
// given at the first frame's ground-truth box and read from each frame's
// results. Scored by success AUC (OTB definition, frames from the second,
// a lost region scores IoU 0), as benchmark_region_real prints it. And the
// same sequences from the middle frame's box, offline as track_bag runs
// (the frames before it tracked backwards), each half scored apart, as
// `benchmark_region_real --mid` prints it.
#include "instant_motion_tracking/core/tracking_session.h"

#include "../box_sequence.h"
#include "shared_data.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <optional>
#include <string>
#include <vector>

namespace imt {
namespace {

struct RealCase {
  const char* sequence;
  double min_auc;
};

class RegionReal : public ::testing::TestWithParam<RealCase> {};

// The sequence named `name` under ../shared/data, or none.
std::optional<test::BoxSequence> findSequence(const char* name) {
  for (const test::BoxSequence& s : test::BoxSequence::all(test::sharedDataDir()))
    if (s.name() == name) return s;
  return std::nullopt;
}

// The whole pipeline, live, with the region given at `box` on the first
// frame: its score over the sequence.
void trackFromFirstFrame(const test::BoxSequence& seq, const cv::Rect2d& box, test::BoxScore* score) {
  TrackingSession session(PipelineOptions(), TrackingSession::Mode::kLive);
  uint32_t id = 0;
  for (int f = 1; f <= seq.frames(); ++f) {
    const cv::Mat gray = seq.gray(f);
    ASSERT_FALSE(gray.empty()) << seq.name() << " frame " << f;
    session.analyze(gray, seq.stamp(f));
    session.advance();
    const std::vector<FrameResult> results = session.takeResults();
    if (f == 1) {
      std::string err;
      ASSERT_TRUE(session.addRegion(1, 0, box, &id, &err)) << err;
      continue;
    }
    ASSERT_EQ(results.size(), 1u);
    ASSERT_EQ(results[0].regions.size(), 1u);
    const RegionState& s = results[0].regions[0];
    if (seq.scored(f)) score->add(s.status != RegionStatus::kLost, s.extent(), seq.box(f), gray.size());
  }
}

TEST_P(RegionReal, FirstFrameBoxIsFollowed) {
  const RealCase& c = GetParam();
  const std::optional<test::BoxSequence> found = findSequence(c.sequence);
  if (!found) GTEST_SKIP() << c.sequence << " not found under " << test::sharedDataDir();
  test::BoxScore score;
  trackFromFirstFrame(*found, found->box(1), &score);
  ASSERT_GT(score.frames(), 20);
  std::printf("%s: success AUC %.3f, mean IoU %.3f, P@20px %.3f over %d frames\n", c.sequence, score.successAuc(),
              score.meanIou(), score.precision20(), score.frames());
  EXPECT_GE(score.successAuc(), c.min_auc);
}

// Human3 (a walker whose few corners sit on his swinging limbs) is chaotic
// from one box: a run either keeps him past the sign that hides him at
// frames 50-62 or loses him there. Its figure is the mean over the first 8
// of benchmark_region_real's nudged boxes (--starts 8): 0.590 since the
// filter checks the features' scale (2026-11-29, fourth session; runs
// 0.519..0.651, none lost at the sign), 0.501 since each region keeps a
// correlation filter (region_filter.h; runs 0.204..0.607), 0.110 before
// (OpenCV CSRT 0.439 on the colour frames, 0.148 on gray).
// Floor 0.55 (0.35 before): under the mean by a little more than one run
// lost at the sign.
TEST(RegionReal, Human3FromNudgedBoxes) {
  const std::optional<test::BoxSequence> found = findSequence("otb_human3_first199");
  if (!found) GTEST_SKIP() << "otb_human3_first199 not found under " << test::sharedDataDir();
  constexpr int kNudge[8][4] = {{0, 0, 0, 0}, {1, 0, 0, 0},  {0, 1, 0, 0}, {-1, 0, 0, 0},
                                {0, -1, 0, 0}, {0, 0, 2, 0}, {0, 0, 0, 2}, {1, 1, -2, -2}};
  const cv::Rect2d b = found->box(1);
  double sum = 0;
  for (const auto& n : kNudge) {
    test::BoxScore score;
    trackFromFirstFrame(*found, cv::Rect2d(b.x + n[0], b.y + n[1], b.width + n[2], b.height + n[3]), &score);
    std::printf("Human3 from (%+d, %+d, %+d, %+d): success AUC %.3f\n", n[0], n[1], n[2], n[3], score.successAuc());
    sum += score.successAuc();
  }
  std::printf("Human3, mean of 8 nudged boxes: %.3f\n", sum / 8);
  EXPECT_GE(sum / 8, 0.55);
}

// Since the filter checks the features' scale (2026-11-29, fourth
// session): car1 0.776 (8 nudged starts 0.724..0.792, mean 0.763), boat1
// 0.819, Human3 0.562 (0.519..0.651, mean 0.590), V25_2 0.949, V24_7 0.930.
// Human3's floor raised from 0.15 to 0.50, under its lowest run.
// Since each region keeps a correlation filter (2026-11-29, third
// session; region_filter.h): car1 0.784 (8 nudged starts 0.747..0.811,
// mean 0.776), boat1 0.819, Human3 0.555 (0.204..0.607, mean 0.501; 0.116
// before), V25_2 0.949, V24_7 0.930. Human3's floor raised from 0.07 to
// 0.15, under its runs that lose the walker at the sign (0.204): its mean
// is held by Human3FromNudgedBoxes.
// car1 0.757 (8 nudged starts 0.748..0.789, mean 0.768), Human3 0.116,
// since a coasting region's scale rate fades (2026-11-29, second session).
// Before: car1 0.782 (8 nudged starts 0.624..0.789, mean 0.761; 0.766 and
// 0.772 before) since a scale that a shift of each class of features
// explains as well is refused (2026-11-29): one nudged start refuses a 1%
// shrink on 6 frames and ends 20% large. Its floor stays at 0.70, over that
// start: the figure guarded is this box's.
// Since a box holding a rectangle is read as one (2026-11-28, eighth
// session; region_shape.h): V25_2 0.838 -> 0.949, V24_7 0.873 -> 0.927, the
// others the same; their floors raised from 0.79 and 0.81 to 0.90 and 0.87
// (8 nudged starts 0.949..0.950 and 0.909..0.930).
// Before (2026-11-28, features weighed by how well their LK
// windows matched): car1 0.775, boat1 0.812, Human3 0.117, V25_2 0.838,
// V24_7 0.873 (8 nudged starts: car1 0.776, 0.741..0.798; boat1 0.809;
// Human3 0.107); car1's floor raised from 0.65 to 0.70.
// Before (2026-11-27, late, the motion fit made again from
// the inliers alone): car1 0.767, boat1 0.817, Human3 0.128, V25_2 0.844,
// V24_7 0.869 (8 nudged starts: car1 0.762, boat1 0.812).
// Before (2026-11-27, night, the look sizing a region its
// features carry weakly): car1 0.728, boat1 0.808, Human3 0.127, V25_2
// 0.846, V24_7 0.872 (boat1's 8 nudged starts 0.771..0.823).
// Before (2026-11-27, evening, a look's window halved first):
// car1 0.728, boat1 0.784, Human3 0.127, V25_2 0.846, V24_7 0.872 (boat1's
// 8 nudged starts 0.752..0.798, still over its floor).
// Before (2026-11-27, the box's aspect taken along by the
// look): car1 0.731, boat1 0.811, Human3 0.128, V25_2 0.846, V24_7 0.866
// (before: 0.756, 0.755, 0.128, 0.846, 0.867; boat1's floor was 0.70 then;
// now under its 8 nudged starts' lowest, 0.751, as car1's is).
// Earlier (2026-11-26, regions turning with the camera and
// their look, scored by their reported extent): car1 0.754, boat1 0.755,
// Human3 0.126, V25_2 0.846, V24_7 0.867 (before they turned: 0.761, 0.743,
// 0.118, 0.707, 0.739; OpenCV CSRT: 0.740, 0.768, 0.178, 0.682, 0.661;
// benchmark_region_real). Floors about 0.05 under ours (Human3: 0.05, under
// half its figure): a change that loses a target on real video shows here.
// car1 is sensitive to the last bit of the pixels (from libjpeg's own gray
// decode instead of cvtColor it scored 0.602 before that change; its 8
// nudged starts then spanned 0.720..0.771; now 0.741..0.798), so its floor
// is 0.70, further under it than the others'.
INSTANTIATE_TEST_SUITE_P(Sequences, RegionReal,
                         ::testing::Values(RealCase{"vot2015_car1", 0.70}, RealCase{"uav123_10fps_boat1", 0.74},
                                           RealCase{"otb_human3_first199", 0.50},
                                           RealCase{"pot210_V25_2", 0.90}, RealCase{"pot210_V24_7", 0.87}),
                         [](const ::testing::TestParamInfo<RealCase>& info) {
                           std::string n = info.param.sequence;
                           for (char& ch : n)
                             if (!isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

struct MidCase {
  const char* sequence;
  double min_auc_backward, min_auc_forward;
};

class RegionRealMid : public ::testing::TestWithParam<MidCase> {};

TEST_P(RegionRealMid, MiddleFrameBoxIsFollowedBothWays) {
  const MidCase& c = GetParam();
  const std::optional<test::BoxSequence> found = findSequence(c.sequence);
  if (!found) GTEST_SKIP() << c.sequence << " not found under " << test::sharedDataDir();
  const test::BoxSequence& seq = *found;
  std::vector<cv::Mat> gray;
  for (int f = 1; f <= seq.frames(); ++f) {
    gray.push_back(seq.gray(f));
    ASSERT_FALSE(gray.back().empty()) << c.sequence << " frame " << f;
  }
  TrackingSession session(PipelineOptions(), TrackingSession::Mode::kOffline);
  session.setImageSource(seq.framesByStamp(gray));
  for (int f = 1; f <= seq.frames(); ++f) {
    session.analyze(gray[f - 1], seq.stamp(f));
    session.advance();
  }
  session.advance(/*all=*/true);
  const int mid = seq.middleFrame();
  uint32_t id = 0;
  std::string err;
  ASSERT_TRUE(session.addRegion(1, seq.stamp(mid), seq.box(mid), &id, &err)) << err;
  test::BoxScore backward, forward;
  for (int f = 1; f <= seq.frames(); ++f) {
    if (f == mid || !seq.scored(f)) continue;
    FrameResult r;
    ASSERT_TRUE(session.statesAt(seq.stamp(f), &r, &err)) << err;
    ASSERT_EQ(r.regions.size(), 1u);
    const RegionState& s = r.regions[0];
    (f < mid ? backward : forward).add(s.status != RegionStatus::kLost, s.extent(), seq.box(f), gray[0].size());
  }
  // POT scores every other frame: V25_2 has 12 and 13 scored frames a half.
  ASSERT_GE(backward.frames(), 10);
  ASSERT_GE(forward.frames(), 10);
  std::printf("%s from frame %d: success AUC backward %.3f over %d frames, forward %.3f over %d frames\n",
              c.sequence, mid, backward.successAuc(), backward.frames(), forward.successAuc(), forward.frames());
  EXPECT_GE(backward.successAuc(), c.min_auc_backward);
  EXPECT_GE(forward.successAuc(), c.min_auc_forward);
}

// Since the filter checks the features' scale (2026-11-29, fourth
// session): Human3 0.703 / 0.744 (8 nudged boxes 0.642..0.720 /
// 0.665..0.772, means 0.689 / 0.721), its floors raised from 0.55 / 0.35 to
// 0.60 / 0.62; car1 0.805 / 0.867 (0.798..0.859 / 0.858..0.876), the rest
// within 0.002 of before.
// Since each region keeps a correlation filter (2026-11-29, third
// session): Human3 0.703 / 0.561 (8 nudged boxes 0.636..0.720 /
// 0.410..0.765, means 0.687 / 0.601; 0.111 / 0.444 before), its floors
// raised from 0.07 / 0.10 to 0.55 / 0.35; car1 0.760 / 0.875 (0.760..0.809
// / 0.856..0.888), boat1 0.869 / 0.862 (0.863..0.872 / 0.834..0.873),
// V25_2 0.897 / 0.893, V24_7 0.925 / 0.875 (0.912..0.932 / 0.847..0.881).
// Human3 forward 0.666 (8 nudged boxes 0.131..0.666, mean 0.440; 0.273 and
// 0.237 before) since a scale that a shift of each class of features
// explains as well is refused, the region's own corners classed too
// (2026-11-29); car1 forward's 8 boxes 0.844..0.861, the rest the same.
// Measured (2026-11-28; backward / forward): car1 0.777 / 0.841, boat1 0.869
// / 0.878, Human3 0.096 / 0.273, V25_2 0.894 / 0.893, V24_7 0.927 / 0.873.
// From 8 nudged boxes (benchmark_region_real --mid --starts 8) each half
// spans: car1 0.768..0.799 / 0.837..0.874, boat1 0.863..0.872 /
// 0.854..0.899, Human3 0.096..0.121 / 0.131..0.299, V25_2 0.883..0.905 /
// 0.889..0.929, V24_7 0.912..0.930 / 0.861..0.889. The floors are a little
// under the lowest of those (a pixel's change of the box moves a run within
// them), Human3's forward half well under its wide spread. The POT posters
// are turned in the image at the middle frame (25 and -8 degrees): their
// boxes are read as the turned rectangles they bound (region_shape.h);
// taken as unturned, V25_2 scored 0.513 / 0.706 and V24_7 0.864 / 0.718.
INSTANTIATE_TEST_SUITE_P(Sequences, RegionRealMid,
                         ::testing::Values(MidCase{"vot2015_car1", 0.74, 0.80},
                                           MidCase{"uav123_10fps_boat1", 0.84, 0.83},
                                           MidCase{"otb_human3_first199", 0.60, 0.62},
                                           MidCase{"pot210_V25_2", 0.85, 0.85},
                                           MidCase{"pot210_V24_7", 0.88, 0.83}),
                         [](const ::testing::TestParamInfo<MidCase>& info) {
                           std::string n = info.param.sequence;
                           for (char& ch : n)
                             if (!isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n;
                         });

struct StridedCase {
  const char* sequence;
  int stride;
  double min_auc;
};

class RegionRealStrided : public ::testing::TestWithParam<StridedCase> {};

// The same videos seen by a slower camera: every 2nd or 3rd frame, at a half
// or a third of the frame rate (BoxSequence::strided), so that the targets
// move two or three times as far between frames as the options were
// measured at. Nothing here was tuned at these rates.
TEST_P(RegionRealStrided, FirstFrameBoxIsFollowedAtALowerFrameRate) {
  const StridedCase& c = GetParam();
  const std::optional<test::BoxSequence> found = findSequence(c.sequence);
  if (!found) GTEST_SKIP() << c.sequence << " not found under " << test::sharedDataDir();
  const test::BoxSequence seq = found->strided(c.stride);
  test::BoxScore score;
  trackFromFirstFrame(seq, seq.box(1), &score);
  // POT scores every other frame: at stride 3, V25_2 has 8 scored frames.
  ASSERT_GE(score.frames(), 8);
  std::printf("%s: success AUC %.3f, mean IoU %.3f, P@20px %.3f over %d frames\n", seq.name().c_str(),
              score.successAuc(), score.meanIou(), score.precision20(), score.frames());
  EXPECT_GE(score.successAuc(), c.min_auc);
}

// Measured on 2026-12-01 (benchmark_region_real --stride N --starts 8: the
// exact box's run, then the 8 nudged boxes' mean and spread; OpenCV CSRT on
// the colour frames, its 8 runs' mean):
//   every 2nd frame: car1 0.723 (0.726, 0.720..0.748; CSRT 0.716), boat1
//   0.797 (0.796, 0.777..0.805; CSRT 0.712), Human3 0.667 (0.644,
//   0.598..0.667; CSRT 0.505); POT-210 scores only the frames this leaves out;
//   every 3rd frame: car1 0.718 (0.709, 0.687..0.722; CSRT 0.679), boat1
//   0.803 (0.793, 0.765..0.804; CSRT 0.580), Human3 0.568 (0.573,
//   0.522..0.602; CSRT 0.620), V25_2 0.946, V24_7 0.910.
// The floors lie under each sequence's lowest nudged run, so that a pixel's
// change of the box does not fail them while a lost target does.
INSTANTIATE_TEST_SUITE_P(Sequences, RegionRealStrided,
                         ::testing::Values(StridedCase{"vot2015_car1", 2, 0.68}, StridedCase{"uav123_10fps_boat1", 2, 0.74},
                                           StridedCase{"otb_human3_first199", 2, 0.55},
                                           StridedCase{"vot2015_car1", 3, 0.65}, StridedCase{"uav123_10fps_boat1", 3, 0.74},
                                           StridedCase{"otb_human3_first199", 3, 0.48},
                                           StridedCase{"pot210_V25_2", 3, 0.90}, StridedCase{"pot210_V24_7", 3, 0.86}),
                         [](const ::testing::TestParamInfo<StridedCase>& info) {
                           std::string n = info.param.sequence;
                           for (char& ch : n)
                             if (!isalnum(static_cast<unsigned char>(ch))) ch = '_';
                           return n + "_every" + std::to_string(info.param.stride);
                         });

}  // namespace
}  // namespace imt
