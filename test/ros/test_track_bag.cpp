// End-to-end tests of the track_bag tool: small bags written here with the
// rosbag C++ API, the built binary run on them, its exit status, stderr and
// output files checked. Every run is wrapped in `timeout 60`, so a hang fails
// (status 124) instead of blocking the suite.
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
  int corrupt_frame = -1;                // this frame's compressed data is garbage
  int crc_warning_frame = -1;            // this frame's PNG has a tEXt chunk with a bad CRC
  int bad_frame = -1;                    // this frame's encoding is `bad_encoding`
  std::string bad_encoding;
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
      bag.write("/cam/camera_info", bag_time, info);
    }
    const cv::Mat gray = frameImage(i, s.width, s.height);
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
      bag.write(s.image_topic, bag_time, rawImage(gray, enc, h));
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

const char* kHeaderCameraMotion = "stamp,model,h00,h01,h02,h10,h11,h12,h20,h21,h22,features,inliers";

// --- good runs ----------------------------------------------------------------

// Every supported image kind gives one camera_motion row per frame, stamped
// with the frame's header stamp, and the other CSVs with their headers.
struct ImageKind {
  const char* name;
  const char* encoding;
  const char* compressed;
};

void PrintTo(const ImageKind& k, std::ostream* os) { *os << k.name; }

class TrackBagImageKinds : public TrackBag, public ::testing::WithParamInterface<ImageKind> {};

TEST_P(TrackBagImageKinds, WritesOneCameraMotionRowPerFrame) {
  BagSpec spec;
  spec.encoding = GetParam().encoding;
  spec.compressed = GetParam().compressed;
  const std::string bag = makeBag(std::string(GetParam().name) + ".bag", spec);
  const std::string out = path(std::string("out_") + GetParam().name);
  const ToolRun r = run("--bag " + quote(bag) + " --out-dir " + quote(out) + " --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");  // nothing to warn about in a clean bag without --init

  const auto rows = readCsv(out + "/camera_motion.csv");
  ASSERT_EQ(rows.size(), 1u + spec.frames);
  EXPECT_EQ(readFile(out + "/camera_motion.csv").substr(0, std::string(kHeaderCameraMotion).size() + 1),
            std::string(kHeaderCameraMotion) + "\n");
  for (int i = 0; i < spec.frames; ++i) {
    const auto& row = rows[1 + i];
    ASSERT_EQ(row.size(), 13u) << "row " << i;
    // Stamps are the header stamps, written with 9 decimals (spec: >= 6).
    EXPECT_EQ(row[0], formatFixed(ros::Time(frameStamp(spec, i)).toSec(), 9));
    const std::string model = row[1];
    EXPECT_TRUE(model == "invalid" || model == "translation" || model == "similarity" ||
                model == "homography")
        << model;
    EXPECT_EQ(row[10], "1") << "H(2,2) = 1";
    if (i == 0) {
      // First frame: invalid with the identity (spec).
      EXPECT_EQ(model, "invalid");
      EXPECT_EQ(std::vector<std::string>(row.begin() + 2, row.begin() + 11),
                (std::vector<std::string>{"1", "0", "0", "0", "1", "0", "0", "0", "1"}));
    } else if (model != "invalid") {
      // The texture moves 1 px left per frame. 0.25 px: sub-pixel LK on a
      // blurred random texture (JPEG included) is far better than that; a
      // sign or axis error would be off by >= 1 px.
      EXPECT_NEAR(std::stod(row[4]), -1.0, 0.25) << "frame " << i;
      EXPECT_NEAR(std::stod(row[7]), 0.0, 0.25) << "frame " << i;
    }
  }
  EXPECT_EQ(readFile(out + "/regions.csv"), "stamp,id,x,y,width,height,status,confidence\n");
  EXPECT_EQ(readFile(out + "/planar_targets.csv"),
            "stamp,id,x0,y0,x1,y1,x2,y2,x3,y3,tx,ty,tz,qx,qy,qz,qw,status\n");
  EXPECT_EQ(readFile(out + "/anchors.csv"), "stamp,id,u,v,tx,ty,tz,qx,qy,qz,qw,status\n");

  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["frames"], spec.frames);
  EXPECT_GT(j["seconds"].get<double>(), 0.0);
  EXPECT_GT(j["frames_per_second"].get<double>(), 0.0);
  EXPECT_TRUE(j["stages"].contains("motion_analysis"));
  EXPECT_TRUE(j["stages"].contains("decode"));
  EXPECT_EQ(j["image_topic"], spec.compressed.empty() ? "/cam/image_raw" : "/cam/image_raw/compressed");
  // The sibling camera_info is found for the compressed topic too.
  EXPECT_EQ(j["camera_info_topic"], "/cam/camera_info");
  EXPECT_EQ(j["intrinsics"]["source"], "camera_info");
  EXPECT_DOUBLE_EQ(j["intrinsics"]["fx"].get<double>(), 100.0);
  // CameraInfo's principal point (OpenCV pixel centres) + 0.5 = ours: the centre.
  EXPECT_DOUBLE_EQ(j["intrinsics"]["cx"].get<double>(), spec.width / 2.0);
  EXPECT_EQ(j["imu_samples"], 7 * spec.frames);
}

