#include "instant_motion_tracking/io/summary.h"

#include <cerrno>
#include <cstring>
#include <fstream>

namespace imt {

nlohmann::json RunSummary::toJson() const {
  nlohmann::json j = nlohmann::json::object();
  j["frames"] = frames;
  j["seconds"] = seconds;
  j["frames_per_second"] = seconds > 0 ? nlohmann::json(frames / seconds) : nlohmann::json();
  nlohmann::json stages = nlohmann::json::object();
  for (const auto& [name, s] : stage_seconds) {
    stages[name] = {{"seconds", s},
                    {"ms_per_frame", frames > 0 ? nlohmann::json(1e3 * s / frames)
                                                : nlohmann::json()}};
  }
  j["stages"] = stages;
  for (const auto& [key, value] : details.items()) j[key] = value;
  return j;
}

bool writeJsonFile(const std::string& path, const nlohmann::json& j, std::string* error) {
  std::ofstream out(path, std::ios::out | std::ios::trunc);
  if (!out) {
    *error = path + ": cannot create the file: " + std::strerror(errno);
    return false;
  }
  // Replace invalid UTF-8 (e.g. from a topic name) rather than throw.
  out << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << '\n';
  out.flush();
  if (!out) {
    *error = path + ": write failed (disk full?)";
    return false;
  }
  return true;
}

}  // namespace imt
