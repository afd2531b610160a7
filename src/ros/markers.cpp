#include "instant_motion_tracking/ros/markers.h"

#include <string>

namespace imt {
namespace {

geometry_msgs::Point toPointMsg(const Eigen::Vector3d& p) {
  geometry_msgs::Point q;
  q.x = p.x();
  q.y = p.y();
  q.z = p.z();
  return q;
}

// The image pixel (u, v)'s ray (through the lens: undistorted) on the plane z = 1 m.
geometry_msgs::Point backProject(double u, double v, const CameraModel& k) {
  const cv::Point2d ideal = k.undistort(cv::Point2d(u, v));
  return toPointMsg(Eigen::Vector3d((ideal.x - k.cx) / k.fx, (ideal.y - k.cy) / k.fy, 1.0));
}

std_msgs::ColorRGBA colour(RegionStatus s) {
  std_msgs::ColorRGBA c;
  c.a = 1.0;
  switch (s) {
    case RegionStatus::kTracked: c.g = 1.0; break;
    case RegionStatus::kFeatureless: c.b = 1.0; c.g = 0.6; break;
    case RegionStatus::kOutOfView: c.r = 1.0; c.g = 0.6; break;
    case RegionStatus::kLost: c.r = 1.0; break;
  }
  return c;
}

// A line marker in `header`'s frame, `width` m wide, that rviz drops half
// a second after its last update (no DELETEALL: other nodelets publish
// markers too).
visualization_msgs::Marker lineMarker(const std_msgs::Header& header, const std::string& ns, uint32_t id,
                                      int type, double width) {
  visualization_msgs::Marker m;
  m.header = header;
  m.ns = ns;
  m.id = static_cast<int>(id);
  m.type = type;
  m.action = visualization_msgs::Marker::ADD;
  m.pose.orientation.w = 1.0;
  m.scale.x = width;
  m.lifetime = ros::Duration(0.5);
  return m;
}

}  // namespace

visualization_msgs::MarkerArray regionMarkers(const std::vector<RegionState>& states,
                                              const std_msgs::Header& header,
                                              const CameraModel& k) {
  visualization_msgs::MarkerArray out;
  for (const RegionState& s : states) {
    if (s.status == RegionStatus::kLost || !k.valid) continue;
    visualization_msgs::Marker box =
        lineMarker(header, "regions", s.id, visualization_msgs::Marker::LINE_STRIP, 0.004);
    box.color = colour(s.status);
    const cv::Rect2d b = s.extent();
    for (const auto& [u, v] : {std::pair<double, double>{b.x, b.y}, {b.br().x, b.y}, {b.br().x, b.br().y},
                               {b.x, b.br().y}, {b.x, b.y}})
      box.points.push_back(backProject(u, v, k));
    out.markers.push_back(box);
    visualization_msgs::Marker text = box;
    text.ns = "region_labels";
    text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    text.points.clear();
    text.pose.position = backProject(b.x, b.y - 4, k);
    text.scale.z = 0.03;
    text.text = std::to_string(s.id) + " " + regionStatusName(s.status);
    out.markers.push_back(text);
  }
  return out;
}

visualization_msgs::MarkerArray planarTargetMarkers(const std::vector<PlanarTargetState>& states,
                                                    const std_msgs::Header& header) {
  visualization_msgs::MarkerArray out;
  for (const PlanarTargetState& s : states) {
    if (!s.hasPose()) continue;
    visualization_msgs::Marker quad =
        lineMarker(header, "planar_targets", s.id, visualization_msgs::Marker::LINE_STRIP, 0.005);
    quad.color.a = 1.0;
    quad.color.g = s.status == TargetStatus::kTracked ? 1.0 : 0.6;
    quad.color.r = s.status == TargetStatus::kTracked ? 0.0 : 1.0;
    const double w = s.width_m / 2, h = s.height_m / 2;
    for (const auto& [x, y] : {std::pair<double, double>{-w, -h}, {w, -h}, {w, h}, {-w, h}, {-w, -h}})
      quad.points.push_back(toPointMsg(s.T_cam_target * Eigen::Vector3d(x, y, 0)));
    out.markers.push_back(quad);
  }
  return out;
}

visualization_msgs::MarkerArray anchorMarkers(const std::vector<AnchorState>& states,
                                              const std_msgs::Header& header, double axis_m) {
  visualization_msgs::MarkerArray out;
  for (const AnchorState& s : states) {
    if (!s.hasEstimate()) continue;
    // Line width: a tenth of the axis length.
    visualization_msgs::Marker axes =
        lineMarker(header, "anchors", s.id, visualization_msgs::Marker::LINE_LIST, 0.1 * axis_m);
    const Eigen::Vector3d o = s.T_cam_anchor.translation();
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d tip = o + axis_m * s.T_cam_anchor.linear().col(k);
      std_msgs::ColorRGBA c;
      c.a = 1.0;
      (k == 0 ? c.r : k == 1 ? c.g : c.b) = 1.0;
      for (const Eigen::Vector3d& p : {o, tip}) {
        axes.points.push_back(toPointMsg(p));
        axes.colors.push_back(c);
      }
    }
    axes.color.a = 1.0;
    out.markers.push_back(axes);
    visualization_msgs::Marker text = axes;
    text.ns = "anchor_labels";
    text.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    text.points.clear();
    text.colors.clear();
    // Above the origin (optical y points down).
    text.pose.position = toPointMsg(o - Eigen::Vector3d(0, 0.3 * axis_m, 0));
    text.scale.z = 0.3 * axis_m;
    text.color.r = text.color.g = text.color.b = 1.0;
    text.text = std::to_string(s.id) + " " + anchorStatusName(s.status);
    out.markers.push_back(text);
  }
  return out;
}

}  // namespace imt
