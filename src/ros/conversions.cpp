#include "instant_motion_tracking/ros/conversions.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <string>

namespace imt {
namespace {
// A number for a message: 6 significant digits.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%g", v);
  return buf;
}

bool finite3(const geometry_msgs::Vector3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// The enum value whose name (`name_of`) is `name`; `fallback` when none is.
template <class E, class F>
E statusFromName(const std::string& name, F name_of, std::initializer_list<E> values, E fallback) {
  for (E e : values)
    if (name == name_of(e)) return e;
  return fallback;
}
// The messages of a tracker's states, in order (each through its toMsg).
template <typename State>
auto itemsToMsg(const std::vector<State>& states) {
  std::vector<decltype(toMsg(states.front()))> out;
  out.reserve(states.size());
  for (const State& s : states) out.push_back(toMsg(s));
  return out;
}

// A tracker's states from the items of an array message, all at its stamp.
template <typename State, typename Item>
std::vector<State> statesFromMsg(const std::vector<Item>& items, double stamp) {
  std::vector<State> out;
  out.reserve(items.size());
  for (const Item& m : items) out.push_back(fromMsg(m, stamp));
  return out;
}

}  // namespace

instant_motion_tracking::MotionData toMsg(const MotionData& md, const std_msgs::Header& header) {
  instant_motion_tracking::MotionData m;
  m.header = header;
  m.width = md.width;
  m.height = md.height;
  m.analysis_scale = md.analysis_scale;
  m.model = static_cast<uint8_t>(md.camera.model);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.homography[3 * r + c] = md.camera.H(r, c);
  m.num_features = md.camera.features;
  m.num_inliers = md.camera.inliers;
  const size_t n = md.features.size();
  m.ids.resize(n);
  m.x.resize(n);
  m.y.resize(n);
  m.dx.resize(n);
  m.dy.resize(n);
  m.background_weight.resize(n);
  m.foreground.resize(n);
  m.age.resize(n);
  m.patch_error.resize(n);
  for (size_t i = 0; i < n; ++i) {
    const FeatureMotion& f = md.features[i];
    m.ids[i] = f.id;
    m.x[i] = f.x;
    m.y[i] = f.y;
    m.dx[i] = f.dx;
    m.dy[i] = f.dy;
    m.background_weight[i] = f.bg_weight;
    m.foreground[i] = f.foreground ? 1 : 0;
    m.age[i] = f.age;
    m.patch_error[i] = f.patch_error;
  }
  return m;
}

MotionData fromMsg(const instant_motion_tracking::MotionData& m) {
  MotionData md;
  md.stamp = m.header.stamp.toSec();
  md.width = static_cast<int>(m.width);
  md.height = static_cast<int>(m.height);
  md.analysis_scale = std::isfinite(m.analysis_scale) && m.analysis_scale > 0 ? m.analysis_scale : 1.f;
  md.camera.model = m.model <= 3 ? static_cast<MotionModel>(m.model) : MotionModel::kInvalid;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) md.camera.H(r, c) = m.homography[3 * r + c];
  if (!md.camera.H.allFinite()) {
    md.camera.model = MotionModel::kInvalid;
    md.camera.H.setIdentity();
  }
  md.camera.features = static_cast<int>(m.num_features);
  md.camera.inliers = static_cast<int>(m.num_inliers);
  // Malformed messages (arrays of different lengths) keep the common prefix.
  const size_t n = std::min({m.ids.size(), m.x.size(), m.y.size(), m.dx.size(), m.dy.size(),
                             m.background_weight.size(), m.foreground.size(), m.age.size()});
  md.features.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    FeatureMotion f;
    f.id = m.ids[i];
    f.x = m.x[i];
    f.y = m.y[i];
    f.dx = m.dx[i];
    f.dy = m.dy[i];
    if (!std::isfinite(f.x) || !std::isfinite(f.y) || !std::isfinite(f.dx) || !std::isfinite(f.dy))
      continue;
    f.bg_weight = knownBackgroundWeight(m.background_weight[i]);
    f.foreground = m.foreground[i] != 0;
    f.age = m.age[i];
    // Optional (empty from publishers before it); unknown is 0.
    if (i < m.patch_error.size()) f.patch_error = knownPatchError(m.patch_error[i]);
    md.features.push_back(f);
  }
  return md;
}

