// Where the real test data lives (../shared/data next to the repository, or
// $IMT_SHARED_DATA): tests that read it skip cleanly when it is absent.
#pragma once

#include <sys/stat.h>

#include <cstdlib>
#include <string>

namespace imt {
namespace test {

inline std::string sharedDataDir() {
  if (const char* env = std::getenv("IMT_SHARED_DATA"); env && *env) return env;
  return IMT_SHARED_DATA_DIR;
}

inline bool pathExists(const std::string& p) {
  struct stat st;
  return ::stat(p.c_str(), &st) == 0;
}

}  // namespace test
}  // namespace imt
