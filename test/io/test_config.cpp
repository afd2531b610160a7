#include "instant_motion_tracking/io/config.h"

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <fstream>
#include <sstream>

namespace imt {
namespace {

const std::string kDefaultYaml = std::string(IMT_SOURCE_DIR) + "/config/default.yaml";

YAML::Node lookup(const YAML::Node& root, const std::string& dotted) {
  std::stringstream ss(dotted);
  std::string part;
  YAML::Node node;
  node.reset(root);  // rebinds (operator= would assign into the tree)
  while (std::getline(ss, part, '.')) {
    if (!node.IsMap()) return YAML::Node();
    const YAML::Node child = node[part];
    if (!child) return YAML::Node();
    node.reset(child);
  }
  return node;
}

// config/default.yaml documents every parameter, with the struct's default:
// the struct is the single source of defaults, the file must not drift.
TEST(Config, DefaultYamlListsEveryParameterWithItsDefault) {
  const YAML::Node root = YAML::LoadFile(kDefaultYaml);
  const Config defaults;
  for (const auto& [name, value] : listParameters(defaults)) {
    const YAML::Node n = lookup(root, name);
    ASSERT_TRUE(n && n.IsScalar()) << name << " is missing from config/default.yaml";
    const YAML::Node expected = YAML::Load(value);
    if (value.front() == '"') {
      EXPECT_EQ(n.as<std::string>(), expected.as<std::string>()) << name;
    } else if (value == "true" || value == "false") {
      EXPECT_EQ(n.as<bool>(), expected.as<bool>()) << name;
    } else {
      EXPECT_DOUBLE_EQ(n.as<double>(), expected.as<double>()) << name;
    }
  }
  // ...and loading it is accepted as a whole (no unknown keys).
  Config c;
  std::string err;
  EXPECT_TRUE(loadConfigFile(kDefaultYaml, &c, &err)) << err;
}

// Each parameter is described once, in its struct's visit(): the file is
// that description rendered, so its defaults and comments cannot drift.
TEST(Config, DefaultYamlIsGeneratedFromTheStructs) {
  std::ifstream in(kDefaultYaml);
  std::stringstream file;
  file << in.rdbuf();
  EXPECT_EQ(file.str(), defaultConfigYaml())
      << "config/default.yaml differs from the options structs: regenerate it with\n"
         "  track_bag --print-default-config > config/default.yaml";
}

TEST(Config, EveryLineOfDefaultYamlHasAComment) {
  std::ifstream in(kDefaultYaml);
  std::string line;
  int n = 0;
  while (std::getline(in, line)) {
    ++n;
    const auto first = line.find_first_not_of(' ');
    if (first == std::string::npos || line[first] == '#') continue;
    if (line.back() == ':') continue;  // a section header
    EXPECT_NE(line.find('#'), std::string::npos) << "default.yaml line " << n << " has no comment";
  }
}

TEST(Config, OverridesAndKeepsTheRest) {
  Config c;
  std::string err;
  ASSERT_TRUE(loadConfigYaml("cache_seconds: 3\nmotion_analysis:\n  max_features: 123\n", "t", &c, &err))
      << err;
  EXPECT_DOUBLE_EQ(c.pipeline.cache_seconds, 3.0);
  EXPECT_EQ(c.pipeline.motion_analysis.max_features, 123);
  EXPECT_EQ(c.pipeline.motion_analysis.grid_cols, MotionAnalysisOptions().grid_cols);
}

TEST(Config, ImageRectifiedDefaultsToRawImages) {
  Config c;
  EXPECT_FALSE(c.pipeline.image_rectified) << "camera_info's K and D unless told otherwise";
  std::string err;
  ASSERT_TRUE(loadConfigYaml("image_rectified: true\n", "t", &c, &err)) << err;
  EXPECT_TRUE(c.pipeline.image_rectified);
  EXPECT_FALSE(loadConfigYaml("image_rectified: 3\n", "t", &c, &err));
  EXPECT_NE(err.find("image_rectified"), std::string::npos) << err;
}

struct BadCase {
  const char* yaml;
  const char* expected;  // substring of the message
};

class ConfigRejects : public ::testing::TestWithParam<BadCase> {};

TEST_P(ConfigRejects, WithAMessageNamingTheProblem) {
  Config c;
  c.pipeline.cache_seconds = 7;
  std::string err;
  EXPECT_FALSE(loadConfigYaml(GetParam().yaml, "my.yaml", &c, &err));
  EXPECT_NE(err.find(GetParam().expected), std::string::npos) << err;
  EXPECT_NE(err.find("my.yaml"), std::string::npos) << err;
  EXPECT_DOUBLE_EQ(c.pipeline.cache_seconds, 7.0) << "config must be unchanged on error";
}

INSTANTIATE_TEST_SUITE_P(
    Cases, ConfigRejects,
    ::testing::Values(BadCase{"cache_secnds: 3\n", "unknown parameter 'cache_secnds'"},
                      BadCase{"motion_analysis:\n  max_feature: 3\n", "motion_analysis.max_feature"},
                      BadCase{"cache_seconds: abc\n", "cache_seconds: expected a number"},
                      BadCase{"cache_seconds: .nan\n", "cache_seconds"},
                      BadCase{"motion_analysis: 3\n", "motion_analysis: expected a mapping"},
                      BadCase{"motion_analysis:\n  max_features: 2.5\n", "expected an integer"},
                      BadCase{"cache_seconds: -2\n", "cache_seconds: must be in"},
                      BadCase{"publish_tf: maybe\n", "publish_tf: expected true or false"},
                      BadCase{"[1, 2]\n", "expected a mapping"},
                      BadCase{"a: [\n", "not valid YAML"}));

TEST(Config, MissingFileIsNamed) {
  Config c;
  std::string err;
  EXPECT_FALSE(loadConfigFile("/nonexistent/x.yaml", &c, &err));
  EXPECT_NE(err.find("/nonexistent/x.yaml"), std::string::npos);
}

}  // namespace
}  // namespace imt
