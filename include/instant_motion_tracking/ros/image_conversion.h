// sensor_msgs/Image and sensor_msgs/CompressedImage -> 8-bit gray (CV_8UC1),
// the only input the core takes. Shared by track_bag and the nodelets: these
// functions never throw (an uncaught exception would kill a nodelet manager)
// and never read outside the message's data, whatever the message claims.
//
// Supported raw encodings: mono8, mono16 (high byte: value >> 8, either
// endianness), bgr8, rgb8, bgra8, rgba8. Compressed: whatever OpenCV decodes
// (jpeg, png, ...; the format string's "compressedDepth" is rejected).
//
// Usage:
//   cv::Mat gray;
//   std::string err;
//   if (!imt::imageToGray(*msg, &gray, &err)) { ROS_WARN_THROTTLE(5, "%s", err.c_str()); return; }
//
// Threading: stateless; safe from any thread.
#pragma once

#include <opencv2/core.hpp>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <string>

namespace imt {

// True for the raw encodings imageToGray() accepts.
bool isSupportedEncoding(const std::string& encoding);

// `gray` gets a new CV_8UC1 image that owns its pixels. False, with a one-line
// message (naming the encoding when that is the problem), for an unsupported
// encoding, a zero size, a step shorter than a row, or data shorter than
// step * height.
bool imageToGray(const sensor_msgs::Image& msg, cv::Mat* gray, std::string* error);

// Decodes to gray. False with a message for empty data, a compressedDepth
// format, or data OpenCV cannot decode.
bool compressedImageToGray(const sensor_msgs::CompressedImage& msg, cv::Mat* gray,
                           std::string* error);

}  // namespace imt
