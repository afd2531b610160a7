// Shared helpers of the scene-generator tests: a preset's options (failing
// the test for an unknown name) and a generator (failing it on bad options).
#pragma once

#include "instant_motion_tracking/sim/scene.h"

#include <gtest/gtest.h>

#include <memory>
#include <optional>
#include <string>

namespace imt {
namespace test {

inline SceneOptions preset(const std::string& name) {
  std::optional<SceneOptions> o = SceneOptions::fromPreset(name);
  EXPECT_TRUE(o.has_value()) << name;
  return o ? *o : SceneOptions();
}

inline std::unique_ptr<SceneGenerator> make(const SceneOptions& o) {
  std::string err;
  auto scene = SceneGenerator::create(o, &err);
  EXPECT_TRUE(scene != nullptr) << err;
  return scene;
}

}  // namespace test
}  // namespace imt
