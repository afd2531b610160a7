// Region tracking on real video against peers: every sequence with box
// ground truth in ../shared/data (or $IMT_SHARED_DATA): VOT2015 car1, UAV123
// boat1, OTB Human3 and POT-210's corner boxes (test/box_sequence.h). Each
// tracker is given the first frame's ground-truth box and runs frame by
// frame, as live. This package runs whole (imt::TrackingSession: motion
// analysis and region tracking, default options, gray frames); OpenCV's KCF
// and CSRT (opencv_contrib) get the colour frames (--peers-gray: the same
// gray frames, as three channels). Scores (OTB definitions,
// frames from the second; a lost region scores IoU 0): success AUC, mean
// IoU, precision at 20 px, and frames/s (tracking only, decoding excluded).
// Single-threaded (cv::setNumThreads(1); --threads N: OpenCV's parallel loops
// on N threads, for every tracker). Each tracker is timed on a warm
// heap: on this project's virtual machines a page's first write costs about
// 12 us, and memory the allocator hands back to the system and takes again
// is written for the first time again (CSRT alone in a fresh process: 22
// frames/s on car1, 48 with glibc's trimming off). So the allocator keeps
// what is freed (mallopt below), ours gets one untimed run of each sequence
// first (--cold: none), and the peers run after it, on the memory it freed.
//
//   make -C _build benchmarks && taskset -c 0 _build/benchmark/benchmark_region_real [--ours-only] [--no-appearance] [--set option=value] [--trace] [--trace-peers] [--peers-gray] [--starts N] [--sre] [--per-start] [--stride N] [--mid] [--cold] [--threads N] [--stages] [sequence...]
#include "instant_motion_tracking/core/tracking_session.h"
#include "instant_motion_tracking/io/config.h"
#include "set_option.h"

#include "../test/box_sequence.h"

#include <opencv2/imgproc.hpp>

#ifdef IMT_HAVE_OPENCV_TRACKING
#include <opencv2/tracking.hpp>
#endif

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <map>
#include <set>

#include <malloc.h>

