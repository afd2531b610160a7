#include "instant_motion_tracking/ros/params.h"

namespace imt {
namespace {

class RosParamReader {
 public:
  explicit RosParamReader(const ros::NodeHandle& nh) : nh_(nh) {}
  template <class T>
  void operator()(const char* name, T& field, const char*) {
    T value = field;
    if (nh_.getParam(name, value)) field = value;
  }
  void operator()(const char* name, double& field, const char*) {
    // Accept integers written without a decimal point ("cache_seconds: 10").
    double d;
    int i;
    if (nh_.getParam(name, d)) {
      field = d;
    } else if (nh_.getParam(name, i)) {
      field = i;
    }
  }
  template <class S>
  void section(const char* name, S& sub) {
    RosParamReader inner(ros::NodeHandle(nh_, name));
    sub.visit(inner);
  }

 private:
  ros::NodeHandle nh_;
};

}  // namespace

bool loadConfigFromRos(const ros::NodeHandle& nh, Config* config, std::string* error) {
  Config c = *config;
  RosParamReader reader(nh);
  c.visit(reader);
  *error = c.validate();
  if (!error->empty()) return false;
  *config = c;
  return true;
}

}  // namespace imt
