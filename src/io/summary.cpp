#include "instant_motion_tracking/io/summary.h"

#include "instant_motion_tracking/core/tracking_session.h"

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

void addSessionDetails(const TrackingSession& session, nlohmann::json* details) {
  nlohmann::json& j = *details;
  const CameraModel k = session.camera();
  j["intrinsics"] = {{"source", session.cameraSource()}, {"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx},
                     {"cy", k.cy}, {"width", k.width}, {"height", k.height}};
  j["R_cam_imu"] = nullptr;
  j["R_cam_imu_source"] = AnchorManager::rotationSourceName(session.rotationSource());
  if (const auto q = session.rotationCamImu()) {
    const Eigen::Matrix3d R = q->toRotationMatrix();
    j["R_cam_imu"] = {{R(0, 0), R(0, 1), R(0, 2)}, {R(1, 0), R(1, 1), R(1, 2)},
                      {R(2, 0), R(2, 1), R(2, 2)}};
  }
  // The video's fit from the features' epipolar lines, when one was made
  // (no rotation known yet, or the turns' to check: a camera that travels as it turns).
  j["R_cam_imu_epipolar"] = nullptr;
  if (const auto& f = session.epipolarRotationFit())
    j["R_cam_imu_epipolar"] = {{"sharp", f->sharp}, {"halves_deg", f->spread_deg}, {"inliers", f->inlier_fraction},
                               {"frames", f->frames}, {"pairs", f->pairs}};
  // The camera-IMU time offset in use, and what the video showed of it.
  j["imu_time_offset"] = session.timeOffset();
  j["imu_time_offset_source"] = AnchorManager::offsetSourceName(session.timeOffsetSource());
  j["imu_time_offset_video"] = nullptr;
  if (const auto& f = session.timeOffsetFit())
    j["imu_time_offset_video"] = {{"offset", f->offset}, {"found", f->found}, {"correlation", f->correlation},
                                  {"correlation_at_zero", f->at_zero}, {"turns", f->turns}};
  // The gyro bias in use (rad/s, IMU frame), its source, and the video's estimate.
  const Eigen::Vector3d& bias = session.gyroBias();
  j["gyro_bias"] = {bias.x(), bias.y(), bias.z()};
  j["gyro_bias_source"] = ImuOrientation::biasSourceName(session.gyroBiasSource());
  j["gyro_bias_video"] = nullptr;
  if (const auto& e = session.videoGyroBias())
    j["gyro_bias_video"] = {{"bias", {e->bias.x(), e->bias.y(), e->bias.z()}},
                            {"sigma", {e->sigma.x(), e->sigma.y(), e->sigma.z()}},
                            {"frames", e->frames}, {"lateness", e->lateness},
                            {"lateness_sigma", e->lateness_sigma}};
}

}  // namespace imt
