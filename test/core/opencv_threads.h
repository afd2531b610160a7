// OpenCV's thread count for a scope, for the tests that compare results on
// several threads against one (restored however the scope is left, a failed
// ASSERT included).
#pragma once

#include <opencv2/core.hpp>

namespace imt {
namespace test {

class OpenCvThreads {
 public:
  explicit OpenCvThreads(int n) : saved_(cv::getNumThreads()) { cv::setNumThreads(n); }
  ~OpenCvThreads() { cv::setNumThreads(saved_); }
  OpenCvThreads(const OpenCvThreads&) = delete;
  OpenCvThreads& operator=(const OpenCvThreads&) = delete;

 private:
  int saved_;
};

}  // namespace test
}  // namespace imt
