// Reading a rosbag for track_bag: opens it, chooses the topics as the spec
// says (docs: interface.md, "Offline tool: track_bag"), reads every frame's
// header stamp up front (a cheap first pass that deserializes only the
// header), then delivers the messages of the chosen time window in bag order
// to callbacks.
//
// Topic choice (options override each):
//   image:       the only sensor_msgs/Image or sensor_msgs/CompressedImage topic
//   camera_info: the image topic's sibling `camera_info` (image_transport's
//                `/compressed` suffix removed first), if in the bag
//   imu:         the only sensor_msgs/Imu topic, if any
//   tf:          /tf_static and /tf (tf2_msgs/TFMessage), if present
//
// Usage:
//   imt::BagInput in;
//   std::string err;
//   if (!in.open("run.bag", options, &err)) die(err);
//   const std::vector<double>& stamps = in.frameStamps();    // all frames, before playing
//   imt::BagInput::Callbacks cb;
//   cb.image = [&](const imt::BagImage& im, std::string* why) { ...; return true; };
//   cb.imu = [&](const sensor_msgs::Imu& m) { ... };
//   if (!in.play(cb, &err)) die(err);
//
// Every failure (unreadable, truncated or unindexed bag, missing or ambiguous
// topic, undecodable record) is a false return with a one-line message; no
// exception escapes. Threading: one thread.
#pragma once

#include <Eigen/Geometry>
#include <ros/time.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <tf2_msgs/TFMessage.h>

#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace rosbag {
class Bag;
class MessageInstance;
}

namespace imt {

struct BagInputOptions {
  std::string image_topic;        // "" = the only image topic
  std::string camera_info_topic;  // "" = the image topic's sibling camera_info, if present
  std::string imu_topic;          // "" = the only Imu topic, if any
  double start = 0;               // s after the bag's first message (as rosbag play -s)
  double end = -1;                // s after the bag's first message; < 0 = to the end
};

// One image message; exactly one of `raw` and `compressed` is set.
struct BagImage {
  sensor_msgs::Image::ConstPtr raw;
  sensor_msgs::CompressedImage::ConstPtr compressed;
  ros::Time bag_time;  // time the message was recorded (not its header stamp)
  int index = 0;       // index into BagInput::frameStamps()

  const std_msgs::Header& header() const { return raw ? raw->header : compressed->header; }
};

class BagInput {
 public:
  struct Callbacks {
    // Returning false stops play(), which then fails with `why`.
    std::function<bool(const BagImage&, std::string* why)> image;
    std::function<void(const sensor_msgs::Imu&, const ros::Time& bag_time)> imu;  // optional
    std::function<void(const sensor_msgs::CameraInfo&)> camera_info;               // optional
    // /tf and /tf_static of the window; optional.
    std::function<void(const tf2_msgs::TFMessage&, bool is_static, const ros::Time& bag_time)> tf;
  };

  BagInput();
  ~BagInput();
  BagInput(const BagInput&) = delete;
  BagInput& operator=(const BagInput&) = delete;

  // Opens the bag, chooses the topics and reads the frame stamps of the
  // window. False with a message naming the problem (no image in the window
  // is an error too).
  bool open(const std::string& path, const BagInputOptions& options, std::string* error);

  const std::string& path() const { return path_; }
  const std::string& imageTopic() const { return image_topic_; }
  bool imageCompressed() const { return image_compressed_; }
  const std::string& cameraInfoTopic() const { return camera_info_topic_; }  // "" = none
  const std::string& imuTopic() const { return imu_topic_; }                 // "" = none
  bool hasTfStatic() const { return has_tf_static_; }
  bool hasTf() const { return has_tf_; }

  ros::Time bagBegin() const { return bag_begin_; }        // the bag's first message
  ros::Time bagEnd() const { return bag_end_; }
  ros::Time windowBegin() const { return window_begin_; }  // bag times played
  ros::Time windowEnd() const { return window_end_; }

  // Header stamps (s) of the window's image messages, in bag order; index i
  // is BagImage::index i in play().
  const std::vector<double>& frameStamps() const { return frame_stamps_; }
  // header.frame_id of the first image ("" when empty).
  const std::string& imageFrameId() const { return image_frame_id_; }
  // Wall time of the stamps pass (s).
  double stampsPassSeconds() const { return stamps_pass_seconds_; }

  // The first camera_info message (whole bag) accepted by `valid`, which
  // explains a rejection in its string. False with the reason when there is
  // no camera_info topic or no accepted message (the first rejection's reason).
  bool firstCameraInfo(const std::function<bool(const sensor_msgs::CameraInfo&, std::string*)>& valid,
                       sensor_msgs::CameraInfo* info, std::string* why);
  // header.frame_id of the first IMU message ("" when there is none).
  std::string imuFrameId();

  // Rotation q_target_source (maps vectors of `source` into `target`) from
  // the bag's /tf_static (whole bag), else from /tf (first transform of each
  // frame pair), chaining transforms through intermediate frames. False with
  // the reason when the frames are not connected.
  bool lookupRotation(const std::string& target, const std::string& source,
                      Eigen::Quaterniond* q_target_source, std::string* why);

  // Delivers the window's image, IMU, camera_info and tf messages in bag
  // order (only topics with a callback are read). False with a message on a
  // read error or when a callback returns false.
  bool play(const Callbacks& callbacks, std::string* error);
  // Reads frame `index` (of frameStamps()) again, out of order: random access
  // for the frames a cache did not keep. False with a message when it fails.
  bool readFrame(int index, BagImage* image, std::string* error);

 private:
  // The image message `m` (of the chosen type) as frame `index`; false for
  // another type or an unreadable message.
  bool imageOf(const rosbag::MessageInstance& m, int index, BagImage* image) const;

  std::unique_ptr<rosbag::Bag> bag_;
  std::string path_;
  std::string image_topic_, image_type_, camera_info_topic_, imu_topic_;
  bool image_compressed_ = false, has_tf_static_ = false, has_tf_ = false;
  ros::Time bag_begin_, bag_end_, window_begin_, window_end_;
  std::vector<double> frame_stamps_;
  std::vector<ros::Time> frame_bag_times_;  // parallel to frame_stamps_
  std::string image_frame_id_;
  double stamps_pass_seconds_ = 0;
};

}  // namespace imt
