#include "instant_motion_tracking/io/config.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace imt {
namespace {

template <class T>
const char* typeName();
template <> const char* typeName<int>() { return "an integer"; }
template <> const char* typeName<double>() { return "a number"; }
template <> const char* typeName<bool>() { return "true or false"; }
template <> const char* typeName<std::string>() { return "a string"; }

// Reads fields from a YAML mapping; remembers the first error and which keys
// were consumed, so unknown keys (typos) can be reported.
class YamlReader {
 public:
  YamlReader(const YAML::Node& node, std::string prefix, std::string* error)
      : node_(node), prefix_(std::move(prefix)), error_(error) {}

  template <class T>
  void operator()(const char* name, T& field, const char*) {
    used_.insert(name);
    if (!error_->empty()) return;
    const YAML::Node n = node_[name];
    if (!n) return;
    try {
      if (!n.IsScalar()) throw YAML::Exception(n.Mark(), "not a scalar");
      T value = n.as<T>();
      if constexpr (std::is_same_v<T, double>) {
        if (!std::isfinite(value)) throw YAML::Exception(n.Mark(), "not finite");
      }
      field = value;
    } catch (const YAML::Exception&) {
      *error_ = prefix_ + name + ": expected " + typeName<T>() + ", got '" +
                (n.IsScalar() ? n.Scalar() : std::string("a ") + (n.IsMap() ? "mapping" : "list")) +
                "'";
    }
  }

  template <class S>
  void section(const char* name, S& sub) {
    used_.insert(name);
    if (!error_->empty()) return;
    const YAML::Node n = node_[name];
    if (!n || n.IsNull()) return;
    if (!n.IsMap()) {
      *error_ = prefix_ + name + ": expected a mapping";
      return;
    }
    YamlReader inner(n, prefix_ + name + ".", error_);
    sub.visit(inner);
    inner.checkUnknown();
  }

  void checkUnknown() {
    if (!error_->empty()) return;
    for (const auto& kv : node_) {
      const std::string key = kv.first.as<std::string>();
      if (!used_.count(key)) {
        *error_ = "unknown parameter '" + prefix_ + key + "'";
        return;
      }
    }
  }

 private:
  const YAML::Node node_;
  std::string prefix_;
  std::string* error_;
  std::set<std::string> used_;
};

// A parameter's value as YAML scalar text: strings quoted, numbers with
// up to 10 significant digits, a double always with a point or an exponent.
template <class T>
std::string scalarText(const T& field) {
  std::ostringstream os;
  if constexpr (std::is_same_v<T, bool>) {
    os << (field ? "true" : "false");
  } else if constexpr (std::is_same_v<T, std::string>) {
    os << '"' << field << '"';
  } else if constexpr (std::is_same_v<T, double>) {
    os.precision(10);
    os << field;
    if (os.str().find_first_of(".e") == std::string::npos) os << ".0";
  } else {
    os << field;
  }
  return os.str();
}

class Lister {
 public:
  explicit Lister(std::string prefix = "") : prefix_(std::move(prefix)) {}
  template <class T>
  void operator()(const char* name, T& field, const char*) {
    out.emplace_back(prefix_ + name, scalarText(field));
  }
  template <class S>
  void section(const char* name, S& sub) {
    Lister inner(prefix_ + name + ".");
    sub.visit(inner);
    out.insert(out.end(), inner.out.begin(), inner.out.end());
  }
  std::vector<std::pair<std::string, std::string>> out;

