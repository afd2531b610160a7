// The benchmarks' `--set name=value`: a region_tracking option, or any
// section's as `section.name=value` (e.g. motion_analysis.max_features=192),
// read as config YAML is (so names and types are checked as in a config file).
#pragma once

#include "instant_motion_tracking/io/config.h"

#include <cstdio>
#include <string>

namespace imt {
namespace bench {

// Applies `name=value` to config's region_tracking (`section.name=value` to
// that section); false (the reason on stderr) when the name or value is not one.
inline bool setRegionOption(const std::string& name_value, Config* config) {
  std::string kv = name_value, section = "region_tracking", err;
  const size_t eq = kv.find('=');
  const size_t dot = kv.find('.');
  if (dot != std::string::npos && dot < eq) {
    section = kv.substr(0, dot);
    kv.erase(0, dot + 1);
  }
  const size_t colon = kv.find('=');
  if (colon != std::string::npos) kv.replace(colon, 1, ": ");
  if (loadConfigYaml(section + ": {" + kv + "}", "--set " + name_value, config, &err)) return true;
  std::fprintf(stderr, "%s\n", err.c_str());
  return false;
}

}  // namespace bench
}  // namespace imt
