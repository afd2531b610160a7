// The whole parameter set of the package and its YAML loader (track_bag and
// tests; the nodelets read the same file through the parameter server, see
// ros/params.h). The layout is that of config/default.yaml: top-level pipeline
// and ROS-shell parameters, one nested mapping per core module.
#pragma once

#include "instant_motion_tracking/core/options.h"

#include <string>
#include <vector>

namespace imt {

// Parameters of the ROS shell (nodelets); ignored by track_bag.
struct RosShellOptions {
  // Each field is documented once, in visit() below (config/default.yaml is
  // generated from it: track_bag --print-default-config).
  bool publish_tf = true;
  std::string frame_prefix;
  bool always_subscribe =
      false;           // subscribe to inputs even without subscribers (e.g. tf-only consumers)
  int queue_size = 5;
  double diagnostic_period = 1.0;
  std::string image_transport = "raw";

  template <class V>
  void visit(V& v) {
    v("publish_tf", publish_tf, "broadcast planar_target_<id> / anchor_<id> on tf2");
    v("frame_prefix", frame_prefix, "prefix of those tf frame names");
    v("always_subscribe", always_subscribe,
      "subscribe to inputs even when nothing subscribes to the outputs (tf-only consumers)");
    v("queue_size", queue_size, "subscriber queue length (frames)");
    v("diagnostic_period", diagnostic_period,
      "s (wall time) between /diagnostics reports (input rate, latency, items by status)");
    v("image_transport", image_transport,
      "raw: sensor_msgs/Image on image | compressed: sensor_msgs/CompressedImage on "
      "image/compressed (decoded by the nodelets)");
  }
  std::string validate() const;
};

struct Config {
  PipelineOptions pipeline;
  RosShellOptions ros;

  template <class V>
  void visit(V& v) {
    pipeline.visit(v);
    ros.visit(v);
  }
  // Empty when usable, else a message naming the bad parameter.
  std::string validate() const;
};

// Reads `text` (YAML) over `config` (fields absent from the text keep their
// values). False with a message naming the parameter on a type error, an
// unknown parameter or a value that fails validate(); `config` is then
// unchanged. `source` names the text in messages (a file name).
bool loadConfigYaml(const std::string& text, const std::string& source, Config* config,
                    std::string* error);
bool loadConfigFile(const std::string& path, Config* config, std::string* error);

// config/default.yaml as generated from the options structs: every parameter
// with its default and its visit() doc as the comment (the one description).
std::string defaultConfigYaml();

// Every parameter as "a.b.c" = its default rendered as YAML scalar text, in
// visit() order (for documentation checks).
std::vector<std::pair<std::string, std::string>> listParameters(const Config& config);

}  // namespace imt