namespace {

using Clock = std::chrono::steady_clock;

struct Row {
  double auc = 0, iou = 0, p20 = 0, fps = 0;
  double auc_min = 0, auc_max = 0;  // over the runs from nudged starts (--starts)
  std::vector<double> aucs;          // each run's, in the order of the starts (--per-start)
};

// The row of one run: its scores, and `frames` tracked in `seconds`.
Row scoreOf(const imt::test::BoxScore& score, int frames, double seconds) {
  const double auc = score.successAuc();
  return {auc, score.meanIou(), score.precision20(), seconds > 0 ? frames / seconds : 0, auc, auc, {auc}};
}

// Runs one tracker over the sequence: `step(frame number, &box)` tracks frame
// f (from 1; frame 1 initialises) and returns false when it reports no box.
Row run(const imt::test::BoxSequence& seq, const std::vector<cv::Mat>& frames,
        const std::function<bool(int, cv::Rect2d*)>& step) {
  imt::test::BoxScore score;
  double seconds = 0;
  for (int f = 1; f <= seq.frames(); ++f) {
    cv::Rect2d box;
    const auto t0 = Clock::now();
    const bool ok = step(f, &box);
    seconds += std::chrono::duration<double>(Clock::now() - t0).count();
    if (f > 1 && seq.scored(f)) score.add(ok, box, seq.box(f), frames[0].size());
  }
  return scoreOf(score, seq.frames(), seconds);
}

// --starts N: each tracker runs N times, from the first frame's box and from
// N - 1 copies of it nudged by a pixel or two (what a careful user's drawing
// varies by). Tracking on real video is chaotic: one run's score moves by a
// few hundredths on any small change, so a change is judged by the mean and
// the spread of these runs. The nudge of run k (0: none; x, y, width,
// height in px), each a different box: at most kMaxStarts runs.
constexpr int kNudge[][4] = {{0, 0, 0, 0},  {1, 0, 0, 0},    {0, 1, 0, 0},   {-1, 0, 0, 0},
                             {0, -1, 0, 0}, {0, 0, 2, 0},    {0, 0, 0, 2},   {1, 1, -2, -2},
                             {-2, 1, 1, 0}, {1, -2, 0, 1},   {2, 2, 0, 0},   {-2, -2, 2, 2},
                             {0, 0, -2, 0}, {0, 0, 0, -2},   {2, -1, -1, 1}, {-1, 2, 1, -1}};
constexpr int kMaxStarts = sizeof(kNudge) / sizeof(kNudge[0]);
cv::Rect2d nudged(const cv::Rect2d& b, int k) {
  const int* n = kNudge[k];
  return cv::Rect2d(b.x + n[0], b.y + n[1], b.width + n[2], b.height + n[3]);
}

// --sre: the starts are OTB's spatial robustness evaluation's (Wu, Lim and
// Yang, "Online Object Tracking: A Benchmark", CVPR 2013) instead: the box
// shifted by a tenth of its width and height (4 ways along the axes, 4 along
// the diagonals), and scaled about its centre by 0.8, 0.9, 1.1 and 1.2. A
// user's box is rarely drawn to the pixel; this is how far off OTB's
// authors take one to be.
bool g_sre = false;
constexpr double kSre[][3] = {{-0.1, 0, 1},  {0.1, 0, 1},    {0, -0.1, 1},  {0, 0.1, 1},
                              {-0.1, -0.1, 1}, {0.1, -0.1, 1}, {-0.1, 0.1, 1}, {0.1, 0.1, 1},
                              {0, 0, 0.8},   {0, 0, 0.9},    {0, 0, 1.1},   {0, 0, 1.2}};
constexpr int kSreStarts = sizeof(kSre) / sizeof(kSre[0]);
cv::Rect2d sreBox(const cv::Rect2d& b, int k) {
  const double* e = kSre[k];
  const double w = b.width * e[2], h = b.height * e[2];
  const double cx = b.x + b.width * (0.5 + e[0]), cy = b.y + b.height * (0.5 + e[1]);
  return cv::Rect2d(cx - w / 2, cy - h / 2, w, h);
}

// Run k's start from the box given: nudged, or with --sre OTB's.
cv::Rect2d startBox(const cv::Rect2d& b, int k) { return g_sre ? sreBox(b, k) : nudged(b, k); }

// Adds run k of `runs` to their mean `m`, and its AUC to their spread.
void addRun(const Row& r, int k, int runs, Row* m) {
  m->auc += r.auc / runs;
  m->iou += r.iou / runs;
  m->p20 += r.p20 / runs;
  m->fps += r.fps / runs;
  m->auc_min = k == 0 ? r.auc : std::min(m->auc_min, r.auc);
  m->auc_max = k == 0 ? r.auc : std::max(m->auc_max, r.auc);
  m->aucs.push_back(r.auc);
}

// Mean of `runs` runs of `one(start box)`, with the spread of their AUC.
Row runFromStarts(const imt::test::BoxSequence& seq, int runs, const std::function<Row(const cv::Rect2d&)>& one) {
  Row m;
  for (int k = 0; k < runs; ++k) addRun(one(startBox(seq.box(1), k)), k, runs, &m);
  return m;
}

// --trace: one line per frame of this package's run on stderr.
bool g_trace = false;
// --trace-peers: the same for the peers (their box, IoU and whether they
// reported one).
bool g_trace_peers = false;
// The options of this package's run: the defaults, with --no-appearance
// (regions on motion data alone, the paper's tracker) and --set
// name=value (a region_tracking option, read as config YAML is).
imt::Config g_config;

// --stages: our runs' wall time per stage of the session (motion analysis,
// region tracking, ...), summed over the timed runs of each sequence (the
// warm-up left out), printed after the table.
bool g_stages = false;
std::map<std::string, imt::StageTimes> g_stage_times;
void addStages(const std::string& sequence, const imt::StageTimes& t) {
  imt::StageTimes& sum = g_stage_times[sequence];
  for (const auto& [stage, seconds] : t.seconds) sum.seconds[stage] += seconds;
  sum.frames += t.frames;
}

Row runOurs(const imt::test::BoxSequence& seq, const std::vector<cv::Mat>& gray, const cv::Rect2d& start) {
  imt::TrackingSession session(g_config.pipeline, imt::TrackingSession::Mode::kLive);
  uint32_t id = 0;
  const Row row = run(seq, gray, [&](int f, cv::Rect2d* box) {
    session.analyze(gray[f - 1], seq.stamp(f));
    session.advance();
    std::string err;
    if (f == 1) {
      session.takeResults();
      return session.addRegion(1, 0, start, &id, &err);
    }
    for (const imt::FrameResult& r : session.takeResults())
      for (const imt::RegionState& s : r.regions)
        if (s.id == id) {
          *box = s.extent();
          if (g_trace)
            std::fprintf(stderr, "%s %d turn %.1f iou %.2f %s app %.2f conf %.2f inliers %zu outliers %zu support %.0f box %.0f %.0f %.0f %.0f truth %.0f %.0f %.0f %.0f %s %s\n",
                         seq.name().c_str(), f, s.angle * 180 / M_PI, imt::test::iouClipped(*box, seq.box(f), gray[0].size()),
                         imt::regionStatusName(s.status), s.appearance_score, s.confidence, s.inliers.size(), s.outliers.size(), s.support,
                         box->x, box->y, box->width, box->height, seq.box(f).x, seq.box(f).y, seq.box(f).width,
                         seq.box(f).height, imt::motionModelName(r.motion.camera.model), s.reason.c_str());
          return s.status != imt::RegionStatus::kLost;
        }
    return false;
  });
  addStages(seq.name(), session.times());
  return row;
}

// --mid: the box is given at the middle frame (the first scored one from
// half way), and the frames before it (tracked backwards) and after it are
// scored apart. This package runs offline, as track_bag does (a session in
// Mode::kOffline over the whole sequence, the region added at its frame, each
// frame's state read with statesAt()).
struct Halves {
  Row backward, forward;
};

Halves runOursMid(const imt::test::BoxSequence& seq, const std::vector<cv::Mat>& gray, int mid,
                  const cv::Rect2d& start) {
  const auto t0 = Clock::now();
  imt::TrackingSession session(g_config.pipeline, imt::TrackingSession::Mode::kOffline);
  // The frames beyond the image budget, as track_bag reads them again from the bag.
  session.setImageSource(seq.framesByStamp(gray));
  for (int f = 1; f <= seq.frames(); ++f) {
    session.analyze(gray[f - 1], seq.stamp(f));
    session.advance();
    session.takeResults();
  }
  session.advance(/*all=*/true);
  session.takeResults();
  uint32_t id = 0;
  std::string err;
  Halves h;
  if (!session.addRegion(1, seq.stamp(mid), start, &id, &err)) {
    std::fprintf(stderr, "%s: the region was refused at frame %d: %s\n", seq.name().c_str(), mid, err.c_str());
    return h;
  }
  imt::test::BoxScore back, fwd;
  for (int f = 1; f <= seq.frames(); ++f) {
    if (f == mid || !seq.scored(f)) continue;
    imt::FrameResult r;
    bool ok = false;
    cv::Rect2d box;
    if (session.statesAt(seq.stamp(f), &r, &err))
      for (const imt::RegionState& s : r.regions)
        if (s.id == id) {
          box = s.extent();
          ok = s.status != imt::RegionStatus::kLost;
          if (g_trace)
            std::fprintf(stderr, "%s %d iou %.2f %s app %.2f conf %.2f inliers %zu box %.0f %.0f %.0f %.0f truth %.0f %.0f %.0f %.0f %s\n",
                         seq.name().c_str(), f, imt::test::iouClipped(box, seq.box(f), gray[0].size()),
                         imt::regionStatusName(s.status), s.appearance_score, s.confidence, s.inliers.size(), box.x,
                         box.y, box.width, box.height, seq.box(f).x, seq.box(f).y, seq.box(f).width,
                         seq.box(f).height, s.reason.c_str());
        }
    (f < mid ? back : fwd).add(ok, box, seq.box(f), gray[0].size());
  }
  const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
  // The frames/s of the whole run (the analysis of every frame, both halves tracked).
  h.backward = scoreOf(back, seq.frames(), seconds);
  h.forward = scoreOf(fwd, seq.frames(), seconds);
  return h;
}

Halves midFromStarts(const imt::test::BoxSequence& seq, int runs, int mid,
                     const std::function<Halves(const cv::Rect2d&)>& one) {
  Halves m;
  for (int k = 0; k < runs; ++k) {
    const Halves h = one(startBox(seq.box(mid), k));
    addRun(h.backward, k, runs, &m.backward);
    addRun(h.forward, k, runs, &m.forward);
  }
  return m;
}

#ifdef IMT_HAVE_OPENCV_TRACKING
Row runPeer(const imt::test::BoxSequence& seq, const std::vector<cv::Mat>& colour, cv::Ptr<cv::Tracker> t,
            const cv::Rect2d& start) {
  return run(seq, colour, [&](int f, cv::Rect2d* box) {
    if (f == 1) {
      t->init(colour[0], cv::Rect(start));
      return true;
    }
    cv::Rect r;
    const bool ok = t->update(colour[f - 1], r);
    *box = cv::Rect2d(r);
    if (g_trace_peers)
      std::fprintf(stderr, "%s %d peer iou %.2f %s box %d %d %d %d truth %.0f %.0f %.0f %.0f\n", seq.name().c_str(), f,
                   imt::test::iouClipped(*box, seq.box(f), colour[0].size()), ok ? "ok" : "failed", r.x, r.y, r.width,
                   r.height, seq.box(f).x, seq.box(f).y, seq.box(f).width, seq.box(f).height);
    return ok;
  });
}

// --mid for a peer: a fresh tracker from the middle frame's box each way,
// over the frames after it and over the frames before it in reverse.
Halves runPeerMid(const imt::test::BoxSequence& seq, const std::vector<cv::Mat>& colour,
                  const std::function<cv::Ptr<cv::Tracker>()>& make, int mid, const cv::Rect2d& start) {
  Halves h;
  for (const int dir : {-1, 1}) {
    cv::Ptr<cv::Tracker> t = make();
    imt::test::BoxScore score;
    const auto t0 = Clock::now();
    t->init(colour[mid - 1], cv::Rect(start));
    int n = 0;
    for (int f = mid + dir; f >= 1 && f <= seq.frames(); f += dir, ++n) {
      cv::Rect r;
      const bool ok = t->update(colour[f - 1], r);
      if (seq.scored(f)) score.add(ok, cv::Rect2d(r), seq.box(f), colour[0].size());
    }
    const double seconds = std::chrono::duration<double>(Clock::now() - t0).count();
    (dir < 0 ? h.backward : h.forward) = scoreOf(score, n, seconds);
  }
  return h;
}
#endif

}  // namespace

