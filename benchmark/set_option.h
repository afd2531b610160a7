// The benchmarks' `--set name=value`: a region_tracking option, read as
// config YAML is (so names and types are checked as in a config file).
#pragma once

#include "instant_motion_tracking/io/config.h"

#include <cstdio>
#include <string>

namespace imt {
namespace bench {

// Applies `name=value` to config's region_tracking; false (the reason on
// stderr) when the name or value is not one.
inline bool setRegionOption(const std::string& name_value, Config* config) {
  std::string kv = name_value, err;
  const size_t eq = kv.find('=');
  if (eq != std::string::npos) kv.replace(eq, 1, ": ");
  if (loadConfigYaml("region_tracking: {" + kv + "}", "--set " + name_value, config, &err)) return true;
  std::fprintf(stderr, "%s\n", err.c_str());
  return false;
}

}  // namespace bench
}  // namespace imt
