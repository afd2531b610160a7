// A region's correlation filter (RegionFilter): one find (locate) and one
// learning step (learn) on the rendered `cards` scene at 640x480, for a
// small box (12 x 20 px: a window of 15 x 15 cells) and boxes the size of
// OTB Human3's walker (37 x 69) and VOT car1's car (110 x 100), whose
// windows (the box grown by three times its mean side) are both scaled to
// kWindowPx (50 x 50 cells). On car1 the find and the learning are 28% of
// the tracking (docs/benchmarks.md, "The corner map, the filter's cells and
// the corner scan").
//
//   make -C _build benchmarks
//   taskset -c 0 _build/benchmark/benchmark_region_filter
//
// OpenCV runs single-threaded here (cv::setNumThreads(1) in main), so the
// figures are per core.
#include "instant_motion_tracking/core/region/region_filter.h"
#include "instant_motion_tracking/sim/scene.h"

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>

#include <stdexcept>
#include <string>
#include <vector>

namespace {

// Frame 0 or 1 of `cards` (its camera pans and its cards move between them).
const cv::Mat& cardsFrame(int i) {
  static const std::vector<cv::Mat> frames = [] {
    imt::SceneOptions o = *imt::SceneOptions::fromPreset("cards");
    o.width = 640;
    o.height = 480;
    std::string err;
    auto scene = imt::SceneGenerator::create(o, &err);
    if (!scene) throw std::runtime_error("scene: " + err);
    return std::vector<cv::Mat>{scene->renderFrame(0), scene->renderFrame(1)};
  }();
  return frames[i];
}

// The box (its size from the benchmark's arguments) at the frame's centre.
cv::Rect2d box(const benchmark::State& state) {
  const double w = static_cast<double>(state.range(0)), h = static_cast<double>(state.range(1));
  return cv::Rect2d(320 - w / 2, 240 - h / 2, w, h);
}

void boxSizes(benchmark::internal::Benchmark* b) {
  b->Args({12, 20})->Args({37, 69})->Args({110, 100});
}

void BM_FilterFind(benchmark::State& state) {
  imt::RegionFilter f;
  if (!imt::RegionFilter::create(cardsFrame(0), box(state), &f)) {
    state.SkipWithError("no filter");
    return;
  }
  for (auto _ : state) benchmark::DoNotOptimize(f.locate(cardsFrame(1), box(state)).peak);
}
BENCHMARK(BM_FilterFind)->Apply(boxSizes)->Unit(benchmark::kMicrosecond);

void BM_FilterLearn(benchmark::State& state) {
  imt::RegionFilter f;
  if (!imt::RegionFilter::create(cardsFrame(0), box(state), &f)) {
    state.SkipWithError("no filter");
    return;
  }
  for (auto _ : state) f.learn(cardsFrame(1), box(state), 0.04);
}
BENCHMARK(BM_FilterLearn)->Apply(boxSizes)->Unit(benchmark::kMicrosecond);

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core: the figures the targets are stated in
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  cardsFrame(0);  // render before any timing
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
