#include "instant_motion_tracking/ros/bag_input.h"

#include <rosbag/bag.h>
#include <rosbag/view.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <queue>
#include <set>

namespace imt {
namespace detail {
// The leading Header of any stamped message, the rest left unread: the
// stamps pass deserializes only these few bytes of each image.
struct HeaderOnly {
  uint32_t seq = 0;
  ros::Time stamp;
  std::string frame_id;
};
}  // namespace detail
}  // namespace imt

namespace ros {
namespace message_traits {
template <>
struct MD5Sum<imt::detail::HeaderOnly> {  // "*": accepted for any message type
  static const char* value() { return "*"; }
  static const char* value(const imt::detail::HeaderOnly&) { return value(); }
};
template <>
struct DataType<imt::detail::HeaderOnly> {
  static const char* value() { return "*"; }
  static const char* value(const imt::detail::HeaderOnly&) { return value(); }
};
template <>
struct Definition<imt::detail::HeaderOnly> {
  static const char* value() { return ""; }
  static const char* value(const imt::detail::HeaderOnly&) { return value(); }
};
}  // namespace message_traits
namespace serialization {
template <>
struct Serializer<imt::detail::HeaderOnly> {
  template <typename Stream>
  inline static void read(Stream& stream, imt::detail::HeaderOnly& h) {
    stream.next(h.seq);
    stream.next(h.stamp);
    stream.next(h.frame_id);
  }
};
}  // namespace serialization
}  // namespace ros

namespace imt {
namespace {

const char* kImageType = "sensor_msgs/Image";
const char* kCompressedType = "sensor_msgs/CompressedImage";
const char* kImuType = "sensor_msgs/Imu";
const char* kCameraInfoType = "sensor_msgs/CameraInfo";
const char* kTfType = "tf2_msgs/TFMessage";

std::string oneLine(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == ' ')) s.pop_back();
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  return s;
}

std::string joinList(const std::vector<std::string>& v) {
  std::string s;
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + v[i];
  return s;
}

std::string fmt(double v, int decimals = 3) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

std::string stripSlash(const std::string& frame) {
  return !frame.empty() && frame[0] == '/' ? frame.substr(1) : frame;
}

// Undirected graph of rigid rotations between frames; the first transform of
// each parent/child pair wins (the IMU is rigidly mounted).
class FrameGraph {
 public:
  void add(const tf2_msgs::TFMessage& msg) {
    for (const auto& t : msg.transforms) {
      const std::string parent = stripSlash(t.header.frame_id), child = stripSlash(t.child_frame_id);
      const auto& r = t.transform.rotation;
      Eigen::Quaterniond q(r.w, r.x, r.y, r.z);
      const double n = q.norm();
      if (parent.empty() || child.empty() || parent == child || !std::isfinite(n) || n < 1e-6)
        continue;  // unusable transform: ignored
      if (!pairs_.insert({parent, child}).second) continue;
      q.normalize();
      edges_[parent].push_back({child, q});            // q_parent_child
      edges_[child].push_back({parent, q.inverse()});  // q_child_parent
    }
  }

  bool find(const std::string& target, const std::string& source, Eigen::Quaterniond* q) const {
    if (target == source) {
      q->setIdentity();
      return true;
    }
    std::map<std::string, Eigen::Quaterniond> q_target;  // frame -> q_target_frame
    q_target[target].setIdentity();
    std::queue<std::string> open;
    open.push(target);
    while (!open.empty()) {
      const std::string f = open.front();
      open.pop();
      const auto it = edges_.find(f);
      if (it == edges_.end()) continue;
      for (const auto& [next, q_f_next] : it->second) {
        if (q_target.count(next)) continue;
        q_target[next] = q_target[f] * q_f_next;
        if (next == source) {
          *q = q_target[next].normalized();
          return true;
        }
        open.push(next);
      }
    }
    return false;
  }

 private:
  std::set<std::pair<std::string, std::string>> pairs_;
  std::map<std::string, std::vector<std::pair<std::string, Eigen::Quaterniond>>> edges_;
};

}  // namespace

BagInput::BagInput() = default;
BagInput::~BagInput() = default;

