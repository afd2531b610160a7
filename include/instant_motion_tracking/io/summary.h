// summary.json of a track_bag run (no ROS): frames, wall seconds, frames per
// second and the time of each stage, plus free-form details (inputs,
// intrinsics, counts, warnings) the tool adds.
//
// Usage:
//   imt::RunSummary s;
//   s.frames = 300; s.seconds = 1.5;
//   s.stage_seconds["motion_analysis"] = 1.2;
//   s.details["image_topic"] = "/camera/image_raw";
//   if (!imt::writeJsonFile(dir + "/summary.json", s.toJson(), &err)) die(err);
#pragma once

#include <nlohmann/json.hpp>

#include <map>
#include <string>

namespace imt {

class TrackingSession;

struct RunSummary {
  int frames = 0;                               // frames processed
  double seconds = 0;                           // wall time of the processing (s)
  std::map<std::string, double> stage_seconds;  // stage name -> total wall time (s)
  nlohmann::json details = nlohmann::json::object();  // merged into the top level

  // {"frames", "seconds", "frames_per_second" (null when seconds is 0),
  //  "stages": {name: {"seconds", "ms_per_frame"}}, ...details}.
  nlohmann::json toJson() const;
};

// What the session knows that summary.json reports, added to `details`: the
// intrinsics and their source; the IMU-to-camera rotation, the camera-IMU
// time offset and the gyro bias in use, each with its source and what the
// video showed of it (null when nothing).
void addSessionDetails(const TrackingSession& session, nlohmann::json* details);

// Writes `j` pretty-printed. False with a message naming the file on failure.
bool writeJsonFile(const std::string& path, const nlohmann::json& j, std::string* error);

}  // namespace imt