 private:
  std::string prefix_;
};

// Writes parameters as YAML lines "name: default  # doc", nested sections
// indented under a titled header; see defaultConfigYaml().
class YamlDocWriter {
 public:
  YamlDocWriter(std::ostringstream* out, std::ostringstream* sections, int indent)
      : out_(out), sections_(sections), indent_(indent) {}
  template <class T>
  void operator()(const char* name, T& field, const char* doc) {
    std::string line = std::string(indent_, ' ') + name + ": " + scalarText(field);
    const size_t column = indent_ ? 33 : 27;
    line.resize(std::max(column, line.size() + 1), ' ');
    *out_ << line << "# " << doc << "\n";
  }
  template <class S>
  void section(const char* name, S& sub) {
    std::string header = std::string("# --- ") + sectionTitle(name) + " ";
    header.resize(80, '-');
    *sections_ << "\n" << header << "\n" << name << ":\n";
    YamlDocWriter inner(sections_, sections_, indent_ + 2);
    sub.visit(inner);
  }

 private:
  static const char* sectionTitle(const std::string& name) {
    if (name == "motion_analysis") return "motion analysis (paper 3.1)";
    if (name == "region_tracking") return "region tracking (paper 3.2)";
    if (name == "planar_tracking") return "planar targets (paper 3.3)";
    if (name == "imu") return "IMU orientation (paper 3.4)";
    if (name == "anchors") return "anchors (paper 3.4)";
    return "";
  }
  std::ostringstream *out_, *sections_;
  int indent_;
};

}  // namespace

std::string defaultConfigYaml() {
  std::ostringstream top, ros, sections;
  PipelineOptions pipeline;
  RosShellOptions shell;
  YamlDocWriter p(&top, &sections, 0), r(&ros, &sections, 0);
  pipeline.visit(p);
  shell.visit(r);
  return "# instant_motion_tracking parameters: the one file both the nodelets (loaded\n"
         "# into each nodelet's private namespace by launch/tracking.launch) and\n"
         "# track_bag (--config) read: every parameter with its default and what it does.\n"
         "# Generated from the options structs (their visit()): do not edit by hand;\n"
         "# change the struct, then: track_bag --print-default-config > config/default.yaml\n"
         "# (test/io/test_config.cpp checks that the two agree).\n"
         "\n# --- pipeline -----------------------------------------------------------------\n" +
         top.str() +
         "\n# --- ROS shell (nodelets only; track_bag ignores these) -----------------------\n" +
         ros.str() + sections.str();
}

std::string RosShellOptions::validate() const {
  if (queue_size < 1 || queue_size > 1000) return "queue_size: must be in [1, 1000]";
  if (!(diagnostic_period >= 0.05 && diagnostic_period <= 3600))
    return "diagnostic_period: must be in [0.05, 3600] s";
  if (image_transport != "raw" && image_transport != "compressed")
    return "image_transport: expected raw or compressed, got '" + image_transport + "'";
  for (char c : frame_prefix) {
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '/'))
      return "frame_prefix: only letters, digits, '_' and '/' are allowed";
  }
  return "";
}

std::string Config::validate() const {
  std::string e = pipeline.validate();
  return e.empty() ? ros.validate() : e;
}

bool loadConfigYaml(const std::string& text, const std::string& source, Config* config,
                    std::string* error) {
  std::string err;
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    *error = source + ": not valid YAML: " + e.what();
    return false;
  }
  Config c = *config;
  if (root && !root.IsNull()) {
    if (!root.IsMap()) {
      *error = source + ": expected a mapping of parameters";
      return false;
    }
    YamlReader reader(root, "", &err);
    c.visit(reader);
    reader.checkUnknown();
  }
  if (err.empty()) err = c.validate();
  if (!err.empty()) {
    *error = source + ": " + err;
    return false;
  }
  *config = c;
  return true;
}

bool loadConfigFile(const std::string& path, Config* config, std::string* error) {
  std::ifstream in(path);
  if (!in) {
    *error = path + ": cannot open the config file";
    return false;
  }
  std::stringstream ss;
  ss << in.rdbuf();
  return loadConfigYaml(ss.str(), path, config, error);
}

std::vector<std::pair<std::string, std::string>> listParameters(const Config& config) {
  Config c = config;
  Lister l;
  c.visit(l);
  return l.out;
}

}  // namespace imt