bool BagInput::open(const std::string& path, const BagInputOptions& options, std::string* error) {
  path_ = path;
  frame_stamps_.clear();
  frame_bag_times_.clear();
  const std::string name = "bag '" + path + "'";
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (!std::filesystem::exists(status)) {
    *error = "cannot open " + name + ": no such file";
    return false;
  }
  if (!std::filesystem::is_regular_file(status)) {
    *error = "cannot open " + name + ": not a regular file";
    return false;
  }
  try {
    bag_ = std::make_unique<rosbag::Bag>();
    try {
      bag_->open(path, rosbag::bagmode::Read);
    } catch (const rosbag::BagUnindexedException&) {
      throw;
    } catch (const std::exception& e) {
      *error = "cannot read " + name + " (not a rosbag, or truncated): " + oneLine(e.what());
      return false;
    }

    // Topics by type.
    rosbag::View all(*bag_);
    std::map<std::string, std::string> types;  // topic -> datatype (first connection's)
    for (const rosbag::ConnectionInfo* c : all.getConnections()) types.emplace(c->topic, c->datatype);
    if (all.size() == 0) {
      *error = name + " holds no messages";
      return false;
    }
    bag_begin_ = all.getBeginTime();
    bag_end_ = all.getEndTime();
    auto topicsOf = [&](std::initializer_list<const char*> wanted) {
      std::vector<std::string> out;
      for (const auto& [topic, type] : types)
        for (const char* w : wanted)
          if (type == w) out.push_back(topic);
      return out;
    };
    // A topic given without its leading slash matches the bag's absolute name.
    auto resolve = [&](const std::string& given) {
      if (types.count(given) || given.empty() || given[0] == '/') return given;
      return types.count("/" + given) ? "/" + given : given;
    };

    // Image topic.
    const std::vector<std::string> images = topicsOf({kImageType, kCompressedType});
    if (!options.image_topic.empty()) {
      image_topic_ = resolve(options.image_topic);
      const auto it = types.find(image_topic_);
      if (it == types.end()) {
        *error = "image topic '" + options.image_topic + "' is not in the bag (" +
                 (images.empty() ? std::string("it has no image topics")
                                 : "image topics: " + joinList(images)) +
                 ")";
        return false;
      }
      if (it->second != kImageType && it->second != kCompressedType) {
        *error = "topic '" + image_topic_ + "' is a " + it->second + ", not a " + kImageType +
                 " or " + kCompressedType;
        return false;
      }
    } else if (images.empty()) {
      *error = name + " has no " + kImageType + " or " + kCompressedType + " topic";
      return false;
    } else if (images.size() > 1) {
      *error = name + " has several image topics (" + joinList(images) +
               "): choose one with --image-topic";
      return false;
    } else {
      image_topic_ = images[0];
    }
    image_type_ = types[image_topic_];
    image_compressed_ = image_type_ == kCompressedType;

    // camera_info: the sibling of the image topic (image_transport layout).
    if (!options.camera_info_topic.empty()) {
      camera_info_topic_ = resolve(options.camera_info_topic);
      const auto it = types.find(camera_info_topic_);
      if (it == types.end()) {
        *error = "camera_info topic '" + options.camera_info_topic + "' is not in the bag";
        return false;
      }
      if (it->second != kCameraInfoType) {
        *error = "topic '" + camera_info_topic_ + "' is a " + it->second + ", not a " +
                 kCameraInfoType;
        return false;
      }
    } else {
      std::string base = image_topic_;
      const std::string suffix = "/compressed";
      if (image_compressed_ && base.size() > suffix.size() &&
          base.compare(base.size() - suffix.size(), suffix.size(), suffix) == 0)
        base.resize(base.size() - suffix.size());
      const std::string sibling = base.substr(0, base.rfind('/') + 1) + "camera_info";
      const auto it = types.find(sibling);
      camera_info_topic_ = it != types.end() && it->second == kCameraInfoType ? sibling : "";
    }

    // IMU.
    const std::vector<std::string> imus = topicsOf({kImuType});
    if (!options.imu_topic.empty()) {
      imu_topic_ = resolve(options.imu_topic);
      const auto it = types.find(imu_topic_);
      if (it == types.end()) {
        *error = "IMU topic '" + options.imu_topic + "' is not in the bag (" +
                 (imus.empty() ? std::string("it has no Imu topics") : "Imu topics: " + joinList(imus)) +
                 ")";
        return false;
      }
      if (it->second != kImuType) {
        *error = "topic '" + imu_topic_ + "' is a " + it->second + ", not a " + kImuType;
        return false;
      }
    } else if (imus.size() > 1) {
      *error = name + " has several " + kImuType + " topics (" + joinList(imus) +
               "): choose one with --imu-topic";
      return false;
    } else {
      imu_topic_ = imus.empty() ? "" : imus[0];
    }
    has_tf_static_ = types.count("/tf_static") && types["/tf_static"] == kTfType;
    has_tf_ = types.count("/tf") && types["/tf"] == kTfType;

    // The window, in bag time.
    const double length = (bag_end_ - bag_begin_).toSec();
    if (!(options.start >= 0) || !std::isfinite(options.start) || !std::isfinite(options.end)) {
      *error = "--start/--end must be finite and --start non-negative";
      return false;
    }
    if (options.end >= 0 && options.end < options.start) {
      *error = "--end " + fmt(options.end) + " is before --start " + fmt(options.start);
      return false;
    }
    if (options.start > length) {
      *error = "--start " + fmt(options.start) + " s is past the end of " + name + " (it lasts " +
               fmt(length) + " s)";
      return false;
    }
    window_begin_ = bag_begin_ + ros::Duration(options.start);
    window_end_ = options.end < 0 || options.end >= length ? bag_end_
                                                           : bag_begin_ + ros::Duration(options.end);

    // Stamps pass: header stamps of the window's frames, in bag order.
    const auto t0 = std::chrono::steady_clock::now();
    rosbag::View frames(*bag_, rosbag::TopicQuery(image_topic_), window_begin_, window_end_);
    frame_stamps_.reserve(frames.size());
    for (const rosbag::MessageInstance& m : frames) {
      if (m.getDataType() != image_type_) continue;  // a stray connection of another type
      const auto h = m.instantiate<detail::HeaderOnly>();
      if (!h) continue;
      if (frame_stamps_.empty()) image_frame_id_ = h->frame_id;
      frame_stamps_.push_back(h->stamp.toSec());
      frame_bag_times_.push_back(m.getTime());
    }
    stamps_pass_seconds_ =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (frame_stamps_.empty()) {
      *error = "no image messages on " + image_topic_ +
               (options.start > 0 || options.end >= 0
                    ? " between " + fmt(options.start) + " s and " + fmt((window_end_ - bag_begin_).toSec()) +
                          " s after the bag's start"
                    : std::string(" in ") + name);
      return false;
    }
  } catch (const rosbag::BagUnindexedException&) {
    *error = name + " is not indexed (an interrupted recording? run 'rosbag reindex' on a copy)";
    return false;
  } catch (const std::exception& e) {  // rosbag::BagException, ros::Exception, bad_alloc
    *error = "cannot read " + name + ": " + oneLine(e.what());
    return false;
  }
  return true;
}

