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

}  // namespace bench
}  // namespace imt
