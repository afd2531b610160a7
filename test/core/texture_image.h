// Test images for the regions' looks: a smooth random texture (seeded: the
// same on every machine's RNG) and an image moved by a known shift.
#pragma once

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdint>

namespace imt {
namespace test {

// Uniform noise blurred by a Gaussian of `sigma` px, stretched to 0..255.
inline cv::Mat smoothTexture(cv::Size size, uint64_t seed, double sigma) {
  cv::Mat noise(size, CV_8UC1);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
  cv::Mat t;
  cv::GaussianBlur(noise, t, cv::Size(0, 0), sigma);
  cv::normalize(t, t, 0, 255, cv::NORM_MINMAX);
  return t;
}

// `image` moved by (dx, dy) px, sub-pixel shifts read bilinearly (a whole
// pixel's shift is exact).
inline cv::Mat shifted(const cv::Mat& image, double dx, double dy) {
  cv::Mat out;
  const cv::Mat m = (cv::Mat_<double>(2, 3) << 1, 0, dx, 0, 1, dy);
  cv::warpAffine(image, out, m, image.size(), cv::INTER_LINEAR, cv::BORDER_REFLECT);
  return out;
}

}  // namespace test
}  // namespace imt