bool fromCameraInfo(const sensor_msgs::CameraInfo& info, CameraModel* k, std::string* why,
                    bool image_rectified) {
  // A rectified image is seen through P (its own pinhole, no distortion);
  // a raw one through K and D.
  const double fx = image_rectified ? info.P[0] : info.K[0];
  const double fy = image_rectified ? info.P[5] : info.K[4];
  const double cx = image_rectified ? info.P[2] : info.K[2];
  const double cy = image_rectified ? info.P[6] : info.K[5];
  const char* which = image_rectified ? "P" : "K";
  const bool all_finite = image_rectified
                              ? std::all_of(info.P.begin(), info.P.end(), [](double v) { return std::isfinite(v); })
                              : std::all_of(info.K.begin(), info.K.end(), [](double v) { return std::isfinite(v); });
  if (!all_finite) {
    *why = std::string("camera_info ") + which + " has a NaN or infinite entry";
    return false;
  }
  if (fx <= 0 || fy <= 0) {
    *why = std::string("camera_info ") + which + " has no usable focal length" +
           (image_rectified ? " (image_rectified: true uses P)" : "");
    return false;
  }
  // K's last row is 0 0 1 and its second row starts with 0 (1e-6: the
  // rounding of a K written as text).
  if (!image_rectified && (std::abs(info.K[3]) > 1e-6 || std::abs(info.K[6]) > 1e-6 ||
                           std::abs(info.K[7]) > 1e-6 || std::abs(info.K[8] - 1) > 1e-6)) {
    *why = "camera_info K is not a camera matrix (expected [fx s cx; 0 fy cy; 0 0 1])";
    return false;
  }
  if (info.width == 0 || info.height == 0) {
    *why = "camera_info has no image size";
    return false;
  }
  const double w = info.width, h = info.height;
  if (w > 65536 || h > 65536) {  // as images (image_conversion.h)
    *why = "camera_info size " + std::to_string(info.width) + "x" + std::to_string(info.height) +
           " is over 65536 px";
    return false;
  }
  // Plausible for a lens: a field of view from ~0.1 deg (focal length 1000
  // image sizes) to ~180 deg (1/1000 of one), the principal point within an
  // image size of the image. Beyond these the model would be silently wrong.
  const double size = std::max(w, h);
  if (fx < 1e-3 * size || fy < 1e-3 * size || fx > 1e3 * size || fy > 1e3 * size) {
    *why = std::string("camera_info ") + which + " focal length (fx " + num(fx) + ", fy " +
           num(fy) + ") is implausible for a " + std::to_string(info.width) + "x" +
           std::to_string(info.height) + " image (from 0.001 to 1000 times its size)";
    return false;
  }
  if (cx < -w || cx > 2 * w || cy < -h || cy > 2 * h) {
    *why = std::string("camera_info ") + which + " principal point (" + num(cx) + ", " +
           num(cy) + ") is far outside the " + std::to_string(info.width) + "x" +
           std::to_string(info.height) + " image";
    return false;
  }
  CameraModel m;
  m.fx = fx;
  m.fy = fy;
  m.cx = cx + 0.5;  // OpenCV/ROS pixel centres at integers -> ours at +0.5
  m.cy = cy + 0.5;
  m.width = static_cast<int>(info.width);
  m.height = static_cast<int>(info.height);
  m.valid = true;
  const bool all_zero =
      std::all_of(info.D.begin(), info.D.end(), [](double c) { return c == 0.0; });
  if (!image_rectified && !all_zero) {  // all-zero (or empty) D: no distortion, whatever the name
    CameraModel::Distortion d;
    if (!CameraModel::parseDistortion(info.distortion_model, &d) ||
        d == CameraModel::Distortion::kNone) {
      *why = "camera_info distortion_model '" + info.distortion_model +
             "' is not supported (plumb_bob, rational_polynomial, equidistant) and D is not zero";
      return false;
    }
    std::string e;
    if (!m.setDistortion(d, info.D, &e)) {
      *why = "camera_info D: " + e;
      return false;
    }
  }
  *k = m;
  return true;
}

