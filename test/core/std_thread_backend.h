// OpenCV's parallel loops on plain std::threads, for the ThreadSanitizer run
// of the parallel region steps (scripts/tsan.sh, which also runs the shared
// session's hub tests without it). Debian's OpenCV runs its
// loops on TBB, whose own synchronisation TSan does not see: it took every
// access a TBB worker made to what the calling thread wrote before the loop
// for a race. Here each loop starts its workers and joins them (thread
// creation and join are what TSan sees), the caller working too, and hands
// out the stripes one at a time. Slow (threads started per loop), for tests
// only: test_core installs it before its first test when
// IMT_TEST_STD_THREADS is set (test_std_thread_backend.cpp).
#pragma once

#include <opencv2/core/parallel/parallel_backend.hpp>

#include <algorithm>
#include <atomic>
#include <thread>
#include <vector>

namespace imt {
namespace test {

class StdThreadBackend : public cv::parallel::ParallelForAPI {
 public:
  explicit StdThreadBackend(int threads) : threads_(std::max(1, threads)) {}

  // Loops run by any instance (that OpenCV's do run here).
  static inline std::atomic<long> loops{0};

  void parallel_for(int tasks, FN_parallel_for_body_cb_t body, void* data) override {
    ++loops;
    std::atomic<int> next{0};
    const auto run = [&](int index) {
      index_ = index;
      for (int t = next.fetch_add(1); t < tasks; t = next.fetch_add(1)) body(t, t + 1, data);
      index_ = 0;
    };
    std::vector<std::thread> workers;
    for (int i = 1; i < std::min(tasks, threads_.load()); ++i) workers.emplace_back(run, i);
    run(0);
    for (std::thread& w : workers) w.join();
  }
  int getThreadNum() const override { return index_; }
  int getNumThreads() const override { return threads_; }
  int setNumThreads(int n) override { return threads_.exchange(std::max(1, n)); }
  const char* getName() const override { return "imt test std::thread"; }

 private:
  static inline thread_local int index_ = 0;
  std::atomic<int> threads_;
};

}  // namespace test
}  // namespace imt
