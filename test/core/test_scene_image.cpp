// Tests of the scene generator's images: determinism, thread safety, noise,
// brightness, motion blur and textures.
#include "instant_motion_tracking/sim/scene.h"

#include "scene_test_util.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <thread>

namespace imt {
namespace {

using test::make;
using test::preset;

TEST(Scene, RenderingIsDeterministicAndThreadSafe) {
  SceneOptions o = preset("cards");
  o.duration = 2;
  auto a = make(o), b = make(o);
  ASSERT_TRUE(a && b);
  const cv::Mat a7 = a->renderFrame(7);
  EXPECT_EQ(cv::norm(a7, b->renderFrame(7), cv::NORM_INF), 0);
  EXPECT_EQ(cv::norm(a7, a->renderFrame(7), cv::NORM_INF), 0);
  // Concurrent rendering gives the serial result.
  std::vector<cv::Mat> serial, parallel(6);
  for (int i = 0; i < 6; ++i) serial.push_back(a->renderFrame(i * 9));
  std::vector<std::thread> threads;
  for (int i = 0; i < 6; ++i) threads.emplace_back([&, i] { parallel[i] = a->renderFrame(i * 9); });
  for (std::thread& t : threads) t.join();
  for (int i = 0; i < 6; ++i) EXPECT_EQ(cv::norm(serial[i], parallel[i], cv::NORM_INF), 0) << i;
  // Another seed: other textures and noise.
  o.seed = 2;
  auto c = make(o);
  cv::Mat diff;
  cv::absdiff(a7, c->renderFrame(7), diff);
  EXPECT_GT(cv::countNonZero(diff > 10), a7.total() / 2);
  // Same seed, other frame index: other noise on a still scene.
  SceneOptions s = preset("still");
  auto still = make(s);
  cv::absdiff(still->renderFrame(3), still->renderFrame(4), diff);
  EXPECT_GT(cv::countNonZero(diff), diff.total() / 2);
}

TEST(Scene, NoiseBrightnessAndMotionBlur) {
  SceneOptions o = preset("still");
  o.brightness_amplitude = 0.2;
  o.brightness_period = 4;
  auto scene = make(o);
  ASSERT_TRUE(scene);
  // Frames 0 (gain 1) and 30 (t = 1 s: gain 1.2): the mean scales by the gain.
  const cv::Mat f0 = scene->renderFrame(0), f30 = scene->renderFrame(30);
  EXPECT_NEAR(scene->frameTruth(30).brightness_gain, 1.2, 1e-12);
  EXPECT_NEAR(cv::mean(f30)[0] / cv::mean(f0)[0], 1.2, 0.01);  // noise averages out; rare clipping
  // Sensor noise: two frames at the same gain differ by N(0, sigma sqrt 2).
  o.brightness_amplitude = 0;
  auto flat = make(o);
  cv::Mat d;
  cv::subtract(flat->renderFrame(1), flat->renderFrame(2), d, cv::noArray(), CV_32F);
  cv::Scalar mean, sd;
  cv::meanStdDev(d, mean, sd);
  EXPECT_NEAR(sd[0], o.noise_sigma * std::sqrt(2.0),
              0.15 * o.noise_sigma);  // +-10%, 8-bit rounding
  // Exposure on a still camera changes nothing; on a moving one the frame
  // is the mean of blur_samples renders over the exposure.
  o.exposure = 1 / 30.0;
  auto still_blur = make(o);
  EXPECT_LE(cv::norm(still_blur->renderFrame(5), flat->renderFrame(5), cv::NORM_INF), 1);
  SceneOptions p = preset("wall_pan");
  p.noise_sigma = 0;
  p.brightness_amplitude = 0;
  auto sharp = make(p);
  p.exposure = 0.02;
  p.blur_samples = 5;
  auto blurred = make(p);
  const int i = 120;  // t = 4 s: panning at its fastest (~4 px/frame)
  cv::Mat sum = cv::Mat::zeros(p.height, p.width, CV_32F);
  for (int k = 0; k < 5; ++k)
    cv::accumulate(sharp->renderAt(i / p.fps + 0.02 * (k / 4.0 - 0.5)), sum);
  cv::Mat expected;
  sum.convertTo(expected, CV_8U, 1 / 5.0);
  const cv::Mat got = blurred->renderFrame(i);
  EXPECT_LE(cv::norm(got, expected, cv::NORM_INF), 1);  // 8-bit rounding of the sub-frames
  auto gradient = [](const cv::Mat& img) {
    cv::Mat gx;
    cv::Sobel(img, gx, CV_32F, 1, 0);
    return cv::mean(cv::abs(gx))[0];
  };
  // A 2.4 px smear lowers the mean horizontal gradient by 8% (measured).
  EXPECT_LT(gradient(got), 0.96 * gradient(sharp->renderFrame(i)));
}

TEST(Scene, TexturesGiveDenseWellSpreadCorners) {
  for (const std::string name : {"wall_pan", "cards", "poster_orbit"}) {
    auto scene = make(preset(name));
    ASSERT_TRUE(scene);
    for (int i : {0, 150}) {
      const cv::Mat img = scene->renderFrame(i);
      std::vector<cv::Point2f> corners;
      cv::goodFeaturesToTrack(img, corners, 600, 0.01, 8);
      int cells[6][8] = {};
      for (const cv::Point2f& c : corners)
        cells[static_cast<int>(c.y * 6 / img.rows)][static_cast<int>(c.x * 8 / img.cols)]++;
      int good = 0;
      for (auto& row : cells)
        for (int n : row) good += n >= 3;
      // The featureless patch (cards) or a wall seen at a grazing angle
      // (poster_orbit, blurred along one direction) may leave a few cells
      // with fewer corners: measured 44-48 of 48.
      EXPECT_GE(good, 42) << name << " frame " << i;
      EXPECT_GE(corners.size(), 400u) << name << " frame " << i;
    }
  }
}

TEST(Scene, TexturesFromImageFiles) {
  // A left/right split image: the wall must show it the right way round.
  cv::Mat tex(64, 128, CV_8UC1, cv::Scalar(60));
  tex.colRange(64, 128).setTo(180);
  const std::string file = ::testing::TempDir() + "/imt_scene_texture.png";
  ASSERT_TRUE(cv::imwrite(file, tex));
  SceneOptions o = preset("still");
  o.planes[0].width_m = 4;  // the texture over 4 m x 2 m: the view sees its middle
  o.planes[0].height_m = 2;
  o.planes[0].texture_tile_m = 0;  // stretched over the plane, not repeated
  o.texture_files = {file};
  o.noise_sigma = 0;
  auto scene = make(o);
  ASSERT_TRUE(scene);
  const cv::Mat img = scene->renderFrame(0);
  EXPECT_EQ(img.at<uint8_t>(240, 100), 60);
  EXPECT_EQ(img.at<uint8_t>(240, 540), 180);
  EXPECT_NEAR(img.at<uint8_t>(240, 319), 120, 40);  // the split, blurred by the mip filter
}

TEST(Scene, ProceduralTextureIsDeterministicPeriodicAndDetailed) {
  const cv::Mat a = proceduralTexture(256, 5), b = proceduralTexture(256, 5),
                c = proceduralTexture(256, 6);
  ASSERT_EQ(a.size(), cv::Size(256, 256));
  ASSERT_EQ(a.type(), CV_8UC1);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0);
  EXPECT_GT(cv::norm(a, c, cv::NORM_L1) / a.total(), 10);
  cv::Scalar mean, sd;
  cv::meanStdDev(a, mean, sd);
  EXPECT_GT(sd[0], 25);
  // Periodic: the seam (last column -> first column) is no rougher than any
  // column step inside, so tiled walls have no visible seams.
  auto colStep = [&](int x0, int x1) {
    return cv::norm(a.col(x0), a.col(x1), cv::NORM_L1) / a.rows;
  };
  auto rowStep = [&](int y0, int y1) {
    return cv::norm(a.row(y0), a.row(y1), cv::NORM_L1) / a.cols;
  };
  double inner = 0;
  for (int x = 0; x + 1 < a.cols; ++x) inner += colStep(x, x + 1) / (a.cols - 1);
  EXPECT_LT(colStep(a.cols - 1, 0), 1.6 * inner);
  EXPECT_LT(rowStep(a.rows - 1, 0), 1.6 * inner);
  EXPECT_GT(colStep(0, a.cols / 2), 3 * inner);  // far columns are unrelated
}

}  // namespace
}  // namespace imt
