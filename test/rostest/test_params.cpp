// Rostest node (test/rostest/params.test): the nodelets' parameters are read
// through the YAML loader, as strictly as track_bag reads its config: an
// unknown key or a wrong type names the parameter, and such a nodelet does
// not start while the manager and its other nodelets live on.
#include "instant_motion_tracking/AddRegion.h"
#include "instant_motion_tracking/ros/params.h"

#include "rostest_util.h"

#include <gtest/gtest.h>
#include <ros/ros.h>

#include <set>
#include <string>

namespace {

using imt::test::spinUntil;

// Loads the parameters under `ns` into a default Config.
bool load(const std::string& ns, imt::Config* config, std::string* error) {
  return imt::loadConfigFromRos(ros::NodeHandle(ns), config, error);
}

TEST(Params, LoaderIsAsStrictAsTheYamlLoader) {
  imt::Config c;
  std::string error;
  // Nothing set: the defaults.
  ASSERT_TRUE(load("/params_none", &c, &error)) << error;
  EXPECT_EQ(c.pipeline.cache_seconds, imt::Config().pipeline.cache_seconds);

  // Good values, an integer for a number, a nested one.
  ros::param::set("/params_good/cache_seconds", 5);
  ros::param::set("/params_good/region_tracking/max_scale_change", 0.1);
  ros::param::set("/params_good/image_transport", std::string("compressed"));
  ASSERT_TRUE(load("/params_good", &c, &error)) << error;
  EXPECT_EQ(c.pipeline.cache_seconds, 5.0);
  EXPECT_EQ(c.pipeline.region_tracking.max_scale_change, 0.1);
  EXPECT_EQ(c.ros.image_transport, "compressed");

  // A misspelt key, a wrong type, a nested wrong type, a bad value: refused,
  // named, and the config is left as it was.
  const imt::Config before = c;
  ros::param::set("/params_typo/region_tracking/max_scale_chnage", 0.1);
  EXPECT_FALSE(load("/params_typo", &c, &error));
  EXPECT_NE(error.find("region_tracking.max_scale_chnage"), std::string::npos) << error;
  ros::param::set("/params_type/cache_seconds", std::string("ten"));
  EXPECT_FALSE(load("/params_type", &c, &error));
  EXPECT_NE(error.find("cache_seconds"), std::string::npos) << error;
  ros::param::set("/params_nested/motion_analysis/max_features", true);
  EXPECT_FALSE(load("/params_nested", &c, &error));
  EXPECT_NE(error.find("motion_analysis.max_features"), std::string::npos) << error;
  ros::param::set("/params_value/queue_size", -3);
  EXPECT_FALSE(load("/params_value", &c, &error));
  EXPECT_NE(error.find("queue_size"), std::string::npos) << error;
  EXPECT_EQ(c.pipeline.cache_seconds, before.pipeline.cache_seconds);
  EXPECT_EQ(c.ros.image_transport, before.ros.image_transport);
}

TEST(Params, NodeletWithABadParameterDoesNotStart) {
  ASSERT_TRUE(ros::service::waitForService("add_region", ros::Duration(30)));
  // The two bad loads have been refused once the manager lists the good one
  // alone for a while (their load calls run at the same time as its).
  std::set<std::string> loaded;
  spinUntil([] { return false; }, 3.0);
  ASSERT_TRUE(imt::test::loadedNodelets("/manager", &loaded));
  EXPECT_EQ(loaded.count("/good_tracker"), 1u);
  EXPECT_EQ(loaded.count("/misspelt_tracker"), 0u);
  EXPECT_EQ(loaded.count("/mistyped_tracker"), 0u);
  EXPECT_FALSE(ros::service::exists("misspelt/add_region", false));
  EXPECT_FALSE(ros::service::exists("mistyped/add_region", false));
  // The manager and the good nodelet live on: its service answers.
  instant_motion_tracking::AddRegion add;
  add.request.width = add.request.height = 10;
  ASSERT_TRUE(imt::test::callService("add_region", add));
  EXPECT_FALSE(add.response.success);  // no frame yet: refused with a message
  EXPECT_FALSE(add.response.message.empty());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_params");
  ros::NodeHandle nh;
  return RUN_ALL_TESTS();
}
