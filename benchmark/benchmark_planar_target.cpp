// Planar target tracking speed: one PlanarTargetTracker::step() (feature pose,
// appearance alignment, and the search when the alignment fails or fits
// loosely) per frame, at 640x480 and 1280x720, on the rendered poster_orbit
// scene (the camera orbits a 0.60 x 0.45 m poster), with and without a
// textured card sliding across the poster (as in test_planar_scenes.cpp's
// occluder test: up to ~40% covered in these 4 s). The motion analysis runs
// before timing; only the tracker is timed. Each row steps through the whole
// sequence kPasses times (the same frames for every row: a clear start, the
// card's passage). Reports ms per frame (wall) and cpu_ms (thread CPU time,
// robust to load from other processes); --benchmark_repetitions=N gives
// medians over N runs.
//
//   make -C _build benchmarks
//   taskset -c 0 _build/benchmark/benchmark_planar_target
//
// Also: one image-target search of a frame (BM_ImageTargetSearch).
//
// OpenCV runs single-threaded here (cv::setNumThreads(1) in main).
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/motion_cache.h"
#include "instant_motion_tracking/core/planar/image_target_detector.h"
#include "instant_motion_tracking/core/planar/planar_target.h"
#include "instant_motion_tracking/sim/scene.h"

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <ctime>
#include <map>
#include <memory>
#include <stdexcept>
#include <tuple>
#include <vector>

namespace {

constexpr double kSeconds = 4.0;  // 120 frames
constexpr int kFrames = 120;
constexpr int kPasses = 2;  // whole passes through the sequence per row

// Frames analysed once per (width, height, card): motion data, images, the
// target's corners at frame 0, the camera's intrinsics.
struct Sequence {
  std::unique_ptr<imt::MotionCache> cache;
  imt::FrameTruth::Target target;
  std::vector<std::array<cv::Point2d, 4>> corners;  // the target's true corners, frame by frame
  imt::CameraModel k;
};

const Sequence& sequence(int w, int h, bool card) {
  static std::map<std::tuple<int, int, bool>, Sequence> all;
  Sequence& s = all[{w, h, card}];
  if (s.cache) return s;
  imt::SceneOptions o = *imt::SceneOptions::fromPreset("poster_orbit");
  o.width = w;
  o.height = h;
  o.duration = kSeconds;
  if (card) {
    imt::ScenePlane c;
    for (const imt::ScenePlane& p : o.planes)
      if (p.kind == imt::ScenePlane::Kind::kTarget) c.T_world_plane = p.T_world_plane;
    c.kind = imt::ScenePlane::Kind::kCard;
    c.id = 2;
    c.width_m = 0.30;
    c.height_m = 0.35;
    c.T_world_plane.translation().y() -= 0.2;  // 0.2 m in front of the poster
    c.texture_seed = 77;
    c.motion = "slide";
    c.motion_amplitude = 0.65;
    c.motion_period = 6.0;
    c.motion_phase = -M_PI / 2;
    o.planes.push_back(c);
  }
  std::string err;
  auto scene = imt::SceneGenerator::create(o, &err);
  if (!scene) throw std::runtime_error("scene: " + err);
  if (scene->frameCount() != kFrames) throw std::runtime_error("scene: unexpected frame count");
  imt::MotionAnalyzer analyzer{imt::MotionAnalysisOptions()};
  s.cache = std::make_unique<imt::MotionCache>(0.0);
  s.cache->setImageBudget(size_t(1) << 31);
  for (int i = 0; i < scene->frameCount(); ++i) {
    const cv::Mat frame = scene->renderFrame(i);
    std::string reset;
    s.cache->push(analyzer.process(frame, scene->frameStamp(i)), &reset, frame);
    s.corners.push_back(scene->frameTruth(i).targets.at(0).corners);
  }
  s.target = scene->frameTruth(0).targets.at(0);
  s.k = scene->intrinsics();
  return s;
}

double threadCpuMs() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

// One iteration = one frame; the tracker starts over at frame 0 after the
// last (its creation, which captures the appearance, is not timed).
void BM_PlanarTargetStep(benchmark::State& state) {
  const Sequence& s = sequence(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)),
                               state.range(2) != 0);
  const imt::MotionCache& cache = *s.cache;
  std::unique_ptr<imt::PlanarTargetTracker> tracker;
  uint64_t seq = cache.lastSeq();
  double cpu_ms = 0;
  int64_t aligned = 0;
  std::vector<double> errors;  // mean corner error (px) of each frame, against the truth
  for (auto _ : state) {
    if (seq == cache.lastSeq()) {
      state.PauseTiming();
      std::string err;
      seq = cache.firstSeq();
      tracker = imt::PlanarTargetTracker::create(imt::PlanarTargetOptions(), 1, s.target.corners,
                                                 s.target.width_m, s.target.height_m, s.k,
                                                 cache.at(seq), &err, cache.image(seq));
      if (!tracker) {
        state.SkipWithError(err.c_str());
        return;
      }
      state.ResumeTiming();
    }
    Eigen::Matrix3d H;
    const bool valid = cache.cameraMotion(seq, seq + 1, &H);
    ++seq;
    const double t0 = threadCpuMs();
    const imt::PlanarTargetState& st = tracker->step(cache.at(seq), H, valid, cache.image(seq));
    cpu_ms += threadCpuMs() - t0;
    aligned += st.correlation > 0;
    benchmark::DoNotOptimize(st.corners[0].x);
    double e = 0;
    for (int c = 0; c < 4; ++c) e += cv::norm(cv::Point2d(st.corners[c]) - s.corners[seq - cache.firstSeq()][c]) / 4;
    errors.push_back(e);
  }
  const double n = static_cast<double>(std::max<int64_t>(1, state.iterations()));
  state.counters["cpu_ms"] = cpu_ms / n;
  state.counters["aligned"] = static_cast<double>(aligned) / n;  // share of frames aligned
  if (!errors.empty()) {  // what the time buys: the corners' error, median and worst frame
    std::sort(errors.begin(), errors.end());
    state.counters["median_px"] = errors[errors.size() / 2];
    state.counters["worst_px"] = errors.back();
  }
}
BENCHMARK(BM_PlanarTargetStep)
    ->ArgNames({"w", "h", "card"})
    ->Args({640, 480, 0})
    ->Args({1280, 720, 0})
    ->Args({640, 480, 1})
    ->Args({1280, 720, 1})
    ->Iterations(kPasses * (kFrames - 1))  // every frame after the first, kPasses times
    ->Unit(benchmark::kMillisecond);