INSTANTIATE_TEST_SUITE_P(Each, TrackBagImageKinds,
                         ::testing::Values(ImageKind{"mono8", "mono8", ""},
                                           ImageKind{"mono16", "mono16", ""},
                                           ImageKind{"bgr8", "bgr8", ""},
                                           ImageKind{"rgba8", "rgba8", ""},
                                           ImageKind{"png", "mono8", "png"},
                                           ImageKind{"jpeg", "mono8", "jpeg"}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST_F(TrackBag, InitEntriesAtAnyFrameOutBagAndRotationFromTfStatic) {
  // Entries given at a middle frame (stamp copied with 6 decimals, as from a
  // CSV) and at the last one.
  const std::string init = writeText("init_ok.yaml",
                                     "regions:\n"
                                     "  - {id: 1, stamp: 1000.333333, box: [10, 10, 40, 30]}\n"
                                     "planar_targets:\n"
                                     "  - {id: 1, stamp: 1000.6333333333, corners: [[10, 10], [50, 12], [48, 40], [12, 38]], size: [0.2, 0.15]}\n"
                                     "anchors:\n"
                                     "  - {id: 2, stamp: 1000.1, point: [80, 60]}\n");
  const std::string out = path("out_init");
  const std::string out_bag = path("out_init.bag");
  const ToolRun r = run("--bag " + quote(good_) + " --init " + quote(init) + " --out-dir " +
                    quote(out) + " --out-bag " + quote(out_bag));
  ASSERT_EQ(r.status, 0) << r.err;
  // Nothing to say; no progress bar (stderr is a file, not a terminal).
  EXPECT_EQ(r.errLines(), std::vector<std::string>{}) << r.err;
  // The anchor (given at frame 3) has a row for every frame; at its own frame
  // it sits at the tapped pixel, 1 m (the default depth) along its ray.
  const auto anchors = readCsv(out + "/anchors.csv");
  ASSERT_EQ(anchors.size(), 1u + 20);
  EXPECT_EQ(anchors[1 + 3][1], "2");
  EXPECT_NEAR(std::stod(anchors[1 + 3][2]), 80.0, 1e-6);
  EXPECT_NEAR(std::stod(anchors[1 + 3][3]), 60.0, 1e-6);
  const double tx = std::stod(anchors[1 + 3][4]), ty = std::stod(anchors[1 + 3][5]), tz = std::stod(anchors[1 + 3][6]);
  EXPECT_NEAR(std::sqrt(tx * tx + ty * ty + tz * tz), 1.0, 1e-6);
  // The region (given at frame 10) and the planar target (given at the last
  // frame) have a row for every frame of the bag, backwards and forwards.
  const auto regions = readCsv(out + "/regions.csv");
  ASSERT_EQ(regions.size(), 1u + 20);
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(regions[1 + i][0], formatFixed(ros::Time(1000.0 + i / 30.0).toSec(), 9)) << i;
    EXPECT_EQ(regions[1 + i][1], "1");
  }
  EXPECT_EQ(regions[1 + 10][2], "10");  // the given box at its own frame
  EXPECT_EQ(regions[1 + 10][5], "30");
  const auto targets = readCsv(out + "/planar_targets.csv");
  ASSERT_EQ(targets.size(), 1u + 20);
  EXPECT_EQ(targets[20][2], "10");  // corner x0 at the given (last) frame

  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["init_entries"]["regions"], 1);
  // R_cam_imu = Rz(90 deg) from /tf_static (cam_optical -> imu_link); 1e-9:
  // only float rounding of sin/cos(pi/4) and the quaternion -> matrix.
  const double expected[3][3] = {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}};
  ASSERT_TRUE(j["R_cam_imu"].is_array()) << j.dump();
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(j["R_cam_imu"][a][b].get<double>(), expected[a][b], 1e-9) << a << "," << b;

  // The output bag holds one /motion_data per frame with the image's header.
  rosbag::Bag bag(out_bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/motion_data"));
  std::vector<double> stamps;
  for (const rosbag::MessageInstance& m : view) {
    const auto md = m.instantiate<instant_motion_tracking::MotionData>();
    ASSERT_TRUE(md);
    EXPECT_EQ(md->header.frame_id, "cam_optical");
    EXPECT_EQ(md->width, 160u);
    stamps.push_back(md->header.stamp.toSec());
  }
  ASSERT_EQ(stamps.size(), 20u);
  for (int i = 0; i < 20; ++i) EXPECT_NEAR(stamps[i], 1000.0 + i / 30.0, 1e-9);

  // ...one /anchors per frame, as anchors.csv says (1e-6: the CSV's decimals),
  // and each frame's /tf carries anchor_2 (and planar_target_1) under the image frame.
  int i = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery("/anchors"))) {
    const auto a = m.instantiate<instant_motion_tracking::AnchorArray>();
    ASSERT_TRUE(a);
    ASSERT_LT(i, 20);
    EXPECT_EQ(a->header.frame_id, "cam_optical");
    EXPECT_NEAR(a->header.stamp.toSec(), 1000.0 + i / 30.0, 1e-9);
    ASSERT_EQ(a->anchors.size(), 1u);
    EXPECT_EQ(a->anchors[0].id, 2u);
    EXPECT_EQ(a->anchors[0].status, anchors[1 + i][11]);
    if (anchors[1 + i][11] != "lost") {
      EXPECT_NEAR(a->anchors[0].u, std::stod(anchors[1 + i][2]), 1e-3);
      EXPECT_NEAR(a->anchors[0].pose.position.z, std::stod(anchors[1 + i][6]), 1e-6);
    }
    ++i;
  }
  EXPECT_EQ(i, 20);
  int anchor_tf = 0, target_tf = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery("/tf"))) {
    const auto tf = m.instantiate<tf2_msgs::TFMessage>();
    ASSERT_TRUE(tf);
    for (const auto& t : tf->transforms) {
      EXPECT_EQ(t.header.frame_id, "cam_optical");
      anchor_tf += t.child_frame_id == "anchor_2";
      target_tf += t.child_frame_id == "planar_target_1";
    }
  }
  int anchor_rows_with_pose = 0;
  for (int k = 0; k < 20; ++k) anchor_rows_with_pose += anchors[1 + k][11] != "lost";
  EXPECT_EQ(anchor_tf, anchor_rows_with_pose);
  EXPECT_GT(anchor_tf, 0);
  EXPECT_GT(target_tf, 0);
}