constexpr char kUsage[] =
    "usage: benchmark_region_real [--ours-only] [--no-appearance] [--set option=value] [--trace] [--trace-peers]\n"
    "                             [--peers-gray] [--starts N] [--sre] [--per-start] [--stride N] [--mid] [--cold]\n"
    "                             [--threads N] [--stages] [sequence...]\n"
    "  --ours-only       leave out OpenCV's KCF and CSRT\n"
    "  --no-appearance   our tracker on motion data alone (no look, no own corners)\n"
    "  --set name=value  a region_tracking option, section.name=value another section's (as in config YAML)\n"
    "  --trace           our tracker's state on every frame (implies --ours-only)\n"
    "  --trace-peers     the peers' boxes on every frame\n"
    "  --peers-gray      the peers get the gray frames this package gets, not the colour ones\n"
    "  --starts N        mean of N runs: from the first box and N - 1 nudged copies (N <= 16)\n"
    "  --per-start       also each run's success AUC, after the table (with --starts or --sre)\n"
    "  --sre             runs from OTB's 12 spatially perturbed boxes instead (shifted by a tenth\n"
    "                    of the box's sides 8 ways, scaled by 0.8, 0.9, 1.1, 1.2); not with --starts\n"
    "  --stride N        every Nth frame only, at fps / N (a camera N times slower: targets move\n"
    "                    N times as far between frames); the table's names then end in /N\n"
    "  --mid             the box given at the middle frame; the halves before it (tracked\n"
    "                    backwards; ours offline, as track_bag) and after it scored apart\n"
    "  --cold            no untimed warm-up run of ours on each sequence first (its first run's\n"
    "                    frames/s then include the faults of a fresh process's memory)\n"
    "  --threads N       OpenCV's parallel loops on N threads, for every tracker (default 1)\n"
    "  --stages          our time per stage of the session (motion analysis, region tracking),\n"
    "                    ms a frame, after the table (runs from the first frame's box)\n"
    "  sequence          only these (names as in the table; default every one found)\n"
    "Reads ../shared/data beside the package, or $IMT_SHARED_DATA.\n";

