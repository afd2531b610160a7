// The benchmarks' shared options: `--set name=value`, a region_tracking
// option, or any section's as `section.name=value` (e.g.
// motion_analysis.max_features=192), read as config YAML is (so names and
// types are checked as in a config file); and `--threads N`.
#pragma once

#include "instant_motion_tracking/io/config.h"

#include <opencv2/core.hpp>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <string>

namespace imt {
namespace bench {

// Applies `name=value` to config's region_tracking (`section.name=value` to
// that section); false (the reason on stderr) when the name or value is not one.
inline bool setOption(const std::string& name_value, Config* config) {
  const size_t eq = name_value.find('=');
  std::string name = name_value.substr(0, eq), section = "region_tracking", err;
  const size_t dot = name.find('.');
  if (dot != std::string::npos) {
    section = name.substr(0, dot);
    name.erase(0, dot + 1);
  }
  const std::string value = eq == std::string::npos ? "" : ": " + name_value.substr(eq + 1);
  if (loadConfigYaml(section + ": {" + name + value + "}", "--set " + name_value, config, &err)) return true;
  std::fprintf(stderr, "%s\n", err.c_str());
  return false;
}

// `--threads N`: OpenCV's parallel loops on N threads (1 to 64), for every
// tracker; false (the reason on stderr) for anything else, "2x" included.
inline bool setThreads(const char* arg, int* threads) {
  char* end = nullptr;
  errno = 0;
  const long n = std::strtol(arg, &end, 10);
  if (end == arg || *end != '\0' || errno != 0 || n < 1 || n > 64) {
    std::fprintf(stderr, "--threads: OpenCV's threads, 1 to 64 (got %s)\n", arg);
    return false;
  }
  *threads = static_cast<int>(n);
  cv::setNumThreads(*threads);
  return true;
}

}  // namespace bench
}  // namespace imt
