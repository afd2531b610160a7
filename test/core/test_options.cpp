#include "instant_motion_tracking/core/options.h"

#include <gtest/gtest.h>

#include <cmath>

namespace imt {

TEST(Options, DefaultsAreValid) {
  EXPECT_EQ(PipelineOptions().validate(), "");
}

TEST(Options, ValidateNamesTheBadField) {
  PipelineOptions o;
  o.motion_analysis.max_features = 0;
  EXPECT_NE(o.validate().find("motion_analysis.max_features"), std::string::npos) << o.validate();
  o = PipelineOptions();
  o.cache_seconds = -1;
  EXPECT_NE(o.validate().find("cache_seconds"), std::string::npos) << o.validate();
  o = PipelineOptions();
  o.motion_analysis.quality_level = std::nan("");
  EXPECT_NE(o.validate().find("quality_level"), std::string::npos) << o.validate();
}

}  // namespace imt
