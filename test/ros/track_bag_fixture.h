// Shared by the track_bag tests (test_track_bag.cpp: good runs;
// test_track_bag_bad_input.cpp: bad input): bags written for the test, the
// tool run as a process, the fixture with its temporary folder.
#pragma once
#include "instant_motion_tracking/AnchorArray.h"
#include "instant_motion_tracking/MotionData.h"
#include "instant_motion_tracking/io/csv_writer.h"

#include <geometry_msgs/TransformStamped.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <tf2_msgs/TFMessage.h>

#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace imt {
namespace {

const std::string kBin = std::string(IMT_BIN_DIR) + "/track_bag";
const std::string kSourceDir = IMT_SOURCE_DIR;

// --- bag writing --------------------------------------------------------------

struct BagSpec {
  int frames = 20;
  int width = 160, height = 120;
  double start = 1000.0, fps = 30.0;
  std::vector<double> stamps;            // header stamps; default start + i / fps
  std::string image_topic = "/cam/image_raw";
  std::string encoding = "mono8";        // raw encoding written
  std::string compressed;                // "png" / "jpeg": CompressedImage on <topic>/compressed
  bool camera_info = true;
  int info_width = 0, info_height = 0;   // camera_info size (0 = the image's)
  bool imu = true;
  int imu_nan = 0;                       // this many IMU samples carry NaN
  bool tf_static = true;
  std::function<void(rosbag::Bag&)> extra;  // more messages (second topics, ...)
  std::function<cv::Mat(int)> image;     // frame i's gray image (default frameImage)
  int corrupt_frame = -1;                // this frame's compressed data is garbage
  int crc_warning_frame = -1;            // this frame's PNG has a tEXt chunk with a bad CRC
  int bad_frame = -1;                    // this frame's encoding is `bad_encoding`
  std::string bad_encoding;
  std::function<void(int, sensor_msgs::Image&)> edit_image;       // raw frame i, before it is written
  std::function<void(int, sensor_msgs::CameraInfo&)> edit_info;   // camera_info i, before it is written
};

// Seeded texture shifted 1 px left per frame: content at x in frame i-1 is at
// x - 1 in frame i, so the camera motion is h02 = -1 (translation).
cv::Mat frameImage(int i, int w, int h) {
  static cv::Mat texture;
  if (texture.empty() || texture.cols < w + 100 || texture.rows < h) {
    cv::RNG rng(7);
    texture.create(std::max(h, 480), std::max(w + 100, 740), CV_8UC1);
    rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
    cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1.5);
    cv::normalize(texture, texture, 0, 255, cv::NORM_MINMAX);
  }
  return texture(cv::Rect(i, 0, w, h)).clone();
}

double frameStamp(const BagSpec& s, int i) {
  return s.stamps.empty() ? s.start + i / s.fps : s.stamps[i];
}

sensor_msgs::Image rawImage(const cv::Mat& gray, const std::string& encoding,
                            const std_msgs::Header& header) {
  cv::Mat img;
  if (encoding == "mono8") {
    img = gray;
  } else if (encoding == "mono16") {
    gray.convertTo(img, CV_16UC1, 256.0);
  } else if (encoding == "bgr8" || encoding == "rgb8") {
    cv::cvtColor(gray, img, cv::COLOR_GRAY2BGR);
  } else if (encoding == "bgra8" || encoding == "rgba8") {
    cv::cvtColor(gray, img, cv::COLOR_GRAY2BGRA);
  } else {  // unsupported encodings: plausible data sizes
    img = cv::Mat(gray.rows, gray.cols, encoding == "32FC1" ? CV_32FC1 : CV_8UC2, cv::Scalar(0));
  }
  sensor_msgs::Image m;
  m.header = header;
  m.width = img.cols;
  m.height = img.rows;
  m.encoding = encoding;
  m.step = static_cast<uint32_t>(img.cols * img.elemSize());
  m.data.assign(img.datastart, img.dataend);
  return m;
}