bool cameraInfoForFrames(const sensor_msgs::CameraInfo& info, bool image_rectified, const cv::Size& frames,
                         CameraModel* k, std::string* why) {
  CameraModel m;
  if (!fromCameraInfo(info, &m, why, image_rectified)) return false;
  if (frames.width > 0 && (m.width != frames.width || m.height != frames.height)) {
    *why = "camera_info size " + std::to_string(m.width) + "x" + std::to_string(m.height) + " differs from the images' " +
           std::to_string(frames.width) + "x" + std::to_string(frames.height);
    return false;
  }
  *k = m;
  return true;
}

sensor_msgs::CameraInfo toCameraInfo(const CameraModel& k, const std_msgs::Header& header) {
  sensor_msgs::CameraInfo info;
  info.header = header;
  info.width = k.width;
  info.height = k.height;
  if (k.distortion == CameraModel::Distortion::kNone) {
    info.distortion_model = "plumb_bob";
    info.D.assign(5, 0.0);
  } else {
    info.distortion_model = CameraModel::distortionName(k.distortion);
    info.D = k.D;
  }
  info.K = {k.fx, 0, k.cx - 0.5, 0, k.fy, k.cy - 0.5, 0, 0, 1};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  // P: the rectified image's pinhole, here the same K.
  info.P = {k.fx, 0, k.cx - 0.5, 0, 0, k.fy, k.cy - 0.5, 0, 0, 0, 1, 0};
  return info;
}

bool fromImuMsg(const sensor_msgs::Imu& msg, ImuSample* s, std::string* why) {
  if (!finite3(msg.angular_velocity) || !finite3(msg.linear_acceleration)) {
    *why = "IMU sample with NaN/Inf angular velocity or acceleration";
    return false;
  }
  s->stamp = msg.header.stamp.toSec();
  s->gyro = {msg.angular_velocity.x, msg.angular_velocity.y, msg.angular_velocity.z};
  s->accel = {msg.linear_acceleration.x, msg.linear_acceleration.y, msg.linear_acceleration.z};
  s->has_orientation = msg.orientation_covariance[0] != -1.0;
  if (s->has_orientation) {
    const auto& q = msg.orientation;
    Eigen::Quaterniond e(q.w, q.x, q.y, q.z);
    const double n = e.norm();
    if (!std::isfinite(n) || n < 0.5 || n > 1.5) {
      s->has_orientation = false;  // zero/garbage quaternion: ignore it, keep the gyro
    } else {
      s->orientation = e.normalized();
    }
  }
  return true;
}

sensor_msgs::Imu toImuMsg(const ImuSample& s, const std_msgs::Header& header) {
  sensor_msgs::Imu m;
  m.header = header;
  m.angular_velocity.x = s.gyro.x();
  m.angular_velocity.y = s.gyro.y();
  m.angular_velocity.z = s.gyro.z();
  m.linear_acceleration.x = s.accel.x();
  m.linear_acceleration.y = s.accel.y();
  m.linear_acceleration.z = s.accel.z();
  if (s.has_orientation) {
    m.orientation.x = s.orientation.x();
    m.orientation.y = s.orientation.y();
    m.orientation.z = s.orientation.z();
    m.orientation.w = s.orientation.w();
    m.orientation_covariance[0] = m.orientation_covariance[4] = m.orientation_covariance[8] = 1e-4;
  } else {
    m.orientation_covariance[0] = -1.0;
  }
  return m;
}

geometry_msgs::Pose toPoseMsg(const Eigen::Isometry3d& T) {
  geometry_msgs::Pose p;
  const Eigen::Quaterniond q(T.rotation());
  p.position.x = T.translation().x();
  p.position.y = T.translation().y();
  p.position.z = T.translation().z();
  p.orientation.x = q.x();
  p.orientation.y = q.y();
  p.orientation.z = q.z();
  p.orientation.w = q.w();
  return p;
}

