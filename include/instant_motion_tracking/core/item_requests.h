// What every door checks of an item request before a frame is needed: one
// function per item kind, shared by the services, INIT.yaml and the core
// (issue 16: "the same request gets the same answer at every door").
//
// TrackingSession's add methods run them first, so the services (through the
// nodelets) and track_bag (INIT.yaml's items, added at their frames) get the
// same reason in the same words; INIT.yaml's parser (io/init_spec.h) runs them
// on each entry too, so that a bad entry is named before the bag is read.
// The checks that need the frame (the box, quad or pixel against the image,
// the number of items) are the managers' add(), reached through the session
// at every door. test/item_doors_table.h holds one table of requests with the
// answer each door must give, run through all three.
//
// Each returns "" when the request passes, else the reason.
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <string>

namespace imt {

// A region: id 0 (choose one) or below the anchors' internal region ids
// (AnchorManager::kAnchorRegionBase); a box of finite numbers with a
// positive width and height. (Its size against the image and max_regions:
// RegionManager::add.)
std::string validateRegionRequest(uint32_t id, const cv::Rect2d& box);

// An anchor: a finite pixel; depth 0 (anchors.default_depth) or within
// AnchorManager::kMinDepth .. kMaxDepth m. (The pixel against the image and
// the anchor count: AnchorManager::add.)
std::string validateAnchorRequest(const cv::Point2d& uv, double depth);

// A planar target: validateTargetRequest() (planar/planar_target.h): a convex
// quad, clockwise, of 25 px^2 or more; a positive, finite size.

// The refusal of an id that is already in use for that kind ("region",
// "planar target", "anchor"): "<kind> id <id> is already tracked".
std::string alreadyTrackedError(const std::string& kind, uint32_t id);

// A number as the core's refusals and warnings word it (12 significant
// digits: a stamp keeps its microseconds).
std::string messageNumber(double v);

}  // namespace imt
