// The std::thread backend of the ThreadSanitizer run (std_thread_backend.h):
// installed before the first test when IMT_TEST_STD_THREADS is set (the run
// stops there unless OpenCV's loops then run on it), and checked to run every
// stripe once, on as many threads as it is given.
#include "std_thread_backend.h"

#include <gtest/gtest.h>
#include <opencv2/core/utility.hpp>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <mutex>
#include <set>
#include <string>

namespace {

// IMT_TEST_STD_THREADS=N: OpenCV's loops on N std::threads for the whole run.
class StdThreadsEnvironment : public ::testing::Environment {
 public:
  void SetUp() override {
    const char* n = std::getenv("IMT_TEST_STD_THREADS");
    if (!n) return;
    char* end = nullptr;
    const long threads = std::strtol(n, &end, 10);
    if (*n == '\0' || *end != '\0' || threads < 1 || threads > 64) {
      std::fprintf(stderr, "IMT_TEST_STD_THREADS='%s': a thread count from 1 to 64\n", n);
      std::exit(2);
    }
    // Its own count kept (not OpenCV's current one); cv::setNumThreads changes it after.
    cv::parallel::setParallelForBackend(std::make_shared<imt::test::StdThreadBackend>(static_cast<int>(threads)),
                                        /*propagateNumThreads=*/false);
    // OpenCV's loops now run on it, on as many threads as it has: else the
    // run would pass unseen on TBB.
    const long loops = imt::test::StdThreadBackend::loops;
    std::set<std::thread::id> ids;
    std::mutex m;
    cv::parallel_for_(cv::Range(0, 64), [&](const cv::Range&) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      std::lock_guard<std::mutex> lock(m);
      ids.insert(std::this_thread::get_id());
    }, 64);
    if (imt::test::StdThreadBackend::loops == loops || ids.size() < std::min<size_t>(2, threads)) {
      std::fprintf(stderr, "IMT_TEST_STD_THREADS: OpenCV's loops did not run on the std::thread backend\n");
      std::exit(2);
    }
    std::fprintf(stderr, "OpenCV's parallel loops on %ld std::threads (IMT_TEST_STD_THREADS)\n", threads);
  }
};
::testing::Environment* const kEnvironment = ::testing::AddGlobalTestEnvironment(new StdThreadsEnvironment);

}  // namespace

TEST(StdThreadBackend, RunsEveryStripeOnceOnItsThreads) {
  imt::test::StdThreadBackend backend(3);
  constexpr int kTasks = 200;
  std::vector<int> runs(kTasks, 0);
  std::set<std::thread::id> threads;
  std::mutex m;
  struct Data {
    std::vector<int>* runs;
    std::set<std::thread::id>* threads;
    std::mutex* m;
  } data{&runs, &threads, &m};
  backend.parallel_for(kTasks, [](int start, int end, void* p) {
    auto* d = static_cast<Data*>(p);
    std::lock_guard<std::mutex> lock(*d->m);
    for (int t = start; t < end; ++t) ++(*d->runs)[t];
    d->threads->insert(std::this_thread::get_id());
  }, &data);
  for (int t = 0; t < kTasks; ++t) EXPECT_EQ(runs[t], 1) << "stripe " << t;
  // At most the three it was given (fewer when one took every stripe first).
  EXPECT_GE(threads.size(), 1u);
  EXPECT_LE(threads.size(), 3u);
  EXPECT_EQ(backend.getNumThreads(), 3);
  EXPECT_EQ(backend.setNumThreads(2), 3);
  EXPECT_EQ(backend.getNumThreads(), 2);
}
