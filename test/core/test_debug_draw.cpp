// Tests of the debug overlay (core/debug_draw.h): boxes, quads and anchors
// land on the pixels their states say, lost items are not drawn, other
// statuses are dimmed.
#include "instant_motion_tracking/core/debug_draw.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>

namespace imt {
namespace {

constexpr int kW = 320, kH = 240;
const cv::Vec3b kGray(100, 100, 100);

cv::Mat blank() {
  MotionData md;  // no features: only the status text at the top left
  return drawMotionData(cv::Mat(kH, kW, CV_8UC1, cv::Scalar(100)), md);
}

cv::Vec3b vec(const cv::Scalar& s) {
  return cv::Vec3b(cv::saturate_cast<uchar>(s[0]), cv::saturate_cast<uchar>(s[1]),
                   cv::saturate_cast<uchar>(s[2]));
}

// Max per-channel difference.
int diff(const cv::Vec3b& a, const cv::Vec3b& b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

RegionState region(uint32_t id, cv::Rect2d box, RegionStatus status) {
  RegionState s = RegionState::start(id, box, 1.0);
  s.status = status;
  return s;
}

// Pixels changed by drawing, as a mask.
cv::Mat changed(const cv::Mat& before, const cv::Mat& after) {
  cv::Mat d;
  cv::absdiff(before, after, d);
  cv::cvtColor(d, d, cv::COLOR_BGR2GRAY);
  return d > 0;
}

TEST(DebugDraw, RegionBoxIsDrawnOnItsEdges) {
  // Box covering pixels x 100..179, y 120..179 (our convention: [x, x + w)).
  DebugOverlay o;
  o.regions.push_back(region(3, cv::Rect2d(100, 120, 80, 60), RegionStatus::kTracked));
  cv::Mat img = blank();
  const cv::Mat before = img.clone();
  drawOverlay(&img, o);
  // The four edges carry the region colour (2 px wide lines: both the first
  // and the last pixel row/column of the box are on them).
  for (const cv::Point& p :
       {cv::Point(100, 150), cv::Point(179, 150), cv::Point(140, 120), cv::Point(140, 179)})
    EXPECT_LE(diff(img.at<cv::Vec3b>(p), vec(kRegionColour)), 30) << p;
  // Inside and far outside: untouched.
  EXPECT_EQ(img.at<cv::Vec3b>(150, 140), kGray);
  EXPECT_EQ(img.at<cv::Vec3b>(220, 300), kGray);
  // Its label "3 tracked" sits just above the box.
  const cv::Mat mask = changed(before, img);
  EXPECT_GT(cv::countNonZero(mask(cv::Rect(100, 100, 70, 18))), 20);
  // Nothing drawn outside the box's neighbourhood and its label.
  cv::Mat outside = mask.clone();
  outside(cv::Rect(95, 98, 120, 86)).setTo(0);
  outside(cv::Rect(0, 0, kW, 30)).setTo(0);  // the motion-data text
  EXPECT_EQ(cv::countNonZero(outside), 0);
}

TEST(DebugDraw, LostItemsAreNotDrawnAndOthersAreDimmed) {
  DebugOverlay o;
  o.regions.push_back(region(1, cv::Rect2d(20, 40, 50, 50), RegionStatus::kLost));
  AnchorState a;
  a.id = 2;
  a.pixel = cv::Point2d(200.5, 100.5);
  a.status = AnchorStatus::kLost;
  o.anchors.push_back(a);
  PlanarTargetState t;
  t.status = TargetStatus::kLost;
  t.corners = {cv::Point2d(10, 10), cv::Point2d(50, 10), cv::Point2d(50, 50), cv::Point2d(10, 50)};
  o.targets.push_back(t);
  cv::Mat img = blank();
  const cv::Mat before = img.clone();
  drawOverlay(&img, o);
  EXPECT_EQ(cv::countNonZero(changed(before, img)), 0);

  // Out of view: drawn at half intensity, 1 px wide.
  o = DebugOverlay();
  o.regions.push_back(region(1, cv::Rect2d(100, 120, 80, 60), RegionStatus::kOutOfView));
  drawOverlay(&img, o);
  EXPECT_LE(diff(img.at<cv::Vec3b>(150, 100), vec(kRegionColour * 0.5)), 30);
  // NaN boxes (a lost region from a message) are skipped, not drawn at 0,0.
  o.regions[0].box = cv::Rect2d(NAN, NAN, NAN, NAN);
  o.regions[0].status = RegionStatus::kTracked;
  const cv::Mat again = img.clone();
  drawOverlay(&img, o);
  EXPECT_EQ(cv::countNonZero(changed(again, img)), 0);
}

TEST(DebugDraw, PlanarQuadAndAnchorWithAxes) {
  DebugOverlay o;
  o.intrinsics = CameraModel::fromFieldOfView(kW, kH, 60.0);
  const CameraModel& k = o.intrinsics;
  PlanarTargetState t;
  t.id = 7;
  t.status = TargetStatus::kTracked;
  // A tilted quad; its edges' midpoints must be coloured.
  t.corners = {cv::Point2d(40.5, 60.5), cv::Point2d(140.5, 50.5), cv::Point2d(150.5, 150.5),
               cv::Point2d(30.5, 160.5)};
  t.T_cam_target.matrix().setConstant(NAN);  // no usable pose: quad only
  o.targets.push_back(t);
  // An anchor 2 m straight ahead at the principal point, axes along the camera's.
  AnchorState a;
  a.id = 4;
  a.status = AnchorStatus::kTracked;
  a.pixel = cv::Point2d(k.cx, k.cy);
  a.T_cam_anchor = Eigen::Isometry3d::Identity();
  a.T_cam_anchor.translation() = Eigen::Vector3d(0, 0, 2);
  o.anchors.push_back(a);
  cv::Mat img = blank();
  drawOverlay(&img, o);
  for (int i = 0; i < 4; ++i) {
    const cv::Point2d m = (t.corners[i] + t.corners[(i + 1) % 4]) / 2;
    EXPECT_LE(diff(img.at<cv::Vec3b>(cv::Point(m.x, m.y)), vec(kPlanarTargetColour)), 40) << i;
  }
  // The anchor's ring, 7 px around the pixel, and its x axis: 0.2 m at 2 m
  // is 0.1 fx px to the right, drawn red beyond the ring.
  const cv::Point c(static_cast<int>(k.cx), static_cast<int>(k.cy));
  EXPECT_LE(diff(img.at<cv::Vec3b>(c + cv::Point(0, 7)), vec(kAnchorColour)), 40);
  const int end = static_cast<int>(0.1 * k.fx);
  ASSERT_GT(end, 20);
  EXPECT_LE(diff(img.at<cv::Vec3b>(c + cv::Point(end - 4, 0)), cv::Vec3b(0, 0, 255)), 30);
  // y axis (down in the image): green.
  EXPECT_LE(diff(img.at<cv::Vec3b>(c + cv::Point(0, end - 4)), cv::Vec3b(0, 200, 0)), 30);
}

}  // namespace
}  // namespace imt
