// make_scene: renders a seeded synthetic scene (sim/scene.h) into a rosbag
// with camera images, camera_info, an IMU stream and /tf_static, plus its
// ground truth as JSON and, optionally, an INIT.yaml for track_bag.
//
//   rosrun instant_motion_tracking make_scene --preset cards --out cards.bag
//       [--truth cards.json] [--init cards_init.yaml] [--duration 10] [--seed 1] ...
// Run with --help for every option.
#include "instant_motion_tracking/sim/scene.h"
#include "instant_motion_tracking/sim/scene_files.h"
#include "instant_motion_tracking/ros/conversions.h"

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/TransformStamped.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <rosbag/bag.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2_msgs/TFMessage.h>

#include <cstdio>
#include <cstdlib>
#include <future>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <unistd.h>

namespace {

const char* kUsage = R"(usage: make_scene --out FILE.bag [options]
Renders a seeded synthetic scene into a rosbag (images, camera_info, IMU, /tf_static).
  --preset NAME        scene preset (default wall_pan); --list-presets prints them
  --out FILE           output bag (required)
  --truth FILE         also write the per-frame ground truth (JSON)
  --init FILE          also write an INIT.yaml with the scene's items for track_bag
  --init-frame N       INIT.yaml gives the items at this frame (default 0); each region at the
                       first frame from there on where it is wholly in view and unoccluded
  --duration S         seconds (default: the preset's)
  --fps F              frames per second (default: the preset's)
  --width W --height H image size in pixels
  --seed N             random seed (default 1)
  --start-time S       stamp of the first frame (default 1000.0)
  --noise SIGMA        sensor noise, grey levels
  --exposure S         motion blur exposure time (0 = off)
  --supersample N      anti-aliasing samples per pixel side
  --distortion M:K1,.. lens distortion (camera_info's model and D), e.g. plumb_bob:-0.28,0.07
                       (models plumb_bob, rational_polynomial, equidistant; default none)
  --texture FILE       texture image (repeatable; default procedural)
  --target-texture FILE  picture painted on the planar target(s) (default procedural); --init
                       then gives them as image_targets with this picture
  --encoding E         mono8 (default), mono16, bgr8, rgb8, bgra8, rgba8
  --compressed FMT     write sensor_msgs/CompressedImage (png or jpeg) instead of raw
  --no-imu             do not write the IMU topic
  --image-topic T      default /camera/image_raw (camera_info is its sibling)
  --imu-topic T        default /imu/data
  --frame-id F         camera optical frame (default camera_optical_frame)
  --imu-frame-id F     IMU frame (default imu_link)
  --quiet              no progress output
)";

[[noreturn]] void fail(const std::string& msg) {
  std::cerr << "make_scene: " << msg << std::endl;
  std::exit(2);
}

double toDouble(const std::string& opt, const std::string& v) {
  char* end = nullptr;
  const double d = std::strtod(v.c_str(), &end);
  if (v.empty() || *end != '\0' || !std::isfinite(d)) fail(opt + ": expected a number, got '" + v + "'");
  return d;
}

long toInt(const std::string& opt, const std::string& v) {
  char* end = nullptr;
  const long i = std::strtol(v.c_str(), &end, 10);
  if (v.empty() || *end != '\0') fail(opt + ": expected an integer, got '" + v + "'");
  return i;
}

std::string siblingTopic(const std::string& image_topic, const std::string& name) {
  const auto slash = image_topic.rfind('/');
  return (slash == std::string::npos ? std::string() : image_topic.substr(0, slash + 1)) + name;
}

// Gray render -> the requested raw encoding.
cv::Mat encode(const cv::Mat& gray, const std::string& encoding) {
  cv::Mat out;
  if (encoding == "mono8") return gray;
  if (encoding == "mono16") {
    gray.convertTo(out, CV_16U, 257.0);  // 255 -> 65535, and >> 8 gives the grey back
  } else if (encoding == "bgr8" || encoding == "rgb8") {
    cv::cvtColor(gray, out, cv::COLOR_GRAY2BGR);
  } else {
    cv::cvtColor(gray, out, cv::COLOR_GRAY2BGRA);
  }
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  std::map<std::string, std::string> args;
  std::vector<std::string> textures;
  const std::map<std::string, bool> known = {
      {"--preset", true},      {"--out", true},         {"--truth", true},
      {"--init", true},        {"--init-frame", true},  {"--duration", true},
      {"--fps", true},         {"--width", true},       {"--height", true},
      {"--seed", true},        {"--start-time", true},  {"--noise", true},
      {"--exposure", true},    {"--supersample", true}, {"--texture", true},
      {"--target-texture", true}, {"--distortion", true},
      {"--encoding", true},    {"--compressed", true},  {"--no-imu", false},
      {"--image-topic", true}, {"--imu-topic", true},   {"--frame-id", true},
      {"--imu-frame-id", true}, {"--quiet", false},     {"--help", false},
      {"--list-presets", false}};
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    const auto it = known.find(a);
    if (it == known.end()) fail("unknown option '" + a + "' (see --help)");
    if (!it->second) {
      args[a] = "1";
      continue;
    }
    if (i + 1 >= argc) fail(a + " needs a value");
    if (a == "--texture") {
      textures.push_back(argv[++i]);
    } else {
      args[a] = argv[++i];
    }
  }
  if (args.count("--help")) {
    std::cout << kUsage;
    return 0;
  }
  if (args.count("--list-presets")) {
    for (const auto& p : imt::SceneOptions::presetNames()) std::cout << p << "\n";
    return 0;
  }
  if (!args.count("--out")) fail("--out FILE.bag is required (see --help)");

  const std::string preset = args.count("--preset") ? args["--preset"] : "wall_pan";
  auto preset_options = imt::SceneOptions::fromPreset(preset);
  if (!preset_options) {
    std::string names;
    for (const auto& p : imt::SceneOptions::presetNames()) names += (names.empty() ? "" : ", ") + p;
    fail("unknown preset '" + preset + "' (known: " + names + ")");
  }
  imt::SceneOptions opt = *preset_options;
  if (args.count("--duration")) opt.duration = toDouble("--duration", args["--duration"]);
  if (args.count("--fps")) opt.fps = toDouble("--fps", args["--fps"]);
  if (args.count("--width")) opt.width = toInt("--width", args["--width"]);
  if (args.count("--height")) opt.height = toInt("--height", args["--height"]);
  if (args.count("--seed")) opt.seed = toInt("--seed", args["--seed"]);
  if (args.count("--start-time")) opt.start_time = toDouble("--start-time", args["--start-time"]);
  if (args.count("--noise")) opt.noise_sigma = toDouble("--noise", args["--noise"]);
  if (args.count("--exposure")) opt.exposure = toDouble("--exposure", args["--exposure"]);
  if (args.count("--supersample")) opt.supersample = toInt("--supersample", args["--supersample"]);
  if (args.count("--distortion")) {
    const std::string& v = args["--distortion"];
    const size_t colon = v.find(':');
    opt.distortion_model = v.substr(0, colon);
    opt.distortion.clear();
    if (colon != std::string::npos) {
      std::stringstream in(v.substr(colon + 1));
      std::string item;
      while (std::getline(in, item, ',')) opt.distortion.push_back(toDouble("--distortion", item));
    }
  }
  if (!textures.empty()) opt.texture_files = textures;
  if (args.count("--target-texture"))
    for (imt::ScenePlane& p : opt.planes)
      if (p.kind == imt::ScenePlane::Kind::kTarget) p.texture_file = args["--target-texture"];

  const std::string encoding = args.count("--encoding") ? args["--encoding"] : "mono8";
  if (encoding != "mono8" && encoding != "mono16" && encoding != "bgr8" && encoding != "rgb8" &&
      encoding != "bgra8" && encoding != "rgba8")
    fail("--encoding: unsupported '" + encoding + "' (mono8, mono16, bgr8, rgb8, bgra8, rgba8)");
  const std::string compressed = args.count("--compressed") ? args["--compressed"] : "";
  if (!compressed.empty() && compressed != "png" && compressed != "jpeg")
    fail("--compressed: expected png or jpeg, got '" + compressed + "'");
  const std::string image_topic = args.count("--image-topic") ? args["--image-topic"] : "/camera/image_raw";
  const std::string imu_topic = args.count("--imu-topic") ? args["--imu-topic"] : "/imu/data";
  const std::string frame_id = args.count("--frame-id") ? args["--frame-id"] : "camera_optical_frame";
  const std::string imu_frame = args.count("--imu-frame-id") ? args["--imu-frame-id"] : "imu_link";
  const bool quiet = args.count("--quiet") || !isatty(fileno(stderr));

  std::string err;
  const auto scene = imt::SceneGenerator::create(opt, &err);
  if (!scene) fail(err);

  try {
    rosbag::Bag bag(args["--out"], rosbag::bagmode::Write);
    bag.setCompression(rosbag::compression::LZ4);

    std_msgs::Header header;
    header.frame_id = frame_id;
    header.stamp.fromSec(scene->frameStamp(0));

    // /tf_static: camera optical frame -> IMU frame (rotation only).
    geometry_msgs::TransformStamped tf;
    tf.header = header;
    tf.child_frame_id = imu_frame;
    const Eigen::Quaterniond q = opt.q_cam_imu.normalized();
    tf.transform.rotation.x = q.x();
    tf.transform.rotation.y = q.y();
    tf.transform.rotation.z = q.z();
    tf.transform.rotation.w = q.w();
    tf2_msgs::TFMessage tf_msg;
    tf_msg.transforms.push_back(tf);
    bag.write("/tf_static", header.stamp, tf_msg);

    // IMU samples are interleaved with the frames in time order.
    const std::vector<imt::ImuSample> imu =
        args.count("--no-imu") ? std::vector<imt::ImuSample>() : scene->imuSamples();
    size_t next_imu = 0;
    auto writeImuUntil = [&](double t) {
      for (; next_imu < imu.size() && imu[next_imu].stamp <= t; ++next_imu) {
        std_msgs::Header h;
        h.frame_id = imu_frame;
        h.stamp.fromSec(imu[next_imu].stamp);
        bag.write(imu_topic, h.stamp, imt::toImuMsg(imu[next_imu], h));
      }
    };

    const sensor_msgs::CameraInfo info_template = imt::toCameraInfo(scene->intrinsics(), header);
    const int n = scene->frameCount();
    // Render the next frame on a second core while this one is written.
    std::future<cv::Mat> next = std::async(std::launch::async, [&] { return scene->renderFrame(0); });
    for (int i = 0; i < n; ++i) {
      cv::Mat gray = next.get();
      if (i + 1 < n) next = std::async(std::launch::async, [&, i] { return scene->renderFrame(i + 1); });
      header.stamp.fromSec(scene->frameStamp(i));
      header.seq = i;
      writeImuUntil(scene->frameStamp(i));
      if (compressed.empty()) {
        bag.write(image_topic, header.stamp,
                  cv_bridge::CvImage(header, encoding, encode(gray, encoding)).toImageMsg());
      } else {
        sensor_msgs::CompressedImage c;
        c.header = header;
        c.format = encoding + "; " + compressed + " compressed " + (encoding == "mono8" ? "mono8" : "bgr8");
        std::vector<int> params;
        if (compressed == "jpeg") params = {cv::IMWRITE_JPEG_QUALITY, 95};
        cv::imencode(compressed == "png" ? ".png" : ".jpg", encode(gray, encoding == "mono8" ? "mono8" : "bgr8"),
                     c.data, params);
        bag.write(image_topic + "/compressed", header.stamp, c);
      }
      sensor_msgs::CameraInfo info = info_template;
      info.header = header;
      bag.write(siblingTopic(image_topic, "camera_info"), header.stamp, info);
      if (!quiet) std::fprintf(stderr, "\rmake_scene: frame %d/%d", i + 1, n);
    }
    writeImuUntil(1e300);
    bag.close();
    if (!quiet) std::fprintf(stderr, "\n");
  } catch (const std::exception& e) {
    fail(std::string("writing ") + args["--out"] + ": " + e.what());
  }

  if (args.count("--truth") && !imt::writeSceneTruth(*scene, frame_id, args["--truth"], &err)) fail(err);
  if (args.count("--init")) {
    const long frame = args.count("--init-frame") ? toInt("--init-frame", args["--init-frame"]) : 0;
    if (!imt::writeSceneInit(*scene, static_cast<int>(frame), args["--init"], &err)) fail(err);
  }
  std::cout << "make_scene: wrote " << args["--out"] << " (" << scene->frameCount() << " frames, preset "
            << preset << ", seed " << opt.seed << ")";
  if (args.count("--truth")) std::cout << ", truth " << args["--truth"];
  if (args.count("--init")) std::cout << ", init " << args["--init"];
  std::cout << std::endl;
  return 0;
}