void writeBag(const std::string& path, const BagSpec& s) {
  rosbag::Bag bag(path, rosbag::bagmode::Write);
  const std::string frame_id = "cam_optical";
  const ros::Time t0(s.start);
  if (s.tf_static) {
    geometry_msgs::TransformStamped t;
    t.header.stamp = t0;
    t.header.frame_id = frame_id;  // parent: camera; child: IMU
    t.child_frame_id = "imu_link";
    t.transform.rotation.z = std::sin(M_PI / 4);  // 90 deg about z: R_cam_imu = Rz(90)
    t.transform.rotation.w = std::cos(M_PI / 4);
    tf2_msgs::TFMessage tf;
    tf.transforms.push_back(t);
    bag.write("/tf_static", t0, tf);
  }
  int imu_written = 0;
  for (int i = 0; i < s.frames; ++i) {
    const double stamp = frameStamp(s, i);
    const ros::Time bag_time(s.start + i / s.fps);  // receive times always increase
    std_msgs::Header h;
    h.seq = i;
    h.stamp = ros::Time(stamp);
    h.frame_id = frame_id;
    if (s.imu) {  // 200 Hz between this frame and the next
      for (int k = 0; k < 7; ++k) {
        sensor_msgs::Imu m;
        m.header.stamp = ros::Time(s.start + i / s.fps + k / 200.0);
        m.header.frame_id = "imu_link";
        m.angular_velocity.z = 0.01;
        m.linear_acceleration.z = 9.81;
        m.orientation_covariance[0] = -1;
        if (imu_written < s.imu_nan) m.angular_velocity.x = std::numeric_limits<double>::quiet_NaN();
        ++imu_written;
        bag.write("/imu/data", bag_time + ros::Duration(k / 200.0), m);
      }
    }
    if (s.camera_info) {
      sensor_msgs::CameraInfo info;
      info.header = h;
      info.width = s.info_width ? s.info_width : s.width;
      info.height = s.info_height ? s.info_height : s.height;
      info.K = {100, 0, (info.width - 1) / 2.0, 0, 100, (info.height - 1) / 2.0, 0, 0, 1};
      if (s.edit_info) s.edit_info(i, info);
      bag.write("/cam/camera_info", bag_time, info);
    }
    const cv::Mat gray = s.image ? s.image(i) : frameImage(i, s.width, s.height);
    if (!s.compressed.empty()) {
      sensor_msgs::CompressedImage c;
      c.header = h;
      c.format = "mono8; " + s.compressed + " compressed mono8";
      cv::imencode(s.compressed == "png" ? ".png" : ".jpg", gray, c.data);
      if (i == s.corrupt_frame) std::fill(c.data.begin() + 8, c.data.end(), 0x5A);
      if (i == s.crc_warning_frame) {  // after the signature (8) and IHDR (25 bytes)
        const std::vector<uint8_t> chunk = {0, 0, 0, 3, 't', 'E', 'X', 't', 'a', 0, 'b', 0, 0, 0, 0};
        c.data.insert(c.data.begin() + 33, chunk.begin(), chunk.end());
      }
      bag.write(s.image_topic + "/compressed", bag_time, c);
    } else {
      const std::string enc = i == s.bad_frame ? s.bad_encoding : s.encoding;
      sensor_msgs::Image m = rawImage(gray, enc, h);
      if (s.edit_image) s.edit_image(i, m);
      bag.write(s.image_topic, bag_time, m);
    }
  }
  if (s.extra) s.extra(bag);
  bag.close();
}

// --- running the tool ---------------------------------------------------------

struct ToolRun {
  int status = -1;
  std::string out, err;
  std::vector<std::string> errLines() const {
    std::vector<std::string> lines;
    std::stringstream ss(err);
    std::string l;
    while (std::getline(ss, l)) lines.push_back(l);
    return lines;
  }
};

std::string readFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

class TrackBag : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    char tmpl[] = "/tmp/imt_track_bag_XXXXXX";
    ASSERT_NE(mkdtemp(tmpl), nullptr);
    dir_ = tmpl;
    good_ = dir_ + "/good.bag";
    writeBag(good_, BagSpec());
  }
  static void TearDownTestSuite() {
    if (std::getenv("IMT_KEEP_TEST_DIR")) {  // for debugging: keep the bags and outputs
      std::printf("kept %s\n", dir_.c_str());
      return;
    }
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  // Runs track_bag with `args` (shell words, already quoted where needed).
  // `env` is prepended (e.g. "env -u ROS_PACKAGE_PATH").
  static ToolRun run(const std::string& args, const std::string& env = "") {
    const std::string out = dir_ + "/stdout.txt", err = dir_ + "/stderr.txt";
    // ROS_PACKAGE_PATH lets the tool find config/default.yaml like a sourced
    // devel space would; ROS_HOME keeps rospack's cache out of $HOME.
    const std::string cmd = "ROS_PACKAGE_PATH=" + quote(kSourceDir) + " ROS_HOME=" + quote(dir_) +
                            " " + env + " timeout 60 " + quote(kBin) + " " + args + " >" +
                            quote(out) + " 2>" + quote(err) + " </dev/null";
    ToolRun r;
    const int rc = std::system(cmd.c_str());
    r.status = WIFEXITED(rc) ? WEXITSTATUS(rc) : 128 + WTERMSIG(rc);
    r.out = readFile(out);
    r.err = readFile(err);
    return r;
  }

  static std::string path(const std::string& name) { return dir_ + "/" + name; }

  static std::string writeText(const std::string& name, const std::string& text) {
    std::ofstream(path(name)) << text;
    return path(name);
  }

  static std::string makeBag(const std::string& name, const BagSpec& spec) {
    writeBag(path(name), spec);
    return path(name);
  }

  static std::vector<std::vector<std::string>> readCsv(const std::string& file) {
    std::vector<std::vector<std::string>> rows;
    std::stringstream ss(readFile(file));
    std::string line;
    while (std::getline(ss, line)) {
      std::vector<std::string> f;
      std::stringstream ls(line);
      std::string cell;
      while (std::getline(ls, cell, ',')) f.push_back(cell);
      if (!line.empty() && line.back() == ',') f.emplace_back();
      rows.push_back(f);
    }
    return rows;
  }

  static std::string dir_, good_;
};
std::string TrackBag::dir_, TrackBag::good_;

constexpr const char* kHeaderCameraMotion = "stamp,model,h00,h01,h02,h10,h11,h12,h20,h21,h22,features,inliers";

}  // namespace
}  // namespace imt