namespace {

// The tf transform from `header`'s frame to `child` (planar targets, anchors).
geometry_msgs::TransformStamped toTransformMsg(const Eigen::Isometry3d& T, const std_msgs::Header& header,
                                              const std::string& child) {
  geometry_msgs::TransformStamped t;
  t.header = header;
  t.child_frame_id = child;
  const geometry_msgs::Pose p = toPoseMsg(T);
  t.transform.translation.x = p.position.x;
  t.transform.translation.y = p.position.y;
  t.transform.translation.z = p.position.z;
  t.transform.rotation = p.orientation;
  return t;
}

}  // namespace

instant_motion_tracking::TrackedRegion toMsg(const RegionState& s) {
  instant_motion_tracking::TrackedRegion r;
  r.id = s.id;
  const bool lost = s.status == RegionStatus::kLost;
  const cv::Rect2d b = s.extent();  // the box around the region as seen (turned)
  r.x = lost ? NAN : b.x;
  r.y = lost ? NAN : b.y;
  r.width = lost ? NAN : b.width;
  r.height = lost ? NAN : b.height;
  r.status = regionStatusName(s.status);
  r.confidence = s.confidence;
  r.vx = s.velocity.x();
  r.vy = s.velocity.y();
  r.inlier_ids = s.inliers;
  r.outlier_ids = s.outliers;
  r.angle = lost ? NAN : s.angle;
  r.rect_width = lost ? NAN : s.box.width;
  r.rect_height = lost ? NAN : s.box.height;
  return r;
}

instant_motion_tracking::TrackedRegionArray toMsg(const std::vector<RegionState>& states,
                                                  const std_msgs::Header& header) {
  instant_motion_tracking::TrackedRegionArray a;
  a.header = header;
  a.regions = itemsToMsg(states);
  return a;
}

instant_motion_tracking::PlanarTarget toMsg(const PlanarTargetState& s) {
  instant_motion_tracking::PlanarTarget m;
  m.id = s.id;
  for (int i = 0; i < 4; ++i) {
    m.corners[i].x = s.corners[i].x;
    m.corners[i].y = s.corners[i].y;
  }
  m.pose = toPoseMsg(s.T_cam_target);
  m.width_m = s.width_m;
  m.height_m = s.height_m;
  m.status = targetStatusName(s.status);
  m.confidence = s.confidence;
  return m;
}

instant_motion_tracking::PlanarTargetArray toMsg(const std::vector<PlanarTargetState>& states,
                                                 const std_msgs::Header& header) {
  instant_motion_tracking::PlanarTargetArray a;
  a.header = header;
  a.targets = itemsToMsg(states);
  return a;
}

std::vector<geometry_msgs::TransformStamped> planarTargetTransforms(
    const std::vector<PlanarTargetState>& states, const std_msgs::Header& header,
    const std::string& frame_prefix) {
  std::vector<geometry_msgs::TransformStamped> out;
  for (const PlanarTargetState& s : states) {
    if (!s.hasPose()) continue;
    out.push_back(toTransformMsg(s.T_cam_target, header, frame_prefix + "planar_target_" + std::to_string(s.id)));
  }
  return out;
}

instant_motion_tracking::Anchor toMsg(const AnchorState& s) {
  instant_motion_tracking::Anchor m;
  m.id = s.id;
  const bool est = s.hasEstimate();
  m.u = est ? s.pixel.x : NAN;
  m.v = est ? s.pixel.y : NAN;
  m.pose = toPoseMsg(s.T_cam_anchor);
  if (!est) {
    m.pose.position.x = m.pose.position.y = m.pose.position.z = NAN;
    m.pose.orientation.x = m.pose.orientation.y = m.pose.orientation.z = m.pose.orientation.w = NAN;
  }
  m.status = anchorStatusName(s.status);
  m.confidence = s.confidence;
  return m;
}

instant_motion_tracking::AnchorArray toMsg(const std::vector<AnchorState>& states, const std_msgs::Header& header) {
  instant_motion_tracking::AnchorArray a;
  a.header = header;
  a.anchors = itemsToMsg(states);
  return a;
}

