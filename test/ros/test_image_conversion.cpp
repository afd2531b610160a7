#include "instant_motion_tracking/ros/image_conversion.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstring>
#include <string>

namespace imt {
namespace {

// A 5x3 gray ramp with distinct values, so a wrong stride or channel shows.
cv::Mat grayRamp() {
  cv::Mat g(3, 5, CV_8UC1);
  for (int y = 0; y < g.rows; ++y)
    for (int x = 0; x < g.cols; ++x) g.at<uint8_t>(y, x) = static_cast<uint8_t>(10 + 40 * x + 7 * y);
  return g;
}

// Packs `img` into a message with `pad` extra bytes at the end of each row.
sensor_msgs::Image toMsg(const cv::Mat& img, const std::string& encoding, int pad = 0) {
  sensor_msgs::Image m;
  m.width = img.cols;
  m.height = img.rows;
  m.encoding = encoding;
  const size_t row = img.cols * img.elemSize();
  m.step = static_cast<uint32_t>(row + pad);
  m.data.assign(m.step * img.rows, 0xEE);
  for (int y = 0; y < img.rows; ++y) std::memcpy(&m.data[y * m.step], img.ptr(y), row);
  return m;
}

void expectSame(const cv::Mat& a, const cv::Mat& b, int tolerance) {
  ASSERT_EQ(a.type(), CV_8UC1);
  ASSERT_EQ(a.size(), b.size());
  double max_diff = 0;
  cv::minMaxLoc(cv::abs(a - b), nullptr, &max_diff);
  EXPECT_LE(max_diff, tolerance);
}

TEST(ImageToGray, Mono8WithPaddedRowsIsCopied) {
  const cv::Mat g = grayRamp();
  sensor_msgs::Image m = toMsg(g, "mono8", /*pad=*/3);
  cv::Mat out;
  std::string err;
  ASSERT_TRUE(imageToGray(m, &out, &err)) << err;
  expectSame(out, g, 0);  // exact: no conversion
  m.data[0] = 0;           // the result owns its pixels
  EXPECT_EQ(out.at<uint8_t>(0, 0), g.at<uint8_t>(0, 0));
}

TEST(ImageToGray, Mono16TakesTheHighByteInEitherEndianness) {
  const cv::Mat g = grayRamp();
  cv::Mat g16;
  g.convertTo(g16, CV_16UC1, 256.0);
  g16 += cv::Scalar(0xAB);  // low byte noise that must be dropped (>> 8)
  sensor_msgs::Image little = toMsg(g16, "mono16", /*pad=*/1);  // odd step: no alignment assumed
  cv::Mat out;
  std::string err;
  ASSERT_TRUE(imageToGray(little, &out, &err)) << err;
  expectSame(out, g, 0);

  sensor_msgs::Image big = little;
  big.is_bigendian = 1;
  for (uint32_t y = 0; y < big.height; ++y)
    for (uint32_t x = 0; x < big.width; ++x)
      std::swap(big.data[y * big.step + 2 * x], big.data[y * big.step + 2 * x + 1]);
  ASSERT_TRUE(imageToGray(big, &out, &err)) << err;
  expectSame(out, g, 0);
}

// Colour encodings: channel order must follow the encoding. A pure red image
// is gray 76 (0.299 * 255) and pure blue 29 (0.114 * 255); swapping R and B
// would swap them. Tolerance 1 grey level for OpenCV's fixed-point rounding.
struct ColourCase {
  const char* encoding;
  int type;
  cv::Scalar red;  // pure red in the encoding's channel order
};

class ImageToGrayColour : public ::testing::TestWithParam<ColourCase> {};

TEST_P(ImageToGrayColour, FollowsTheChannelOrder) {
  const ColourCase& c = GetParam();
  const cv::Mat img(4, 6, c.type, c.red);
  cv::Mat out;
  std::string err;
  ASSERT_TRUE(imageToGray(toMsg(img, c.encoding, 2), &out, &err)) << err;
  expectSame(out, cv::Mat(4, 6, CV_8UC1, cv::Scalar(76)), 1);
}

INSTANTIATE_TEST_SUITE_P(
    Each, ImageToGrayColour,
    ::testing::Values(ColourCase{"bgr8", CV_8UC3, cv::Scalar(0, 0, 255)},
                      ColourCase{"rgb8", CV_8UC3, cv::Scalar(255, 0, 0)},
                      ColourCase{"bgra8", CV_8UC4, cv::Scalar(0, 0, 255, 17)},
                      ColourCase{"rgba8", CV_8UC4, cv::Scalar(255, 0, 0, 17)}),
    [](const auto& info) { return std::string(info.param.encoding); });

// Malformed or unsupported messages: rejected with a message, never read out
// of bounds (run under ASan to check the latter).
struct BadImage {
  const char* name;
  void (*mutate)(sensor_msgs::Image*);
  const char* message;
};

void PrintTo(const BadImage& b, std::ostream* os) { *os << b.name; }

class ImageToGrayBad : public ::testing::TestWithParam<BadImage> {};

TEST_P(ImageToGrayBad, IsRejectedWithAMessage) {
  sensor_msgs::Image m = toMsg(cv::Mat(4, 6, CV_8UC3, cv::Scalar(1, 2, 3)), "bgr8");
  GetParam().mutate(&m);
  cv::Mat out;
  std::string err;
  EXPECT_FALSE(imageToGray(m, &out, &err));
  EXPECT_EQ(err, GetParam().message);
}

const BadImage kBadImages[] = {
    {"float_depth", [](sensor_msgs::Image* m) { m->encoding = "32FC1"; },
     "unsupported image encoding '32FC1' (supported: mono8, mono16, bgr8, rgb8, bgra8, rgba8)"},
    {"yuv422", [](sensor_msgs::Image* m) { m->encoding = "yuv422"; },
     "unsupported image encoding 'yuv422' (supported: mono8, mono16, bgr8, rgb8, bgra8, rgba8)"},
    {"bayer", [](sensor_msgs::Image* m) { m->encoding = "bayer_rggb8"; },
     "unsupported image encoding 'bayer_rggb8' (supported: mono8, mono16, bgr8, rgb8, bgra8, rgba8)"},
    {"empty_encoding", [](sensor_msgs::Image* m) { m->encoding = ""; },
     "unsupported image encoding '' (supported: mono8, mono16, bgr8, rgb8, bgra8, rgba8)"},
    {"zero_width", [](sensor_msgs::Image* m) { m->width = 0; }, "bad image size 0x4"},
    {"step_short", [](sensor_msgs::Image* m) { m->step = 17; },
     "image step 17 is shorter than a row (6 px of bgr8 = 18 bytes)"},
    {"data_short", [](sensor_msgs::Image* m) { m->data.resize(m->data.size() - 1); },
     "image data has 71 bytes, step x height is 72"},
    {"height_lies", [](sensor_msgs::Image* m) { m->height = 4000; },
     "image data has 72 bytes, step x height is 72000"},
    {"huge_step_no_overflow", [](sensor_msgs::Image* m) { m->step = 0xFFFFFFFFu; },
     "image data has 72 bytes, step x height is 17179869180"},
};

INSTANTIATE_TEST_SUITE_P(Each, ImageToGrayBad, ::testing::ValuesIn(kBadImages),
                         [](const auto& info) { return std::string(info.param.name); });

TEST(CompressedImageToGray, DecodesPngExactlyAndJpegClosely) {
  const cv::Mat g = grayRamp();
  std::vector<uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", g, png));
  sensor_msgs::CompressedImage m;
  m.format = "mono8; png compressed mono8";
  m.data = png;
  cv::Mat out;
  std::string err;
  ASSERT_TRUE(compressedImageToGray(m, &out, &err)) << err;
  expectSame(out, g, 0);  // lossless

  // A colour JPEG (what image_transport's compressed plugin sends for bgr8).
  cv::Mat colour(32, 32, CV_8UC3, cv::Scalar(0, 0, 255));  // red: gray 76
  std::vector<uint8_t> jpg;
  ASSERT_TRUE(cv::imencode(".jpg", colour, jpg, {cv::IMWRITE_JPEG_QUALITY, 95}));
  m.format = "bgr8; jpeg compressed bgr8";
  m.data = jpg;
  ASSERT_TRUE(compressedImageToGray(m, &out, &err)) << err;
  // 4 grey levels: JPEG chroma subsampling and quantisation of a flat colour.
  expectSame(out, cv::Mat(32, 32, CV_8UC1, cv::Scalar(76)), 4);
}

TEST(CompressedImageToGray, RejectsGarbageEmptyAndDepth) {
  sensor_msgs::CompressedImage m;
  m.format = "jpeg";
  cv::Mat out;
  std::string err;
  EXPECT_FALSE(compressedImageToGray(m, &out, &err));
  EXPECT_EQ(err, "compressed image has no data");
  m.data.assign(1000, 0x5A);
  EXPECT_FALSE(compressedImageToGray(m, &out, &err));
  EXPECT_EQ(err, "cannot decode the compressed image (format 'jpeg', 1000 bytes)");
  // The first bytes of a JPEG, then garbage: a header with nothing behind it.
  m.data = {0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x10, 'J', 'F', 'I', 'F', 0, 1, 1, 0, 0, 1, 0, 1, 0, 0};
  EXPECT_FALSE(compressedImageToGray(m, &out, &err));
  EXPECT_EQ(err.rfind("cannot decode the compressed image (format 'jpeg'", 0), 0u) << err;
  m.format = "16UC1; compressedDepth png";
  EXPECT_FALSE(compressedImageToGray(m, &out, &err));
  EXPECT_EQ(err, "unsupported compressed image format '16UC1; compressedDepth png' (depth image)");
}

TEST(SupportedEncodings, AreExactlyTheSpecsList) {
  for (const char* e : {"mono8", "mono16", "bgr8", "rgb8", "bgra8", "rgba8"})
    EXPECT_TRUE(isSupportedEncoding(e)) << e;
  for (const char* e : {"8UC1", "16UC1", "32FC1", "yuv422", "bgr16", "MONO8"})
    EXPECT_FALSE(isSupportedEncoding(e)) << e;
}

}  // namespace
}  // namespace imt
