#include "instant_motion_tracking/ros/params.h"

#include <ros/param.h>
#include <yaml-cpp/yaml.h>

namespace imt {
namespace {

// A parameter tree as YAML, so that the one YAML loader (io/config.h) reads
// it: the same types, the same unknown-key check, the same messages.
void emit(YAML::Emitter& out, XmlRpc::XmlRpcValue& v) {
  switch (v.getType()) {
    case XmlRpc::XmlRpcValue::TypeStruct:
      out << YAML::BeginMap;
      for (auto& [key, value] : v) {
        out << YAML::Key << key << YAML::Value;
        emit(out, value);
      }
      out << YAML::EndMap;
      break;
    case XmlRpc::XmlRpcValue::TypeArray:
      out << YAML::BeginSeq;
      for (int i = 0; i < v.size(); ++i) emit(out, v[i]);
      out << YAML::EndSeq;
      break;
    case XmlRpc::XmlRpcValue::TypeBoolean:
      out << static_cast<bool>(v);
      break;
    case XmlRpc::XmlRpcValue::TypeInt:
      out << static_cast<int>(v);
      break;
    case XmlRpc::XmlRpcValue::TypeDouble:
      out << static_cast<double>(v);
      break;
    case XmlRpc::XmlRpcValue::TypeString:
      out << YAML::DoubleQuoted << static_cast<std::string>(v);
      break;
    default:  // dates, binary: no parameter of ours is of these types
      out << YAML::BeginSeq << YAML::EndSeq;
      break;
  }
}

}  // namespace

bool loadConfigFromRos(const ros::NodeHandle& nh, Config* config, std::string* error) {
  XmlRpc::XmlRpcValue tree;
  const std::string ns = nh.getNamespace();
  if (!ros::param::get(ns, tree) || tree.getType() != XmlRpc::XmlRpcValue::TypeStruct) {
    // No parameters at all: the defaults.
    *error = config->validate();
    return error->empty();
  }
  YAML::Emitter out;
  out.SetDoublePrecision(17);
  emit(out, tree);
  return loadConfigYaml(out.c_str(), "parameters of " + ns, config, error);
}

}  // namespace imt