// Searching one frame for an image target (ImageTargetDetector: the frame's
// keypoints described, matched against the picture's, and when they agree,
// the picture aligned by ECC): a poster_orbit frame with the picture absent
// (the cost of every searched frame while a target is missing), or warped
// into it at about a third of the frame's width (a find).
void BM_ImageTargetSearch(benchmark::State& state) {
  const Sequence& s = sequence(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)), false);
  const imt::MotionCache& cache = *s.cache;
  const cv::Mat picture = imt::proceduralTexture(1024, 7)(cv::Rect(0, 0, 1024, 768)).clone();
  const imt::PlanarTargetOptions o;
  std::string err;
  const auto detector = imt::ImageTargetDetector::create(picture, o, &err);
  if (!detector) {
    state.SkipWithError(err.c_str());
    return;
  }
  cv::Mat frame = cache.image(cache.firstSeq() + 30).clone();
  const bool present = state.range(2) != 0;
  if (present) {
    const float w = frame.cols, h = frame.rows;
    const std::vector<cv::Point2f> from = {{0, 0}, {1024, 0}, {1024, 768}, {0, 768}};
    const std::vector<cv::Point2f> to = {
        {0.35f * w, 0.3f * h}, {0.68f * w, 0.33f * h}, {0.66f * w, 0.72f * h}, {0.33f * w, 0.68f * h}};
    cv::warpPerspective(picture, frame, cv::getPerspectiveTransform(from, to), frame.size(), cv::INTER_AREA,
                        cv::BORDER_TRANSPARENT);
  }
  double cpu_ms = 0;
  int64_t found = 0;
  for (auto _ : state) {
    const double t0 = threadCpuMs();
    imt::ImageTargetDetector::Detection d;
    found += detector->detect(imt::ImageTargetDetector::describeFrame(frame, o), &d);
    cpu_ms += threadCpuMs() - t0;
  }
  const double n = static_cast<double>(std::max<int64_t>(1, state.iterations()));
  state.counters["cpu_ms"] = cpu_ms / n;
  state.counters["found"] = static_cast<double>(found) / n;
}
BENCHMARK(BM_ImageTargetSearch)
    ->ArgNames({"w", "h", "present"})
    ->Args({640, 480, 0})
    ->Args({640, 480, 1})
    ->Args({1280, 720, 0})
    ->Args({1280, 720, 1})
    ->Iterations(10)
    ->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core: the figures the targets are stated in
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  for (const bool card : {false, true}) {  // render and analyse before any timing
    sequence(640, 480, card);
    sequence(1280, 720, card);
  }
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