int main(int argc, char** argv) {
  cv::setNumThreads(1);
  // Freed memory kept for the next run, whatever its size (see the top of
  // this file): blocks up to glibc's largest mmap threshold (32 MB) from the
  // heap, and the heap never trimmed.
  mallopt(M_MMAP_THRESHOLD, 32 << 20);
  mallopt(M_TRIM_THRESHOLD, -1);
  bool ours_only = false, mid_mode = false, peers_gray = false, per_start = false, cold = false;
  int starts = 1, stride = 1, threads = 1;
  std::set<std::string> only;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--ours-only") ours_only = true;
    else if (a == "--no-appearance") {
      g_config.pipeline.region_tracking.appearance = false;
      g_config.pipeline.region_tracking.region_features = 0;
    }
    else if (a == "--set" && i + 1 < argc) {
      if (!imt::bench::setOption(argv[++i], &g_config)) return 2;
    }
    else if (a == "--trace") g_trace = ours_only = true;
    else if (a == "--trace-peers") g_trace_peers = true;
    else if (a == "--peers-gray") peers_gray = true;
    else if (a == "--mid") mid_mode = true;
    else if (a == "--cold") cold = true;
    else if (a == "--stages") g_stages = true;
    else if (a == "--per-start") per_start = true;
    else if (a == "--sre") g_sre = true;
    else if (a == "--stride" && i + 1 < argc) {
      stride = std::atoi(argv[++i]);
      if (stride < 1 || stride > 10) {
        std::fprintf(stderr, "--stride: every Nth frame, N from 1 to 10\n");
        return 2;
      }
    }
    else if (a == "--threads" && i + 1 < argc) {
      if (!imt::bench::setThreads(argv[++i], &threads)) return 2;
    }
    else if (a == "--starts" && i + 1 < argc) {
      starts = std::atoi(argv[++i]);
      if (starts < 1 || starts > kMaxStarts) {
        std::fprintf(stderr, "--starts: a count of runs, 1 to %d (one per nudge of the box)\n", kMaxStarts);
        return 2;
      }
    }
    else if (a == "--help" || a == "-h") {
      std::printf("%s", kUsage);
      return 0;
    }
    else if (!a.empty() && a[0] == '-') {
      std::fprintf(stderr, "unknown option '%s'\n%s", a.c_str(), kUsage);
      return 2;
    }
    else only.insert(a);
  }
  if (g_sre) {
    if (starts != 1) {
      std::fprintf(stderr, "--sre and --starts: the runs start either from OTB's perturbed boxes or from nudged ones\n");
      return 2;
    }
    starts = kSreStarts;
  }
  const char* env = std::getenv("IMT_SHARED_DATA");
  const std::string dir = env && *env ? env : IMT_SHARED_DATA_DIR;
  std::vector<imt::test::BoxSequence> sequences = imt::test::BoxSequence::all(dir);
  if (sequences.empty()) {
    std::fprintf(stderr, "no real sequences with box ground truth under %s\n", dir.c_str());
    return 1;
  }
  for (const std::string& name : only) {
    if (std::none_of(sequences.begin(), sequences.end(),
                     [&](const imt::test::BoxSequence& s) { return s.name() == name; })) {
      std::fprintf(stderr, "no sequence '%s' under %s; there are:", name.c_str(), dir.c_str());
      for (const imt::test::BoxSequence& s : sequences) std::fprintf(stderr, " %s", s.name().c_str());
      std::fprintf(stderr, "\n");
      return 2;
    }
  }
  std::printf("Region tracking on real video (%s), %s, %s box given", dir.c_str(),
              threads == 1 ? "one thread" : (std::to_string(threads) + " threads").c_str(),
              mid_mode ? "the middle frame's (halves scored apart)" : "first frame's");
  if (g_sre) std::printf(" (means of %d runs from OTB's spatially perturbed copies of it)", starts);
  else if (starts > 1) std::printf(" (means of %d runs from it and nudged copies)", starts);
  if (stride > 1) std::printf("; every %d%s frame", stride, stride == 2 ? "nd" : stride == 3 ? "rd" : "th");
  if (peers_gray) std::printf("; the peers given the gray frames");
  std::printf("\n| sequence | tracker | frames | success AUC |%s mean IoU | P@20px | frames/s |\n",
              starts > 1 ? " AUC min..max |" : "");
  std::printf("|---|---|---|---|%s---|---|---|\n", starts > 1 ? "---|" : "");
  std::map<std::string, std::vector<Row>> rows;  // tracker -> one row per sequence
  std::string per_start_lines;                   // --per-start, printed after the table
  [[maybe_unused]] const char* peer_frames = peers_gray ? " (gray)" : "";
  for (const imt::test::BoxSequence& full : sequences) {
    if (!only.empty() && !only.count(full.name())) continue;
    const imt::test::BoxSequence seq = stride > 1 ? full.strided(stride) : full;
    int scored = 0;
    for (int f = 2; f <= seq.frames(); ++f) scored += seq.scored(f);
    if (scored == 0) {  // POT-210 scores every other frame: none of them at --stride 2
      std::fprintf(stderr, "%s: no scored frame after the first; left out\n", seq.name().c_str());
      continue;
    }
    std::vector<cv::Mat> gray, colour;
    for (int f = 1; f <= seq.frames(); ++f) {
      colour.push_back(seq.colour(f));
      if (colour.back().empty()) {
        std::fprintf(stderr, "%s: frame %d cannot be read\n", seq.name().c_str(), f);
        return 1;
      }
      gray.push_back(seq.gray(f));
      if (peers_gray) cv::cvtColor(gray.back(), colour.back(), cv::COLOR_GRAY2BGR);
    }
    // Each row: the tracker, its scores, and the frames it is scored over.
    struct Result {
      std::string name;
      Row row;
      int frames;
    };
    std::vector<Result> results;
    if (!cold) {  // the warm-up, untimed and unscored (see the top of this file)
      const bool trace = g_trace;
      g_trace = false;
      if (mid_mode) runOursMid(seq, gray, seq.middleFrame(), seq.box(seq.middleFrame()));
      else runOurs(seq, gray, seq.box(1));
      g_trace = trace;
      g_stage_times.erase(seq.name());
    }
    if (mid_mode) {
      const int mid = seq.middleFrame();
      const auto add = [&](const std::string& name, const Halves& h) {
        results.push_back({name + ", backward", h.backward, mid - 1});
        results.push_back({name + ", forward", h.forward, seq.frames() - mid});
      };
      add("instant_motion_tracking", midFromStarts(seq, starts, mid, [&](const cv::Rect2d& b) {
            return runOursMid(seq, gray, mid, b);
          }));
#ifdef IMT_HAVE_OPENCV_TRACKING
      if (!ours_only) {
        add(std::string("OpenCV KCF") + peer_frames, midFromStarts(seq, starts, mid, [&](const cv::Rect2d& b) {
              return runPeerMid(seq, colour, [] { return cv::TrackerKCF::create(); }, mid, b);
            }));
        add(std::string("OpenCV CSRT") + peer_frames, midFromStarts(seq, starts, mid, [&](const cv::Rect2d& b) {
              return runPeerMid(seq, colour, [] { return cv::TrackerCSRT::create(); }, mid, b);
            }));
      }
#endif
    } else {
      results.push_back({"instant_motion_tracking",
                         runFromStarts(seq, starts, [&](const cv::Rect2d& b) { return runOurs(seq, gray, b); }),
                         seq.frames()});
#ifdef IMT_HAVE_OPENCV_TRACKING
      if (!ours_only) {
        results.push_back({std::string("OpenCV KCF") + peer_frames, runFromStarts(seq, starts, [&](const cv::Rect2d& b) {
                             return runPeer(seq, colour, cv::TrackerKCF::create(), b);
                           }),
                           seq.frames()});
        results.push_back({std::string("OpenCV CSRT") + peer_frames, runFromStarts(seq, starts, [&](const cv::Rect2d& b) {
                             return runPeer(seq, colour, cv::TrackerCSRT::create(), b);
                           }),
                           seq.frames()});
      }
#endif
    }
    for (const auto& [name, r, frames] : results) {
      std::printf("| %s | %s | %d | %.3f |", seq.name().c_str(), name.c_str(), frames, r.auc);
      if (starts > 1) std::printf(" %.3f..%.3f |", r.auc_min, r.auc_max);
      std::printf(" %.3f | %.3f | %.1f |\n", r.iou, r.p20, r.fps);
      std::fflush(stdout);
      rows[name].push_back(r);
      if (per_start) {
        per_start_lines += "- " + seq.name() + ", " + name + ":";
        char a[16];
        for (const double auc : r.aucs) {
          std::snprintf(a, sizeof(a), " %.3f", auc);
          per_start_lines += a;
        }
        per_start_lines += "\n";
      }
    }
  }
  for (const auto& [name, v] : rows) {
    Row m;
    m.auc_min = m.auc_max = 0;
    for (const Row& r : v) {
      m.auc_min += r.auc_min / v.size();
      m.auc_max += r.auc_max / v.size();
      m.auc += r.auc / v.size();
      m.iou += r.iou / v.size();
      m.p20 += r.p20 / v.size();
      m.fps += r.fps / v.size();
    }
    std::printf("| **mean** | %s | | %.3f |", name.c_str(), m.auc);
    if (starts > 1) std::printf(" %.3f..%.3f |", m.auc_min, m.auc_max);
    std::printf(" %.3f | %.3f | %.1f |\n", m.iou, m.p20, m.fps);
  }
  if (per_start)
    std::printf("\nSuccess AUC of each run (%s):\n%s",
                g_sre ? "shifted left, right, up, down, up-left, up-right, down-left, down-right; scaled 0.8, 0.9, 1.1, 1.2"
                      : "the first from the box given",
                per_start_lines.c_str());
  if (g_stages && !g_stage_times.empty()) {
    std::printf("\nOur time per stage of the session, ms a frame (its frames/s above also counts the calls'"
                " own overhead):\n");
    for (const auto& [sequence, t] : g_stage_times) {
      std::printf("- %s:", sequence.c_str());
      for (const auto& [stage, seconds] : t.seconds)
        std::printf(" %s %.3f", stage.c_str(), t.frames > 0 ? 1e3 * seconds / t.frames : 0.0);
      std::printf("\n");
    }
  }
#ifndef IMT_HAVE_OPENCV_TRACKING
  std::printf("(OpenCV tracking module not found: KCF/CSRT rows skipped; install libopencv-contrib-dev)\n");
#endif
  return 0;
}