bool BagInput::firstCameraInfo(
    const std::function<bool(const sensor_msgs::CameraInfo&, std::string*)>& valid,
    sensor_msgs::CameraInfo* info, std::string* why) {
  if (camera_info_topic_.empty()) {
    *why = "no camera_info topic";
    return false;
  }
  std::string first_reason;
  try {
    rosbag::View view(*bag_, rosbag::TopicQuery(camera_info_topic_));
    for (const rosbag::MessageInstance& m : view) {
      const auto msg = m.instantiate<sensor_msgs::CameraInfo>();
      if (!msg) continue;
      std::string reason;
      if (valid(*msg, &reason)) {
        *info = *msg;
        return true;
      }
      if (first_reason.empty()) first_reason = reason;
    }
  } catch (const std::exception& e) {
    *why = "cannot read " + camera_info_topic_ + ": " + oneLine(e.what());
    return false;
  }
  *why = first_reason.empty() ? "no message on " + camera_info_topic_
                              : "no usable message on " + camera_info_topic_ + " (" + first_reason + ")";
  return false;
}

std::string BagInput::imuFrameId() {
  if (imu_topic_.empty()) return "";
  try {
    rosbag::View view(*bag_, rosbag::TopicQuery(imu_topic_));
    for (const rosbag::MessageInstance& m : view) {
      const auto h = m.instantiate<detail::HeaderOnly>();
      if (h) return h->frame_id;
    }
  } catch (const std::exception&) {
  }
  return "";
}

