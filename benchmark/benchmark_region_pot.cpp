// Region tracking on real video against peers: the POT-210 excerpt
// (../shared/data/pot210_excerpt, or $IMT_SHARED_DATA; 1280x720 phone video
// with official corner ground truth). Each tracker is given the bounding box
// of the target's frame-1 corners and scored by IoU against the bounding box
// of the annotated corners (annotated, unflagged frames). This package's
// whole pipeline (motion analysis + region tracking) against OpenCV's KCF and
// CSRT (opencv_contrib). Single-threaded (cv::setNumThreads(1)).
//
//   make -C _build benchmarks && taskset -c 0 _build/benchmark/benchmark_region_pot
#include "instant_motion_tracking/core/motion/motion_analysis.h"
#include "instant_motion_tracking/core/region/region_manager.h"

#include "../test/box_metrics.h"
#include "../test/pot210.h"

#include <opencv2/imgproc.hpp>
#ifdef IMT_HAVE_OPENCV_TRACKING
#include <opencv2/tracking.hpp>
#endif

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>

namespace {

using Clock = std::chrono::steady_clock;

// Runs one tracker over the sequence: `step(frame number, box)` tracks frame
// f (from 1; frame 1 initialises) and returns false when the tracker reports
// a failure. Prints a table row.
void run(const imt::test::PotSequence& pot, cv::Size size, const char* name,
         const std::function<bool(int, cv::Rect2d*)>& step) {
  double seconds = 0, sum = 0;
  int scored = 0;
  for (int f = 1; f <= pot.frames(); ++f) {
    cv::Rect2d box = pot.box(1);
    const auto t0 = Clock::now();
    const bool ok = step(f, &box);
    seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    if (f == 1 || !pot.scored(f)) continue;
    sum += ok ? imt::test::iouClipped(box, pot.box(f), size) : 0.0;
    ++scored;
  }
  std::printf("| %s | %s | %d | %.1f | %.2f | %.3f |\n", pot.name().c_str(), name, scored, pot.frames() / seconds,
              1000 * seconds / pot.frames(), scored ? sum / scored : 0.0);
}

}  // namespace

int main() {
  cv::setNumThreads(1);
  const char* env = std::getenv("IMT_SHARED_DATA");
  const std::string dir = std::string(env && *env ? env : IMT_SHARED_DATA_DIR) + "/pot210_excerpt";
  std::printf("Region tracking on POT-210 (%s), one thread; IoU of the target's bounding box\n", dir.c_str());
  std::printf("| sequence | tracker | frames scored | frames/s | ms/frame | mean IoU |\n|---|---|---|---|---|---|\n");
  for (const auto& [name, frames] : {std::pair<const char*, int>{"V25_2", 50}, {"V24_7", 110}}) {
    imt::test::PotSequence pot;
    if (!pot.load(dir, name, frames)) {
      std::fprintf(stderr, "POT-210 sequence %s not found under %s\n", name, dir.c_str());
      return 1;
    }
    std::vector<cv::Mat> gray, bgr;
    for (int f = 1; f <= frames; ++f) {
      gray.push_back(pot.gray(f));
      cv::Mat c;
      cv::cvtColor(gray.back(), c, cv::COLOR_GRAY2BGR);
      bgr.push_back(c);
    }
    // This package, live: the region is given at frame 1 and followed frame by frame.
    imt::MotionAnalyzer analyzer{imt::MotionAnalysisOptions()};
    imt::RegionManager regions(imt::RegionTrackerOptions(), 10.0);
    uint32_t id = 0;
    run(pot, gray[0].size(), "instant_motion_tracking (pipeline)", [&](int f, cv::Rect2d* box) {
      const std::vector<imt::RegionState> states = regions.update(analyzer.process(gray[f - 1], f / 30.0));
      std::string err;
      if (f == 1) return regions.add(1, 0, pot.box(1), &id, &err);
      for (const imt::RegionState& s : states)
        if (s.id == id) {
          *box = s.box;
          return s.status != imt::RegionStatus::kLost;
        }
      return false;
    });
#ifdef IMT_HAVE_OPENCV_TRACKING
    for (const char* peer : {"OpenCV KCF", "OpenCV CSRT"}) {
      cv::Ptr<cv::Tracker> t;
      if (std::string(peer) == "OpenCV KCF") t = cv::TrackerKCF::create();
      else t = cv::TrackerCSRT::create();
      run(pot, gray[0].size(), peer, [&](int f, cv::Rect2d* box) {
        if (f == 1) {
          t->init(bgr[0], cv::Rect(pot.box(1)));
          return true;
        }
        cv::Rect r;
        const bool ok = t->update(bgr[f - 1], r);
        *box = cv::Rect2d(r);
        return ok;
      });
    }
#endif
  }
#ifndef IMT_HAVE_OPENCV_TRACKING
  std::printf("(OpenCV tracking module not found: KCF/CSRT rows skipped; install libopencv-contrib-dev)\n");
#endif
  return 0;
}