TEST_F(TrackBag, StartAndEndSelectAWindowOfTheBag) {
  // Bag times 1000 + i/30: from 0.2 s to 0.4 s after the first message are
  // frames 6..12 (0.2 = 6/30, 0.4 = 12/30; rosbag's window is inclusive).
  const std::string out = path("out_window");
  const ToolRun r = run("--bag " + quote(good_) + " --out-dir " + quote(out) +
                    " --start 0.19 --end=0.41 --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto rows = readCsv(out + "/camera_motion.csv");
  ASSERT_EQ(rows.size(), 1u + 7);
  EXPECT_EQ(rows[1][0], formatFixed(ros::Time(1000.0 + 6 / 30.0).toSec(), 9));
  EXPECT_EQ(rows[1][1], "invalid");  // the window's first frame is a first frame
  EXPECT_EQ(rows[7][0], formatFixed(ros::Time(1000.0 + 12 / 30.0).toSec(), 9));

  // An init stamp outside the window is outside what is processed.
  const std::string init = writeText("init_window.yaml",
                                     "regions:\n  - {id: 1, stamp: 1000.0, box: [1, 1, 5, 5]}\n");
  const ToolRun bad = run("--bag " + quote(good_) + " --init " + quote(init) + " --out-dir " +
                      quote(out) + " --start 0.19 --end 0.41");
  EXPECT_EQ(bad.status, 1);
  EXPECT_EQ(bad.err, "track_bag: error: " + init +
                         ": regions[0] (id 1): stamp 1000 is outside the part of the bag given "
                         "by --start/--end (frames 1000.200000 .. 1000.400000)\n");
}

TEST_F(TrackBag, StampsGoingBackwardsOrRepeatingResetOnceEachAndAreStillWritten) {
  BagSpec spec;
  spec.frames = 12;
  for (int i = 0; i < spec.frames; ++i) spec.stamps.push_back(1000.0 + i / 30.0);
  spec.stamps[5] = spec.stamps[4];          // repeated
  spec.stamps[9] = spec.stamps[8] - 1.0;    // backwards
  const std::string out = path("out_backwards");
  const ToolRun r = run("--bag " + quote(makeBag("backwards.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  // Frames 5 and 9 reset the analysis (and frame 10, after the backwards jump,
  // is forwards again). One warning line per reason with its count; the
  // counts add up to the 2 resets.
  int resets = 0;
  for (const std::string& line : r.errLines()) {
    const std::string prefix = "track_bag: warning: motion analysis reset ";
    ASSERT_EQ(line.rfind(prefix, 0), 0u) << line;
    resets += std::stoi(line.substr(prefix.size()));
  }
  EXPECT_EQ(resets, 2) << r.err;
  const auto rows = readCsv(out + "/camera_motion.csv");
  ASSERT_EQ(rows.size(), 1u + spec.frames);
  EXPECT_EQ(rows[1 + 9][0], formatFixed(ros::Time(spec.stamps[9]).toSec(), 9));
  EXPECT_EQ(rows[1 + 5][1], "invalid");
  EXPECT_EQ(rows[1 + 9][1], "invalid");
}

TEST_F(TrackBag, FrameSizeOtherThanCameraInfoWarnsOnceAndUsesTheFieldOfView) {
  BagSpec spec;
  spec.info_width = 320;
  spec.info_height = 240;
  const std::string out = path("out_size");
  const ToolRun r = run("--bag " + quote(makeBag("size.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(r.errLines().size(), 1u) << r.err;
  EXPECT_EQ(r.errLines()[0],
            "track_bag: warning: image size 160x120 (first at frame 0) differs from "
            "/cam/camera_info's 320x240; intrinsics from default_hfov_deg 60 deg for it");
  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["intrinsics"]["source"], "field_of_view");
  // fx = (w / 2) / tan(hfov / 2) = 80 / tan(30 deg); 1e-9: closed form.
  EXPECT_NEAR(j["intrinsics"]["fx"].get<double>(), 80.0 / std::tan(M_PI / 6), 1e-9);
}

TEST_F(TrackBag, NoCameraInfoNoTfAndNanImuAreNotedOnce) {
  BagSpec spec;
  spec.camera_info = false;
  spec.tf_static = false;
  spec.imu_nan = 3;
  const std::string out = path("out_noinfo");
  const ToolRun r = run("--bag " + quote(makeBag("noinfo.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(),
            (std::vector<std::string>{
                "track_bag: note: no camera_info topic; intrinsics from default_hfov_deg 60 deg",
                "track_bag: warning: dropped 3 IMU sample(s) with NaN/Inf values (first at stamp 1000.000000)",
                "track_bag: note: IMU-to-camera rotation unknown: no transform between 'cam_optical' and "
                "'imu_link' in the bag (it has no /tf_static or /tf)"}));
  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["imu_samples"], 7 * spec.frames - 3);
  EXPECT_EQ(j["imu_dropped"], 3);
  EXPECT_TRUE(j["R_cam_imu"].is_null());
  EXPECT_TRUE(j["camera_info_topic"].is_null());
  EXPECT_EQ(j["intrinsics"]["source"], "field_of_view");
}

TEST_F(TrackBag, AnchorsWithoutImuAreTranslationOnly) {
  BagSpec spec;
  spec.imu = false;
  const std::string init = writeText("init_anchor.yaml", "anchors:\n  - {id: 4, stamp: 1000.0, point: [80, 60], depth: 2.0}\n");
  const std::string out = path("out_noimu");
  const ToolRun r = run("--bag " + quote(makeBag("noimu.bag", spec)) + " --init " + quote(init) +
                        " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(), (std::vector<std::string>{
                              "track_bag: warning: no usable IMU in the bag: anchors are translation-only (status no_imu)"}));
  const auto rows = readCsv(out + "/anchors.csv");
  ASSERT_EQ(rows.size(), 1u + spec.frames);
  for (size_t i = 1; i < rows.size(); ++i) EXPECT_EQ(rows[i][11], "no_imu") << i;
  // At its frame: the tapped pixel, 2 m along its ray (the given depth).
  const double tx = std::stod(rows[1][4]), ty = std::stod(rows[1][5]), tz = std::stod(rows[1][6]);
  EXPECT_NEAR(std::sqrt(tx * tx + ty * ty + tz * tz), 2.0, 1e-6);
}

TEST_F(TrackBag, DecoderWarningsBecomeOneCountedWarning) {
  // libpng decodes a PNG whose ancillary tEXt chunk has a bad CRC and prints
  // "libpng warning: tEXt: CRC error" on stderr; the tool captures that and
  // reports it once, counted, after the run.
  BagSpec spec;
  spec.compressed = "png";
  spec.crc_warning_frame = 4;
  const std::string out = path("out_png_warning");
  const ToolRun r = run("--bag " + quote(makeBag("png_warning.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(),
            std::vector<std::string>{
                "track_bag: warning: the image decoder complained about 1 compressed frame(s) "
                "(first: frame 4 (stamp 1000.133333) on /cam/image_raw/compressed: libpng warning: "
                "tEXt: CRC error)"});
  EXPECT_EQ(readCsv(out + "/camera_motion.csv").size(), 1u + spec.frames);
}

TEST_F(TrackBag, ChoosesTheImageTopicGivenWhenThereAreSeveral) {
  BagSpec spec;
  spec.extra = [](rosbag::Bag& bag) {
    sensor_msgs::Image m = rawImage(frameImage(0, 16, 12), "mono8", std_msgs::Header());
    m.header.stamp = ros::Time(2000.0);
    bag.write("/other/image", ros::Time(1000.0), m);
  };
  const std::string bag = makeBag("two_topics_ok.bag", spec);
  const std::string out = path("out_two");
  // Without the leading slash too: matched to the bag's absolute name.
  const ToolRun r = run("--bag " + quote(bag) + " --out-dir " + quote(out) +
                    " --image-topic other/image --camera-info-topic /cam/camera_info");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto rows = readCsv(out + "/camera_motion.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1][0], "2000.000000000");
  // The given camera_info (160x120) does not match the 16x12 frame: warned.
  EXPECT_NE(r.err.find("differs from /cam/camera_info's 160x120"), std::string::npos) << r.err;
}

TEST_F(TrackBag, HelpGoesToStdoutWithStatusZero) {
  const ToolRun r = run("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.err, "");
  for (const char* opt : {"--bag", "--init", "--out-dir", "--image-topic", "--camera-info-topic",
                          "--imu-topic", "--config", "--out-bag", "--start", "--end", "--quiet"})
    EXPECT_NE(r.out.find(opt), std::string::npos) << opt;
}

TEST_F(TrackBag, ProgressBarOnATerminalOnlyAndNotWithQuiet) {
  // `script` gives the tool a pseudo-terminal for stdout and stderr.
  if (std::system("command -v script >/dev/null 2>&1") != 0) GTEST_SKIP() << "no script(1)";
  const std::string out = path("out_tty");
  const std::string log = path("tty.log");
  auto onTty = [&](const std::string& extra) {
    const std::string inner = "ROS_PACKAGE_PATH=" + kSourceDir + " timeout 60 " + kBin + " --bag " +
                              good_ + " --out-dir " + out + extra;
    const std::string cmd = "script -qec " + quote(inner) + " " + quote(log) + " >/dev/null 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0);
    return readFile(log);
  };
  const std::string shown = onTty("");
  EXPECT_NE(shown.find("20/20 frames"), std::string::npos) << shown;
  const std::string quiet = onTty(" --quiet");
  EXPECT_EQ(quiet.find("frames"), std::string::npos) << quiet;
}

// --- bad inputs: non-zero status, one line on stderr naming the problem -------

struct BadCase {
  const char* name;
  // Returns the arguments; may write files first.
  std::function<std::string(const std::string& dir, const std::string& good)> args;
  std::string message;  // expected in the error line (after "track_bag: error: ")
  int status = 1;
  std::string env;
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

class TrackBagBadInput : public TrackBag, public ::testing::WithParamInterface<BadCase> {};

TEST_P(TrackBagBadInput, FailsWithOneLineNamingTheProblem) {
  const BadCase& c = GetParam();
  const ToolRun r = run(c.args(dir_, good_), c.env);
  ASSERT_NE(r.status, 124) << "timed out (hang)";
  EXPECT_EQ(r.status, c.status) << r.err;
  ASSERT_EQ(r.errLines().size(), 1u) << r.err;
  const std::string line = r.errLines()[0];
  EXPECT_EQ(line.rfind("track_bag: error: ", 0), 0u) << line;
  EXPECT_NE(line.find(c.message), std::string::npos) << "got:      " << line << "\nexpected: " << c.message;
  EXPECT_EQ(r.out, "");
}

std::string q(const std::string& s) { return quote(s); }

std::string withBag(const std::string& dir, const std::string& name, const BagSpec& spec,
                    const std::string& extra = "") {
  writeBag(dir + "/" + name, spec);
  return "--bag " + q(dir + "/" + name) + " --out-dir " + q(dir + "/out_bad") + " " + extra;
}

std::string withInit(const std::string& dir, const std::string& good, const std::string& yaml) {
  std::ofstream(dir + "/bad_init.yaml") << yaml;
  return "--bag " + q(good) + " --init " + q(dir + "/bad_init.yaml") + " --out-dir " +
         q(dir + "/out_bad");
}

BagSpec rawWithEncoding(const std::string& e) {
  BagSpec s;
  s.bad_frame = 3;
  s.bad_encoding = e;
  return s;
}

std::vector<BadCase> badCases() {
  using D = const std::string&;
  std::vector<BadCase> v;
  auto add = [&](const char* name, std::function<std::string(D, D)> args, std::string message,
                 int status = 1, std::string env = "") {
    v.push_back({name, std::move(args), std::move(message), status, std::move(env)});
  };
  // The bag itself.
  add("nonexistent_bag", [](D d, D) { return "--bag " + q(d + "/nope.bag") + " --out-dir " + q(d + "/o"); },
      "cannot open bag '/", 1);
  add("truncated_bag", [](D d, D good) {
        const std::string bytes = readFile(good);
        std::ofstream(d + "/truncated.bag", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
        return "--bag " + q(d + "/truncated.bag") + " --out-dir " + q(d + "/o");
      },
      "truncated.bag' (not a rosbag, or truncated)");
  add("text_file_named_bag", [](D d, D) {
        std::ofstream(d + "/text.bag") << "hello, I am not a bag\n";
        return "--bag " + q(d + "/text.bag") + " --out-dir " + q(d + "/o");
      },
      "text.bag' (not a rosbag, or truncated): Error reading version line");
  add("unindexed_bag", [](D d, D good) {
        // A recording that was never closed: index_pos still 0 in the header.
        std::string bytes = readFile(good);
        const size_t at = bytes.find("index_pos=");
        if (at != std::string::npos) bytes.replace(at + 10, 8, std::string(8, '\0'));
        std::ofstream(d + "/unindexed.bag", std::ios::binary) << bytes;
        return "--bag " + q(d + "/unindexed.bag") + " --out-dir " + q(d + "/o");
      },
      "unindexed.bag' is not indexed");
  add("directory_as_bag", [](D d, D) { return "--bag " + q(d) + " --out-dir " + q(d + "/o"); },
      "not a regular file");
  // Topics.
  add("no_image_topic", [](D d, D) {
        BagSpec s;
        s.frames = 0;  // IMU-less, image-less: only /tf_static
        return withBag(d, "no_image.bag", s);
      },
      "no_image.bag' has no sensor_msgs/Image or sensor_msgs/CompressedImage topic");
  add("two_image_topics", [](D d, D) {
        BagSpec s;
        s.extra = [](rosbag::Bag& bag) {
          bag.write("/cam2/image_raw", ros::Time(1000.0),
                    rawImage(frameImage(0, 16, 12), "mono8", std_msgs::Header()));
        };
        return withBag(d, "two_images.bag", s);
      },
      "has several image topics (/cam/image_raw, /cam2/image_raw): choose one with --image-topic");
  add("image_topic_not_in_bag", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --image-topic /nope";
      },
      "image topic '/nope' is not in the bag (image topics: /cam/image_raw)");
  add("image_topic_of_other_type", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --image-topic /imu/data";
      },
      "topic '/imu/data' is a sensor_msgs/Imu, not a sensor_msgs/Image or sensor_msgs/CompressedImage");
  add("camera_info_topic_not_in_bag", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --camera-info-topic /x/camera_info";
      },
      "camera_info topic '/x/camera_info' is not in the bag");
  add("imu_topic_not_in_bag", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --imu-topic /imu2";
      },
      "IMU topic '/imu2' is not in the bag (Imu topics: /imu/data)");
  add("two_imu_topics", [](D d, D) {
        BagSpec s;
        s.extra = [](rosbag::Bag& bag) {
          sensor_msgs::Imu m;
          bag.write("/imu2", ros::Time(1000.0), m);
        };
        return withBag(d, "two_imus.bag", s);
      },
      "has several sensor_msgs/Imu topics (/imu/data, /imu2): choose one with --imu-topic");
  // Images.
  add("encoding_32FC1", [](D d, D) { return withBag(d, "f32.bag", rawWithEncoding("32FC1")); },
      "frame 3 (stamp 1000.100000) on /cam/image_raw: unsupported image encoding '32FC1'");
  add("encoding_yuv422", [](D d, D) { return withBag(d, "yuv.bag", rawWithEncoding("yuv422")); },
      "frame 3 (stamp 1000.100000) on /cam/image_raw: unsupported image encoding 'yuv422'");
  add("corrupt_compressed_image", [](D d, D) {
        BagSpec s;
        s.compressed = "png";
        s.corrupt_frame = 2;
        return withBag(d, "corrupt.bag", s);
      },
      "frame 2 (stamp 1000.066667) on /cam/image_raw/compressed: cannot decode the compressed image (format 'mono8; png compressed mono8'");
  add("image_data_shorter_than_claimed", [](D d, D) {
        BagSpec s;
        s.extra = [](rosbag::Bag& bag) {
          sensor_msgs::Image m = rawImage(frameImage(0, 160, 120), "mono8", std_msgs::Header());
          m.header.stamp = ros::Time(1001.0);
          m.height = 240;  // claims twice the rows it has
          bag.write("/cam/image_raw", ros::Time(1001.0), m);
        };
        return withBag(d, "short.bag", s);
      },
      "frame 20 (stamp 1001.000000) on /cam/image_raw: image data has 19200 bytes, step x height is 38400");
  // INIT.yaml.
  add("init_missing_file", [](D d, D good) {
        return "--bag " + q(good) + " --init " + q(d + "/nope.yaml") + " --out-dir " + q(d + "/o");
      },
      "nope.yaml: cannot open the init file");
  add("init_invalid_yaml", [](D d, D g) { return withInit(d, g, "regions: [\n  - id: 1\n"); },
      "bad_init.yaml: invalid YAML at line 2, column 3");
  add("init_missing_field", [](D d, D g) { return withInit(d, g, "regions:\n  - {id: 7, stamp: 1000}\n"); },
      "bad_init.yaml: regions[0] (id 7): missing field 'box'");
  add("init_wrong_length", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 7, stamp: 1000, box: [1, 2, 3]}\n");
      },
      "bad_init.yaml: regions[0] (id 7): box must have 4 numbers, got 3");
  add("init_non_positive_size", [](D d, D g) {
        return withInit(d, g, "planar_targets:\n  - {id: 1, stamp: 1000, corners: [[0, 0], [9, 0], [9, 9], [0, 9]], size: [0.2, -1]}\n");
      },
      "bad_init.yaml: planar_targets[0] (id 1): size must be positive, got 0.2 x -1 m");
  add("init_non_positive_depth", [](D d, D g) {
        return withInit(d, g, "anchors:\n  - {id: 1, stamp: 1000, point: [5, 5], depth: -2}\n");
      },
      "bad_init.yaml: anchors[0] (id 1): depth must be positive, got -2");
  add("init_nan", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 7, stamp: 1000, box: [1, .nan, 3, 4]}\n");
      },
      "bad_init.yaml: regions[0] (id 7): box[1] must be finite, got '.nan'");
  add("init_duplicate_id", [](D d, D g) {
        return withInit(d, g, "anchors:\n  - {id: 1, stamp: 1000, point: [5, 5]}\n  - {id: 1, stamp: 1000.1, point: [6, 6]}\n");
      },
      "bad_init.yaml: anchors[1] (id 1): duplicate id (also anchors[0])");
  add("init_bad_id", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 2.5, stamp: 1000, box: [1, 2, 3, 4]}\n");
      },
      "bad_init.yaml: regions[0]: id must be a positive integer, got '2.5'");
  add("init_unknown_key", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 7, stamp: 1000, bbox: [1, 2, 3, 4]}\n");
      },
      "bad_init.yaml: regions[0] (id 7): unknown key 'bbox' (expected id, stamp, box)");
  add("init_unknown_list", [](D d, D g) { return withInit(d, g, "targets: []\n"); },
      "bad_init.yaml: unknown list 'targets' (expected regions, planar_targets, anchors)");
  add("init_empty", [](D d, D g) { return withInit(d, g, ""); },
      "bad_init.yaml: empty (expected a mapping with regions, planar_targets and/or anchors)");
  add("init_stamp_outside_bag", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 7, stamp: 1234.5, box: [1, 2, 3, 4]}\n");
      },
      "bad_init.yaml: regions[0] (id 7): stamp 1234.5 is outside the bag (frames 1000.000000 .. 1000.633333)");
  // Options and configuration.
  add("missing_out_dir", [](D, D good) { return "--bag " + q(good); }, "missing --out-dir (see --help)", 2);
  add("missing_bag", [](D d, D) { return "--out-dir " + q(d + "/o"); }, "missing --bag (see --help)", 2);
  add("unknown_option", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --frobnicate 3";
      },
      "unknown option '--frobnicate' (see --help)", 2);
  add("stray_argument", [](D d, D good) { return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " extra"; },
      "unexpected argument 'extra'", 2);
  add("option_without_value", [](D, D good) { return "--out-dir /tmp/x --bag"; },
      "option --bag needs a value", 2);
  add("option_twice", [](D d, D good) {
        return "--bag " + q(good) + " --bag " + q(good) + " --out-dir " + q(d + "/o");
      },
      "option --bag given twice", 2);
  add("bad_start", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --start soon";
      },
      "--start: expected a non-negative number of seconds, got 'soon'", 2);
  add("end_before_start", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --start 2 --end 1";
      },
      "--end 1 must be after --start 2", 2);
  add("start_past_the_end", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --start 5";
      },
      "--start 5.000 s is past the end of bag '");
  add("window_without_frames", [](D d, D good) {
        // Frames at 0.6 s and 0.6333 s after the start: none in 0.61 .. 0.62.
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --start 0.61 --end 0.62";
      },
      "no image messages on /cam/image_raw between 0.610 s and 0.620 s after the bag's start");
  add("bad_config", [](D d, D good) {
        std::ofstream(d + "/bad_config.yaml") << "nonsense: 1\n";
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --config " + q(d + "/bad_config.yaml");
      },
      "bad_config.yaml: unknown parameter 'nonsense'");
  add("config_missing", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --config " + q(d + "/nope_config.yaml");
      },
      "nope_config.yaml: cannot open the config file");
  add("default_config_not_found", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o");
      },
      "cannot find config/default.yaml of package instant_motion_tracking (source the workspace's "
      "setup.bash, or pass --config FILE)",
      1, "env -u ROS_PACKAGE_PATH");
  add("out_dir_is_a_file", [](D d, D good) {
        std::ofstream(d + "/a_file") << "x";
        return "--bag " + q(good) + " --out-dir " + q(d + "/a_file");
      },
      "cannot create --out-dir '");
  add("out_bag_unwritable", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --out-bag " + q(d + "/no/such/dir/out.bag");
      },
      "cannot create --out-bag '");
  add("out_bag_is_the_input", [](D d, D good) {
        fs::copy_file(good, d + "/copy.bag", fs::copy_options::overwrite_existing);
        return "--bag " + q(d + "/copy.bag") + " --out-dir " + q(d + "/o") + " --out-bag " + q(d + "/./copy.bag");
      },
      "/./copy.bag' is the input bag");
  return v;
}

INSTANTIATE_TEST_SUITE_P(Each, TrackBagBadInput, ::testing::ValuesIn(badCases()),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace imt
