// The shape a region's box holds, read from the frame's edges when the box is
// given (private to the region tracker).
//
// A drawn box is the axis-aligned extent of whatever it was drawn around. For
// most objects (a car, a boat, a walker) what fills it is unknown, and the
// region reports a hedged extent as it turns (region_geometry::
// reportedExtent). A rectangle (a poster, a screen, a card) shows itself by
// its edges: straight, in one orientation (mod 90 degrees), with its four
// sides on them. Such a box is taken as that rectangle: as drawn when its own
// sides lie on the edges, or, when the edges are turned and a turned
// rectangle whose corners touch the box's sides lies on them better, as that
// turned rectangle.
//
// Usage:
//   const imt::PlacedShape s = imt::placedShape(gray, box);
//   if (s.rectangle) { state.box = s.box; state.angle = s.angle; }
#pragma once

#include <opencv2/core.hpp>

namespace imt {

struct PlacedShape {
  bool rectangle = false;  // its sides lie on edges
  cv::Rect2d box;          // the rectangle before its turn (the given box when not turned)
  double angle = 0;        // rad; its turn in the image (x toward y), 0 when not turned
  // What was read, for traces: the edges' orientation (rad, mod pi/2) and how
  // concentrated it is (0: none, 1: every edge at it); the weakest side's
  // edge strength over the box's mean, for the turned rectangle and the box
  // as drawn (0: not tried).
  double edge_angle = 0, edge_concentration = 0, turned_sides = 0, drawn_sides = 0;
};

// Reads `box` of `gray` (CV_8UC1). Not a rectangle when the box is mostly
// outside the image, smaller than 8 px a side, or flat.
PlacedShape placedShape(const cv::Mat& gray, const cv::Rect2d& box);

}  // namespace imt
