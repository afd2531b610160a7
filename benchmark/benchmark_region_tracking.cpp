// Region tracking speed and accuracy against peers, in one process on the
// same rendered frames (the `cards` scene): this package's whole pipeline
// (motion analysis + region tracking) with 1, 4, 10 and 100 regions, and
// OpenCV's KCF and CSRT trackers (opencv_contrib) on the same 4 regions.
// Prints a table: frames per second of the whole pipeline and mean IoU
// against the generator's ground truth. Single-threaded (cv::setNumThreads(1);
// --threads N: OpenCV's parallel loops on N threads, for every tracker).
//
//   make -C _build benchmarks && taskset -c 0 _build/benchmark/benchmark_region_tracking [--set option=value] [--ours-only] [--regions N] [--threads N] [--with-target] [seconds]
//
// --set name=value changes a region_tracking option of the first rows (read
// as config YAML is), to see what a part of the tracker costs; --ours-only
// leaves out the peers (a minute of CSRT); --regions N runs our rows with N
// regions only (after a warm-up run with one), e.g. to profile that count;
// --with-target also tracks the static patch as a planar target in our
// rows (regions and a target in one session: what the target adds).
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "../test/box_metrics.h"
#include "instant_motion_tracking/core/tracking_session.h"
#include "instant_motion_tracking/io/config.h"
#include "set_option.h"
#include "instant_motion_tracking/sim/scene.h"

#include <opencv2/imgproc.hpp>
#ifdef IMT_HAVE_OPENCV_TRACKING
#include <opencv2/tracking.hpp>
#endif

#include <array>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <map>
#include <random>

namespace {

using Clock = std::chrono::steady_clock;
using imt::FrameTruth;

using imt::test::iouClipped;

const FrameTruth::Region* region(const FrameTruth& f, uint32_t id) {
  for (const auto& r : f.regions)
    if (r.id == id) return &r;
  return nullptr;
}

struct Row {
  std::string name;
  int regions;
  double fps, iou;
};

// Mean IoU over the scored regions and frames where they are >= half visible.
struct IouAccumulator {
  double sum = 0;
  int n = 0;
  void add(const cv::Rect2d& box, const FrameTruth& f, uint32_t id, cv::Size size, bool lost = false) {
    const FrameTruth::Region* r = region(f, id);
    if (!r || r->visible_fraction < 0.5) return;
    sum += lost ? 0 : iouClipped(box, r->box, size);
    ++n;
  }
  double mean() const { return n ? sum / n : 0; }
};

}  // namespace