std::vector<geometry_msgs::TransformStamped> anchorTransforms(const std::vector<AnchorState>& states,
                                                              const std_msgs::Header& header,
                                                              const std::string& frame_prefix) {
  std::vector<geometry_msgs::TransformStamped> out;
  for (const AnchorState& s : states) {
    if (!s.hasEstimate()) continue;
    out.push_back(toTransformMsg(s.T_cam_anchor, header, frame_prefix + "anchor_" + std::to_string(s.id)));
  }
  return out;
}

Eigen::Isometry3d fromPoseMsg(const geometry_msgs::Pose& p) {
  const Eigen::Quaterniond q(p.orientation.w, p.orientation.x, p.orientation.y, p.orientation.z);
  const Eigen::Vector3d t(p.position.x, p.position.y, p.position.z);
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  const double n = q.norm();
  if (!std::isfinite(n) || n < 1e-6 || !t.allFinite()) {
    T.matrix().setConstant(NAN);
    return T;
  }
  T.linear() = q.normalized().toRotationMatrix();
  T.translation() = t;
  return T;
}

RegionState fromMsg(const instant_motion_tracking::TrackedRegion& m, double stamp) {
  RegionState s;
  s.id = m.id;
  s.stamp = stamp;
  s.box = cv::Rect2d(m.x, m.y, m.width, m.height);
  if (std::isfinite(m.angle) && m.rect_width > 0 && m.rect_height > 0) {
    // The region's own rectangle about the extent's centre, and its turn.
    const double cx = m.x + m.width / 2.0, cy = m.y + m.height / 2.0;
    s.box = cv::Rect2d(cx - m.rect_width / 2.0, cy - m.rect_height / 2.0, m.rect_width, m.rect_height);
    s.angle = m.angle;
  }
  s.status = statusFromName(m.status, regionStatusName,
                            {RegionStatus::kTracked, RegionStatus::kFeatureless, RegionStatus::kOutOfView,
                             RegionStatus::kLost},
                            RegionStatus::kLost);
  s.confidence = m.confidence;
  s.velocity = Eigen::Vector2d(m.vx, m.vy);
  s.inliers = m.inlier_ids;
  s.outliers = m.outlier_ids;
  return s;
}

std::vector<RegionState> fromMsg(const instant_motion_tracking::TrackedRegionArray& m) {
  return statesFromMsg<RegionState>(m.regions, m.header.stamp.toSec());
}

PlanarTargetState fromMsg(const instant_motion_tracking::PlanarTarget& m, double stamp) {
  PlanarTargetState s;
  s.id = m.id;
  s.stamp = stamp;
  for (int i = 0; i < 4; ++i) s.corners[i] = cv::Point2d(m.corners[i].x, m.corners[i].y);
  s.T_cam_target = fromPoseMsg(m.pose);
  s.width_m = m.width_m;
  s.height_m = m.height_m;
  s.status = statusFromName(m.status, targetStatusName,
                            {TargetStatus::kTracked, TargetStatus::kOutOfView, TargetStatus::kLost, TargetStatus::kNotFound,
                             TargetStatus::kPredicted},
                            TargetStatus::kLost);
  s.confidence = m.confidence;
  return s;
}

std::vector<PlanarTargetState> fromMsg(const instant_motion_tracking::PlanarTargetArray& m) {
  return statesFromMsg<PlanarTargetState>(m.targets, m.header.stamp.toSec());
}

AnchorState fromMsg(const instant_motion_tracking::Anchor& m, double stamp) {
  AnchorState s;
  s.id = m.id;
  s.stamp = stamp;
  s.pixel = cv::Point2d(m.u, m.v);
  s.T_cam_anchor = fromPoseMsg(m.pose);
  s.status = statusFromName(m.status, anchorStatusName,
                            {AnchorStatus::kTracked, AnchorStatus::kOutOfView, AnchorStatus::kNoImu,
                             AnchorStatus::kLost, AnchorStatus::kCalibrating},
                            AnchorStatus::kLost);
  s.confidence = m.confidence;
  return s;
}

std::vector<AnchorState> fromMsg(const instant_motion_tracking::AnchorArray& m) {
  return statesFromMsg<AnchorState>(m.anchors, m.header.stamp.toSec());
}

}  // namespace imt
