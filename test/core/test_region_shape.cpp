// The shape a region's box holds, read from the frame's edges when it is
// given (src/core/region/region_shape.h): drawn pictures of a poster turned
// or not, an oval, a textured patch without edges, and boxes it cannot read.
#include "instant_motion_tracking/core/region/region_tracker.h"
#include "instant_motion_tracking/sim/scene.h"
#include "../../src/core/region/region_shape.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>

namespace imt {
namespace {

constexpr double kDeg = M_PI / 180;

// A 640x480 wall (gray, a little noise) with a w x h poster about (320, 240)
// turned by `turn` (x toward y): a bright page with dark lines of print along
// its sides. `extent`: the axis-aligned box around the poster.
cv::Mat poster(double w, double h, double turn, cv::Rect2d* extent) {
  cv::Mat img(480, 640, CV_8UC1);
  cv::RNG rng(3);
  rng.fill(img, cv::RNG::NORMAL, 90, 3);
  const cv::Point2d c(320, 240), ux(std::cos(turn), std::sin(turn)), uy(-std::sin(turn), std::cos(turn));
  const auto at = [&](double u, double v) { return c + u * ux + v * uy; };
  const auto quad = [&](double u0, double v0, double u1, double v1) {
    std::vector<cv::Point> p;
    for (const auto& [u, v] : {std::pair{u0, v0}, {u1, v0}, {u1, v1}, {u0, v1}}) {
      const cv::Point2d q = at(u, v);
      p.emplace_back(static_cast<int>(std::lround(q.x * 16)), static_cast<int>(std::lround(q.y * 16)));
    }
    return p;
  };
  cv::fillConvexPoly(img, quad(-w / 2, -h / 2, w / 2, h / 2), cv::Scalar(210), cv::LINE_AA, 4);
  for (double v = -h / 2 + 0.15 * h; v < h / 2 - 0.1 * h; v += 0.1 * h)  // lines of print
    cv::fillConvexPoly(img, quad(-0.4 * w, v, 0.4 * w, v + 0.03 * h), cv::Scalar(40), cv::LINE_AA, 4);
  const double cs = std::abs(std::cos(turn)), sn = std::abs(std::sin(turn));
  const double ew = w * cs + h * sn, eh = w * sn + h * cs;
  *extent = cv::Rect2d(c.x - ew / 2, c.y - eh / 2, ew, eh);
  return img;
}

TEST(RegionShape, ATurnedPosterIsTakenAsItsRectangle) {
  for (const double turn_deg : {-25.0, -8.0, 15.0, 30.0}) {
    cv::Rect2d drawn;
    const cv::Mat img = poster(240, 160, turn_deg * kDeg, &drawn);
    const PlacedShape s = placedShape(img, drawn);
    std::printf("poster turned %.0f deg: rectangle %d at %.2f deg, %.1f x %.1f px (edges %.2f deg, concentration %.2f, "
                "sides %.2f turned, %.2f as drawn)\n",
                turn_deg, s.rectangle, s.angle / kDeg, s.box.width, s.box.height, s.edge_angle / kDeg,
                s.edge_concentration, s.turned_sides, s.drawn_sides);
    ASSERT_TRUE(s.rectangle) << turn_deg;
    // The edges' orientation is read on the box shrunk to 96 px: within a
    // degree of the poster's (a degree moves the rectangle's sides by 1-2 px
    // here), and its size from that within 3%.
    EXPECT_NEAR(s.angle / kDeg, turn_deg, 1.0);
    EXPECT_NEAR(s.box.width, 240, 0.03 * 240);
    EXPECT_NEAR(s.box.height, 160, 0.03 * 160);
    EXPECT_NEAR(s.box.x + s.box.width / 2, 320, 0.5);
    EXPECT_NEAR(s.box.y + s.box.height / 2, 240, 0.5);
  }
}

TEST(RegionShape, APosterAsDrawnStaysAsDrawn) {
  cv::Rect2d drawn;
  const cv::Mat img = poster(240, 160, 0, &drawn);
  const PlacedShape s = placedShape(img, drawn);
  std::printf("poster unturned: rectangle %d, sides %.2f as drawn, turned %.2f\n", s.rectangle, s.drawn_sides,
              s.turned_sides);
  EXPECT_TRUE(s.rectangle);
  EXPECT_EQ(s.angle, 0.0);
  EXPECT_EQ(s.box, drawn);
}

TEST(RegionShape, AnOvalOrATextureIsNoRectangle) {
  // An oval turned 20 degrees, its box around it: its edges run every way,
  // and the box's sides touch it at one point each.
  cv::Mat oval(480, 640, CV_8UC1, cv::Scalar(90));
  const cv::RotatedRect e(cv::Point2f(320, 240), cv::Size2f(260, 120), 20);
  cv::ellipse(oval, e, cv::Scalar(210), -1, cv::LINE_AA);
  const PlacedShape o = placedShape(oval, e.boundingRect2f());
  std::printf("oval: concentration %.2f, sides %.2f turned, %.2f as drawn\n", o.edge_concentration, o.turned_sides,
              o.drawn_sides);
  EXPECT_FALSE(o.rectangle);
  // A patch of texture (the rendered scenes' cards): no edges to read.
  const cv::Mat texture = proceduralTexture(640, 5)(cv::Rect(0, 0, 640, 480)).clone();
  const PlacedShape t = placedShape(texture, cv::Rect2d(200, 150, 180, 120));
  std::printf("texture: concentration %.2f, sides %.2f as drawn\n", t.edge_concentration, t.drawn_sides);
  EXPECT_FALSE(t.rectangle);
  EXPECT_EQ(t.box, cv::Rect2d(200, 150, 180, 120));
}

TEST(RegionShape, BoxesItCannotReadAreNoRectangle) {
  cv::Rect2d drawn;
  const cv::Mat img = poster(240, 160, 15 * kDeg, &drawn);
  EXPECT_FALSE(placedShape(cv::Mat(), drawn).rectangle);
  EXPECT_FALSE(placedShape(img, cv::Rect2d(100, 100, 6, 40)).rectangle);        // too thin
  EXPECT_FALSE(placedShape(img, cv::Rect2d(600, 400, 200, 200)).rectangle);     // mostly outside
  EXPECT_FALSE(placedShape(cv::Mat(480, 640, CV_8UC1, cv::Scalar(7)), drawn).rectangle);  // flat
  cv::Mat colour;
  cv::cvtColor(img, colour, cv::COLOR_GRAY2BGR);
  EXPECT_FALSE(placedShape(colour, drawn).rectangle);  // not gray
}

// A region given around the turned poster starts as that rectangle: turned
// as found, the drawn box reported on the frame it was given, and the
// poster's own rectangle once it has turned back.
TEST(RegionShape, ARegionGivenAroundATurnedPosterReportsTheDrawnBoxThenThePoster) {
  cv::Rect2d drawn;
  const cv::Mat img = poster(240, 160, -20 * kDeg, &drawn);
  RegionTrackerOptions o;
  const RegionTracker tracker(o, img.size());
  RegionState s = RegionState::start(1, drawn, 0);
  tracker.initFromImage(&s, img, MotionData());
  ASSERT_TRUE(s.rectangle);
  EXPECT_NEAR(s.placed_angle / kDeg, -20, 1.0);
  EXPECT_EQ(s.angle, s.placed_angle);
  const cv::Rect2d e = s.extent();
  EXPECT_NEAR(e.x, drawn.x, 1e-9);
  EXPECT_NEAR(e.y, drawn.y, 1e-9);
  EXPECT_NEAR(e.width, drawn.width, 1e-9);
  EXPECT_NEAR(e.height, drawn.height, 1e-9);
  // Turned back to 0: the extent is the poster's own rectangle turned by
  // what the smoothing of the reported turn leaves of 20 degrees (1.5: a
  // 160 px side grows 4%, a 240 px one 0.3%), 3% for the rectangle as
  // above; not the drawn box (280 x 232 px), nor that turned further.
  s.angle = 0;
  EXPECT_NEAR(s.extent().width, 240, 0.03 * 240);
  EXPECT_NEAR(s.extent().height, 160, 0.07 * 160);
  // The poster's 240 x 160 is 0.59 of the drawn box's area: not the drawn box.
  EXPECT_LT(s.extent().area(), 0.65 * drawn.area());
}

}  // namespace
}  // namespace imt