constexpr char kUsage[] =
    "usage: benchmark_region_tracking [--set option=value] [--ours-only] [--regions N] [--threads N] [--with-target] [seconds]\n"
    "  --set name=value  a region_tracking option of our rows, section.name=value another section's (as in config YAML)\n"
    "  --ours-only       leave out OpenCV's KCF and CSRT (a minute of CSRT)\n"
    "  --regions N       our rows with N regions only (1..1000), after a warm-up with one\n"
    "  --threads N       OpenCV's parallel loops on N threads, for every tracker (default 1; our regions\n"
    "                    step in parallel on them)\n"
    "  --with-target     our rows also track the static patch as a planar target (its cost)\n"
    "  seconds           length of the rendered `cards` scene (default 10)\n";

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  int threads = 1;
  double seconds = 10.0;
  bool peers = true;
  bool with_target = false;
  std::vector<int> counts = {1, 4, 10, 100};
  imt::Config config;  // the first rows' options: the defaults, with --set
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--set" && i + 1 < argc) {
      if (!imt::bench::setOption(argv[++i], &config)) return 2;
    } else if (a == "--ours-only") {
      peers = false;
    } else if (a == "--with-target") {
      with_target = true;
    } else if (a == "--regions" && i + 1 < argc) {
      const int c = std::atoi(argv[++i]);
      if (c < 1 || c > 1000) {
        std::fprintf(stderr, "--regions: 1 to 1000 (got %s)\n", argv[i]);
        return 2;
      }
      counts = {c};
    } else if (a == "--threads" && i + 1 < argc) {
      if (!imt::bench::setThreads(argv[++i], &threads)) return 2;
    } else if (a == "--help" || a == "-h") {
      std::printf("%s", kUsage);
      return 0;
    } else {
      char* end = nullptr;
      seconds = std::strtod(argv[i], &end);
      if (a.empty() || *end != '\0' || !(seconds > 0)) {
        std::fprintf(stderr, "unknown argument '%s' (not an option, nor a length in seconds)\n%s", argv[i], kUsage);
        return 2;
      }
    }
  }
  auto opt = imt::SceneOptions::fromPreset("cards");
  opt->duration = seconds;
  opt->seed = 11;
  std::string err;
  auto scene = imt::SceneGenerator::create(*opt, &err);
  if (!scene) {
    std::fprintf(stderr, "scene: %s\n", err.c_str());
    return 1;
  }
  std::vector<cv::Mat> gray, bgr;
  std::vector<FrameTruth> truth;
  for (int i = 0; i < scene->frameCount(); ++i) {
    gray.push_back(scene->renderFrame(i));
    cv::Mat c;
    cv::cvtColor(gray.back(), c, cv::COLOR_GRAY2BGR);
    bgr.push_back(c);
    truth.push_back(scene->frameTruth(i));
  }
  const std::vector<uint32_t> scored = {1, 2, 3, 4};  // three cards and the static patch
  // Start where every scored region is wholly in view and unoccluded (a box
  // given on a half-visible card would stand for only that half).
  int start = 0;
  for (; start < static_cast<int>(truth.size()); ++start) {
    bool whole = true;
    for (uint32_t id : scored) {
      const FrameTruth::Region* r = region(truth[start], id);
      whole = whole && r && r->visible_fraction > 0.999 && r->occluded_fraction < 0.001;
    }
    if (whole) break;
  }
  if (start + 2 > static_cast<int>(truth.size())) {
    std::fprintf(stderr, "the scored regions are not all in view before frame %d of %d: give more than %.1f seconds\n",
                 start, static_cast<int>(truth.size()), seconds);
    return 2;
  }
  gray.erase(gray.begin(), gray.begin() + start);
  bgr.erase(bgr.begin(), bgr.begin() + start);
  truth.erase(truth.begin(), truth.begin() + start);
  std::vector<double> stamps;
  for (int i = start; i < scene->frameCount(); ++i) stamps.push_back(scene->frameStamp(i));
  std::vector<Row> rows;
  const cv::Size size = gray[0].size();
  const int n = static_cast<int>(gray.size());

  // This package: the whole pipeline, live (regions given at the first frame).
  // With the regions' appearance check and own corners (the default), and
  // without either (motion data alone, the paper's tracker).
  for (const bool appearance : {true, false}) {
  std::vector<int> runs = {1};  // the first run warms caches and allocators
  runs.insert(runs.end(), counts.begin(), counts.end());
  for (size_t run = 0; run < runs.size(); ++run) {
    const int count = runs[run];
    imt::PipelineOptions options = config.pipeline;
    if (!appearance) {
      options.region_tracking.appearance = false;
      options.region_tracking.region_features = 0;
    }
    imt::TrackingSession session(options, imt::TrackingSession::Mode::kLive);
    std::map<uint32_t, uint32_t> truth_id;  // tracker id -> scored truth id
    IouAccumulator acc;
    double total = 0;
    for (int k = 0; k < n; ++k) {
      const auto t0 = Clock::now();
      session.analyze(gray[k], stamps[k]);
      session.advance();
      std::vector<imt::RegionState> states;
      for (imt::FrameResult& r : session.takeResults()) states = std::move(r.regions);
      if (k == 0) {
        uint32_t id_unused;
        std::mt19937 rng(1);
        std::uniform_real_distribution<double> ux(0, size.width - 60), uy(0, size.height - 50);
        for (int r = 0; r < count; ++r) {
          uint32_t id;
          cv::Rect2d box(ux(rng), uy(rng), 60, 50);
          if (r < static_cast<int>(scored.size())) box = region(truth[0], scored[r])->box;
          session.addRegion(0, 0, box, &id, &err);
          if (r < static_cast<int>(scored.size())) truth_id[id] = scored[r];
        }
        if (with_target) {
          // The static patch (scored region 4) as a planar target too, its
          // size in metres made up: its cost is what is measured.
          const cv::Rect2d p = region(truth[0], scored[3])->box;
          const std::array<cv::Point2d, 4> corners = {p.tl(), cv::Point2d(p.br().x, p.y), p.br(),
                                                      cv::Point2d(p.x, p.br().y)};
          if (!session.addPlanarTarget(0, 0, corners, 0.5, 0.4, &id_unused, &err))
            std::fprintf(stderr, "planar target: %s\n", err.c_str());
        }
        session.seekRegions(stamps[k], {}, &states, &err);
      }
      total += std::chrono::duration<double>(Clock::now() - t0).count();
      for (const auto& s : states)
        if (truth_id.count(s.id))
          acc.add(s.extent(), truth[k], truth_id[s.id], size, s.status == imt::RegionStatus::kLost);
    }
    if (run == 0) continue;  // the warm-up
    rows.push_back({appearance ? "instant_motion_tracking (pipeline)" : "instant_motion_tracking (pipeline, motion data alone)",
                    count, n / total, acc.mean()});
  }
  }