bool BagInput::lookupRotation(const std::string& target, const std::string& source,
                              Eigen::Quaterniond* q, std::string* why) {
  const std::string t = stripSlash(target), s = stripSlash(source);
  if (t.empty() || s.empty()) {
    *why = "a frame id is empty";
    return false;
  }
  FrameGraph graph;
  try {
    for (const char* topic : {"/tf_static", "/tf"}) {
      if ((std::string(topic) == "/tf_static" && !has_tf_static_) ||
          (std::string(topic) == "/tf" && !has_tf_))
        continue;
      rosbag::View view(*bag_, rosbag::TopicQuery(topic));
      for (const rosbag::MessageInstance& m : view) {
        const auto msg = m.instantiate<tf2_msgs::TFMessage>();
        if (!msg) continue;
        graph.add(*msg);
        // /tf_static is read whole (it is small); /tf until the frames connect.
        if (std::string(topic) == "/tf" && graph.find(t, s, q)) return true;
      }
      if (graph.find(t, s, q)) return true;
    }
  } catch (const std::exception& e) {
    *why = "cannot read tf: " + oneLine(e.what());
    return false;
  }
  *why = "no transform between '" + t + "' and '" + s + "' in " +
         (has_tf_static_ || has_tf_ ? "/tf_static or /tf" : "the bag (it has no /tf_static or /tf)");
  return false;
}

bool BagInput::play(const Callbacks& cb, std::string* error) {
  if (!bag_) {
    *error = "no bag open";
    return false;
  }
  std::vector<std::string> topics = {image_topic_};
  if (cb.imu && !imu_topic_.empty()) topics.push_back(imu_topic_);
  if (cb.camera_info && !camera_info_topic_.empty()) topics.push_back(camera_info_topic_);
  if (cb.tf && has_tf_static_) topics.push_back("/tf_static");
  if (cb.tf && has_tf_) topics.push_back("/tf");
  int index = 0;
  try {
    rosbag::View view(*bag_, rosbag::TopicQuery(topics), window_begin_, window_end_);
    for (const rosbag::MessageInstance& m : view) {
      const std::string& topic = m.getTopic();
      if (topic == image_topic_) {
        BagImage im;
        if (!imageOf(m, index, &im)) continue;  // another type (as in the stamps pass), or unreadable
        if (index >= static_cast<int>(frame_stamps_.size())) {
          *error = "bag '" + path_ + "' changed while it was read";
          return false;
        }
        ++index;
        std::string why;
        if (!cb.image(im, &why)) {
          *error = why;
          return false;
        }
      } else if (topic == imu_topic_) {
        if (const auto msg = m.instantiate<sensor_msgs::Imu>()) cb.imu(*msg, m.getTime());
      } else if (topic == camera_info_topic_) {
        if (const auto msg = m.instantiate<sensor_msgs::CameraInfo>()) cb.camera_info(*msg);
      } else if (topic == "/tf_static" || topic == "/tf") {
        if (const auto msg = m.instantiate<tf2_msgs::TFMessage>())
          cb.tf(*msg, topic == "/tf_static", m.getTime());
      }
    }
  } catch (const std::exception& e) {
    *error = "cannot read bag '" + path_ + "' (after " + std::to_string(index) +
             " frames): " + oneLine(e.what());
    return false;
  }
  return true;
}

bool BagInput::imageOf(const rosbag::MessageInstance& m, int index, BagImage* image) const {
  if (m.getDataType() != image_type_) return false;
  image->bag_time = m.getTime();
  image->index = index;
  if (image_compressed_)
    image->compressed = m.instantiate<sensor_msgs::CompressedImage>();
  else
    image->raw = m.instantiate<sensor_msgs::Image>();
  return image->raw || image->compressed;
}

bool BagInput::readFrame(int index, BagImage* image, std::string* error) {
  if (!bag_ || index < 0 || index >= static_cast<int>(frame_bag_times_.size())) {
    *error = "no frame " + std::to_string(index) + " in the bag's window";
    return false;
  }
  const ros::Time t = frame_bag_times_[index];
  try {
    // Frames recorded at the same bag time: the one whose header stamp is this frame's.
    rosbag::View view(*bag_, rosbag::TopicQuery(image_topic_), t, t);
    for (const rosbag::MessageInstance& m : view) {
      BagImage im;
      if (!imageOf(m, index, &im) || im.header().stamp.toSec() != frame_stamps_[index]) continue;
      *image = std::move(im);
      return true;
    }
  } catch (const std::exception& e) {
    *error = "cannot read frame " + std::to_string(index) + " of bag '" + path_ + "': " + oneLine(e.what());
    return false;
  }
  *error = "frame " + std::to_string(index) + " is no longer in bag '" + path_ + "'";
  return false;
}

}  // namespace imt
