#include "instant_motion_tracking/ros/image_conversion.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cstdint>
#include <exception>

namespace imt {
namespace {

// Bytes per pixel of a supported encoding, 0 otherwise.
int bytesPerPixel(const std::string& e) {
  if (e == "mono8") return 1;
  if (e == "mono16") return 2;
  if (e == "bgr8" || e == "rgb8") return 3;
  if (e == "bgra8" || e == "rgba8") return 4;
  return 0;
}

std::string printable(const std::string& s) {
  std::string out;
  for (char c : s.substr(0, 64)) out += (c >= 32 && c < 127) ? c : '?';
  return s.size() > 64 ? out + "..." : out;
}

// cv::Exception::what() spans lines; messages here are one line.
std::string oneLine(const char* what) {
  std::string s(what);
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

}  // namespace

bool isSupportedEncoding(const std::string& encoding) { return bytesPerPixel(encoding) > 0; }

bool imageToGray(const sensor_msgs::Image& msg, cv::Mat* gray, std::string* error) {
  const int bpp = bytesPerPixel(msg.encoding);
  if (bpp == 0) {
    *error = "unsupported image encoding '" + printable(msg.encoding) +
             "' (supported: mono8, mono16, bgr8, rgb8, bgra8, rgba8)";
    return false;
  }
  const uint64_t w = msg.width, h = msg.height, step = msg.step;
  if (w == 0 || h == 0 || w > (1u << 16) || h > (1u << 16)) {
    *error = "bad image size " + std::to_string(w) + "x" + std::to_string(h);
    return false;
  }
  if (step < w * bpp) {
    *error = "image step " + std::to_string(step) + " is shorter than a row (" +
             std::to_string(w) + " px of " + msg.encoding + " = " + std::to_string(w * bpp) +
             " bytes)";
    return false;
  }
  if (msg.data.size() < step * h) {
    *error = "image data has " + std::to_string(msg.data.size()) + " bytes, step x height is " +
             std::to_string(step * h);
    return false;
  }
  try {
    uint8_t* data = const_cast<uint8_t*>(msg.data.data());  // wrapped read-only below
    const int rows = static_cast<int>(h), cols = static_cast<int>(w);
    if (msg.encoding == "mono8") {
      cv::Mat(rows, cols, CV_8UC1, data, step).copyTo(*gray);
    } else if (msg.encoding == "mono16") {
      // The high byte of each sample, read byte-wise: no alignment needed.
      const int hi = msg.is_bigendian ? 0 : 1;
      gray->create(rows, cols, CV_8UC1);
      for (int y = 0; y < rows; ++y) {
        const uint8_t* src = data + y * step;
        uint8_t* dst = gray->ptr<uint8_t>(y);
        for (int x = 0; x < cols; ++x) dst[x] = src[2 * x + hi];
      }
    } else {
      static const struct { const char* enc; int type; int code; } kColour[] = {
          {"bgr8", CV_8UC3, cv::COLOR_BGR2GRAY},
          {"rgb8", CV_8UC3, cv::COLOR_RGB2GRAY},
          {"bgra8", CV_8UC4, cv::COLOR_BGRA2GRAY},
          {"rgba8", CV_8UC4, cv::COLOR_RGBA2GRAY}};
      for (const auto& c : kColour) {
        if (msg.encoding == c.enc) {
          cv::Mat out;  // a fresh Mat: never write into the caller's buffer
          cv::cvtColor(cv::Mat(rows, cols, c.type, data, step), out, c.code);
          *gray = out;
        }
      }
    }
  } catch (const std::exception& e) {  // cv::Exception, std::bad_alloc
    *error = "cannot convert the " + msg.encoding + " image to gray: " + oneLine(e.what());
    return false;
  }
  return true;
}

bool compressedImageToGray(const sensor_msgs::CompressedImage& msg, cv::Mat* gray,
                           std::string* error) {
  if (msg.format.find("compressedDepth") != std::string::npos) {
    *error = "unsupported compressed image format '" + printable(msg.format) + "' (depth image)";
    return false;
  }
  if (msg.data.empty()) {
    *error = "compressed image has no data";
    return false;
  }
  cv::Mat out;
  try {
    const cv::Mat buf(1, static_cast<int>(msg.data.size()), CV_8UC1,
                      const_cast<uint8_t*>(msg.data.data()));
    out = cv::imdecode(buf, cv::IMREAD_GRAYSCALE);
  } catch (const std::exception& e) {
    *error = "cannot decode the compressed image (format '" + printable(msg.format) +
             "'): " + oneLine(e.what());
    return false;
  }
  if (out.empty() || out.type() != CV_8UC1) {
    *error = "cannot decode the compressed image (format '" + printable(msg.format) + "', " +
             std::to_string(msg.data.size()) + " bytes)";
    return false;
  }
  *gray = out;
  return true;
}

}  // namespace imt
