#include "instant_motion_tracking/core/item_requests.h"

#include "instant_motion_tracking/core/anchor/anchor_manager.h"

#include <cmath>
#include <sstream>

namespace imt {

std::string messageNumber(double v) {
  std::ostringstream os;
  os.precision(12);
  os << v;
  return os.str();
}

std::string validateRegionRequest(uint32_t id, const cv::Rect2d& box) {
  if (id >= AnchorManager::kAnchorRegionBase)
    return "region id " + std::to_string(id) + " is reserved (ids must be below " +
           std::to_string(AnchorManager::kAnchorRegionBase) + ")";
  if (!(std::isfinite(box.x) && std::isfinite(box.y) && std::isfinite(box.width) && std::isfinite(box.height)))
    return "box has a NaN or infinite value";
  if (box.width <= 0 || box.height <= 0)
    return "box width and height must be positive (got " + messageNumber(box.width) + " x " +
           messageNumber(box.height) + ")";
  return "";
}

std::string validateAnchorRequest(const cv::Point2d& uv, double depth) {
  if (!std::isfinite(uv.x) || !std::isfinite(uv.y))
    return "pixel (" + messageNumber(uv.x) + ", " + messageNumber(uv.y) + ") has a NaN or infinite value";
  if (!std::isfinite(depth) || depth < 0 ||
      (depth > 0 && (depth < AnchorManager::kMinDepth || depth > AnchorManager::kMaxDepth)))
    return "depth must be positive and within " + messageNumber(AnchorManager::kMinDepth) + " .. " +
           messageNumber(AnchorManager::kMaxDepth) + " m (0 = anchors.default_depth), got " +
           messageNumber(depth);
  return "";
}

std::string alreadyTrackedError(const std::string& kind, uint32_t id) {
  return kind + " id " + std::to_string(id) + " is already tracked";
}

}  // namespace imt
