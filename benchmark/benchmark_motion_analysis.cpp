// Motion analysis speed at 640x480, 1280x720, 480x640 and 1920x1080 input
// (default options, analysis at 320 px width), next to the bare OpenCV work
// it builds on: downscale + cv::goodFeaturesToTrack + pyramidal LK, on the
// same frames and with the same feature count, window, levels and iterations.
//
//   make -C _build_motion benchmarks
//   taskset -c 0 _build_motion/benchmark/benchmark_motion_analysis
//
// OpenCV runs single-threaded here (cv::setNumThreads(1) in main) so the
// figures are per core. Frames are rendered before timing: the scene
// generator's "cards" preset (camera pan/roll/zoom, three moving cards), played
// forward and backward so that consecutive frames are always neighbours.
// BM_ModuleVsBaseline interleaves the two per frame and reports their ratio,
// which is robust to load from other processes. BM_CornerMapVsOpenCv does the
// same for the corner detection's map of one grid cell (MinEigenvalues
// against cv::cornerMinEigenVal).
#include "../src/core/motion/min_eigenvalues.h"
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/sim/scene.h"

#include <benchmark/benchmark.h>
#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <ctime>
#include <map>
#include <stdexcept>
#include <utility>
#include <vector>

namespace {

constexpr int kFrames = 60;

const std::vector<cv::Mat>& frames(int w, int h) {
  static std::map<std::pair<int, int>, std::vector<cv::Mat>> cache;
  auto& v = cache[{w, h}];
  if (v.empty()) {
    imt::SceneOptions o = *imt::SceneOptions::fromPreset("cards");
    o.width = w;
    o.height = h;
    o.duration = kFrames / o.fps;
    std::string err;
    auto scene = imt::SceneGenerator::create(o, &err);
    if (!scene) throw std::runtime_error("scene: " + err);
    for (int i = 0; i < std::min(kFrames, scene->frameCount()); ++i)
      v.push_back(scene->renderFrame(i));
  }
  return v;
}

// k-th frame of the forward-backward (ping-pong) sequence.
const cv::Mat& frameAt(const std::vector<cv::Mat>& v, int64_t k) {
  const int64_t n = static_cast<int64_t>(v.size());
  const int64_t period = 2 * n - 2;
  const int64_t i = k % period;
  return v[i < n ? i : period - i];
}

double threadCpuMs() {
  timespec t;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

// Mean number of features the module tracks on these frames: the baseline
// detects and tracks this many.
int moduleFeatureCount(const std::vector<cv::Mat>& v) {
  imt::MotionAnalyzer analyzer{imt::MotionAnalysisOptions()};
  int64_t sum = 0;
  for (size_t i = 0; i < v.size(); ++i)
    sum += analyzer.process(v[i], static_cast<double>(i)).features.size();
  return static_cast<int>(sum / static_cast<int64_t>(v.size()));
}

// Bare OpenCV: downscale, one pyramid (with derivatives, as the module keeps),
// forward LK of last frame's corners, corners detected afresh over the whole
// frame. No verification, no camera model, no classification.
class Baseline {
 public:
  explicit Baseline(int corners) : corners_(corners) {}
  void process(const cv::Mat& gray) {
    const imt::MotionAnalysisOptions o;
    const int aw = std::min(o.analysis_width, gray.cols);
    const int ah = gray.rows * aw / gray.cols;
    // The same downscale as the module (exact halvings, then the rest), so
    // that the comparison is about features and tracking.
    const cv::Mat* src = &gray;
    int k = 0;
    while (src->cols % 2 == 0 && src->rows % 2 == 0 && src->cols >= 2 * aw && src->rows >= 2 * ah) {
      cv::resize(*src, halves_[k % 2], cv::Size(src->cols / 2, src->rows / 2), 0, 0,
                 cv::INTER_AREA);
      src = &halves_[k++ % 2];
    }
    if (src->cols != aw || src->rows != ah)
      cv::resize(*src, small_, cv::Size(aw, ah), 0, 0, cv::INTER_AREA);
    else
      small_ = *src;
    const cv::Size win(o.lk_window, o.lk_window);
    cv::buildOpticalFlowPyramid(small_, cur_, win, o.lk_levels, true);
    if (!pts_.empty()) {
      cv::calcOpticalFlowPyrLK(
          prev_, cur_, pts_, next_, status_, err_, win, o.lk_levels,
          cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, o.lk_iterations, 0.01));
    }
    cv::goodFeaturesToTrack(small_, pts_, corners_, o.quality_level, o.min_distance);
    std::swap(prev_, cur_);
  }

 private:
  int corners_;
  cv::Mat small_, halves_[2];
  std::vector<cv::Mat> prev_, cur_;
  std::vector<cv::Point2f> pts_, next_;
  std::vector<uchar> status_;
  std::vector<float> err_;
};

// The input sizes: two landscape ones reached by halvings alone, a portrait
// one and 1920 x 1080 (a factor of 1.5 left after the halvings).
void inputSizes(benchmark::internal::Benchmark* b) {
  b->Args({640, 480})->Args({1280, 720})->Args({480, 640})->Args({1920, 1080});
}

void BM_MotionAnalysis(benchmark::State& state) {
  const auto& v = frames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  imt::MotionAnalyzer analyzer{imt::MotionAnalysisOptions()};
  int64_t k = 0, features = 0;
  for (; k < 10; ++k) analyzer.process(frameAt(v, k), k / 30.0);  // warm up: tracks established
  for (auto _ : state) {
    const imt::MotionData md = analyzer.process(frameAt(v, k), k / 30.0);
    features += md.features.size();
    benchmark::DoNotOptimize(md.camera.H(0, 0));
    ++k;
  }
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["features"] =
      static_cast<double>(features) / std::max<int64_t>(1, state.iterations());
}
BENCHMARK(BM_MotionAnalysis)->Apply(inputSizes)->Unit(benchmark::kMillisecond);

void BM_OpenCvBaseline(benchmark::State& state) {
  const auto& v = frames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  const int corners = moduleFeatureCount(v);
  Baseline baseline(corners);
  int64_t k = 0;
  for (; k < 2; ++k) baseline.process(frameAt(v, k));
  for (auto _ : state) baseline.process(frameAt(v, k++));
  state.counters["fps"] =
      benchmark::Counter(static_cast<double>(state.iterations()), benchmark::Counter::kIsRate);
  state.counters["features"] = corners;
}
BENCHMARK(BM_OpenCvBaseline)->Apply(inputSizes)->Unit(benchmark::kMillisecond);

// Both on each frame, timed by thread CPU time; the ratio is module / baseline.
void BM_ModuleVsBaseline(benchmark::State& state) {
  const auto& v = frames(static_cast<int>(state.range(0)), static_cast<int>(state.range(1)));
  imt::MotionAnalyzer analyzer{imt::MotionAnalysisOptions()};
  Baseline baseline(moduleFeatureCount(v));
  int64_t k = 0;
  for (; k < 10; ++k) analyzer.process(frameAt(v, k), k / 30.0), baseline.process(frameAt(v, k));
  double module_ms = 0, baseline_ms = 0;
  for (auto _ : state) {
    const cv::Mat& f = frameAt(v, k);
    const double t0 = threadCpuMs();
    benchmark::DoNotOptimize(analyzer.process(f, k / 30.0).camera.H(0, 0));
    const double t1 = threadCpuMs();
    baseline.process(f);
    baseline_ms += threadCpuMs() - t1;
    module_ms += t1 - t0;
    ++k;
  }
  const double n = static_cast<double>(std::max<int64_t>(1, state.iterations()));
  state.counters["module_ms"] = module_ms / n;
  state.counters["baseline_ms"] = baseline_ms / n;
  state.counters["ratio"] = baseline_ms > 0 ? module_ms / baseline_ms : 0;
}
BENCHMARK(BM_ModuleVsBaseline)->Apply(inputSizes)->Unit(benchmark::kMillisecond);

// The corner map of each grid cell (8 x 6, default options) of the 320 x 240
// analysis frame, with its pixel of context, as the feature tracker asks for
// it: MinEigenvalues and cv::cornerMinEigenVal in turn on each cell, timed
// by thread CPU time; the ratio is ours / OpenCV's.
void BM_CornerMapVsOpenCv(benchmark::State& state) {
  const auto& v = frames(640, 480);
  const imt::MotionAnalysisOptions o;
  std::vector<cv::Mat> small(8);
  for (size_t i = 0; i < small.size(); ++i)
    cv::resize(frameAt(v, static_cast<int64_t>(i)), small[i], cv::Size(320, 240), 0, 0,
               cv::INTER_AREA);
  const cv::Size size = small[0].size();
  std::vector<cv::Rect> cells;
  for (int gy = 0; gy < o.grid_rows; ++gy)
    for (int gx = 0; gx < o.grid_cols; ++gx) {
      const int x0 = gx * size.width / o.grid_cols, x1 = (gx + 1) * size.width / o.grid_cols;
      const int y0 = gy * size.height / o.grid_rows, y1 = (gy + 1) * size.height / o.grid_rows;
      cells.push_back(cv::Rect(x0 - 1, y0 - 1, x1 - x0 + 2, y1 - y0 + 2) &
                      cv::Rect(cv::Point(), size));
    }
  imt::MinEigenvalues ours;
  cv::Mat map;
  double ours_ms = 0, opencv_ms = 0;
  int64_t k = 0, n = 0;
  for (auto _ : state) {
    const cv::Mat& f = small[k++ % small.size()];
    for (const cv::Rect& c : cells) {
      const double t0 = threadCpuMs();
      ours.apply(f, c, &map);
      benchmark::DoNotOptimize(map.data);
      const double t1 = threadCpuMs();
      cv::cornerMinEigenVal(f(c), map, 3, 3);
      benchmark::DoNotOptimize(map.data);
      opencv_ms += threadCpuMs() - t1;
      ours_ms += t1 - t0;
      ++n;
    }
  }
  state.counters["ours_us_per_cell"] = 1e3 * ours_ms / std::max<int64_t>(1, n);
  state.counters["opencv_us_per_cell"] = 1e3 * opencv_ms / std::max<int64_t>(1, n);
  state.counters["ratio"] = opencv_ms > 0 ? ours_ms / opencv_ms : 0;
}
BENCHMARK(BM_CornerMapVsOpenCv)->Unit(benchmark::kMillisecond);

}  // namespace

int main(int argc, char** argv) {
  cv::setNumThreads(1);  // one core: the figures the targets are stated in
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  frames(640, 480);  // render before any timing
  frames(1280, 720);
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}