#ifdef IMT_HAVE_OPENCV_TRACKING
  // Peers on the same 4 regions, each tracker on its own.
  for (const std::string name : {"KCF", "CSRT"}) {
    if (!peers) break;
    std::vector<cv::Ptr<cv::Tracker>> trackers;
    IouAccumulator acc;
    double total = 0;
    for (int k = 0; k < n; ++k) {
      const auto t0 = Clock::now();
      std::vector<cv::Rect> boxes(scored.size());
      std::vector<bool> ok(scored.size(), true);
      if (k == 0) {
        for (size_t r = 0; r < scored.size(); ++r) {
          cv::Ptr<cv::Tracker> t;
          if (name == "KCF") t = cv::TrackerKCF::create();
          else t = cv::TrackerCSRT::create();
          boxes[r] = region(truth[0], scored[r])->box;
          t->init(bgr[0], boxes[r]);
          trackers.push_back(t);
        }
      } else {
        for (size_t r = 0; r < scored.size(); ++r) ok[r] = trackers[r]->update(bgr[k], boxes[r]);
      }
      total += std::chrono::duration<double>(Clock::now() - t0).count();
      for (size_t r = 0; r < scored.size(); ++r) acc.add(cv::Rect2d(boxes[r]), truth[k], scored[r], size, !ok[r]);
    }
    rows.push_back({"OpenCV " + name, static_cast<int>(scored.size()), n / total, acc.mean()});
  }
#else
  std::printf("(OpenCV tracking module not found: KCF/CSRT rows skipped; install libopencv-contrib-dev)\n");
#endif

  std::printf("\nRegion tracking, cards scene %dx%d, %d frames (from frame %d), %s\n", size.width, size.height, n,
              start, threads == 1 ? "one thread" : (std::to_string(threads) + " threads").c_str());
  std::printf("| tracker | regions | frames/s | ms/frame | mean IoU (scored regions) |\n|---|---|---|---|---|\n");
  for (const Row& r : rows)
    std::printf("| %s | %d | %.1f | %.2f | %.3f |\n", r.name.c_str(), r.regions, r.fps, 1000 / r.fps, r.iou);
  return 0;
}
