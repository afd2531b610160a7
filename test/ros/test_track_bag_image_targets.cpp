// track_bag with an image target (INIT.yaml image_targets): a rendered
// poster_orbit bag whose poster is painted from a picture file (make_scene
// --target-texture, whose --init gives the target by that picture), the
// planar_targets.csv rows scored against the scene's ground truth.
#include "track_bag_fixture.h"

#include "instant_motion_tracking/sim/scene.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace imt {
namespace {

// The picture: a procedural texture (the scene generator's kind) cut to
// the poster's 4:3.
cv::Mat picture() { return proceduralTexture(1024, 7)(cv::Rect(0, 0, 1024, 768)).clone(); }

// A suite of its own (the fixture class is per translation unit).
class TrackBagImageTargets : public TrackBag {};

TEST_F(TrackBagImageTargets, FoundFromItsPictureAndTracked) {
  const std::string png = path("poster_picture.png");
  ASSERT_TRUE(cv::imwrite(png, picture()));
  const std::string bag = path("poster.bag"), truth = path("poster_truth.json"), init = path("poster_init.yaml");
  const std::string make = std::string(IMT_BIN_DIR) + "/make_scene --preset poster_orbit --duration 3 --quiet" +
                           " --target-texture " + quote(png) + " --out " + quote(bag) + " --truth " + quote(truth) +
                           " --init " + quote(init);
  ASSERT_EQ(std::system(make.c_str()), 0) << make;
  ASSERT_NE(readFile(init).find("image_targets:"), std::string::npos) << readFile(init);
  EXPECT_EQ(readFile(init).find("planar_targets:"), std::string::npos) << readFile(init);

  const std::string out = path("out_poster");
  const ToolRun r = run("--bag " + quote(bag) + " --init " + quote(init) + " --out-dir " + quote(out) + " --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json t = nlohmann::json::parse(readFile(truth));
  const auto rows = readCsv(out + "/planar_targets.csv");
  const size_t n = t["frames"].size();
  ASSERT_EQ(rows.size(), 1 + n);
  std::vector<double> errors;
  int not_found = 0;
  for (size_t k = 0; k < n; ++k) {
    const auto& row = rows[1 + k];
    ASSERT_EQ(row.size(), 18u);
    EXPECT_EQ(row[0], formatFixed(t["frames"][k]["stamp"].get<double>(), 9)) << k;
    if (row[17] == "not_found") {
      ++not_found;
      EXPECT_EQ(row[2], "") << "no corners before it is found";
      continue;
    }
    ASSERT_EQ(row[17], "tracked") << "frame " << k;
    double sq = 0;
    for (int c = 0; c < 4; ++c) {
      const auto& g = t["frames"][k]["planar_targets"][0]["corners"][c];
      sq += std::pow(std::stod(row[2 + 2 * c]) - g[0].get<double>(), 2) +
            std::pow(std::stod(row[3 + 2 * c]) - g[1].get<double>(), 2);
    }
    errors.push_back(std::sqrt(sq / 4));
  }
  std::sort(errors.begin(), errors.end());
  ASSERT_FALSE(errors.empty());
  std::printf("track_bag image target: not_found on %d of %zu frames; corner error median %.3f px, worst %.3f px\n",
              not_found, n, errors[errors.size() / 2], errors.back());
  // The poster is in view from the first frame: found within the issue's
  // 0.5 s (15 frames at 30 frames/s).
  EXPECT_LE(not_found, 15);
  // Then aligned with its picture every frame: measured 0.012 px median
  // (a target given by its corners: 0.017 px); 0.1 px leaves 8x margin.
  EXPECT_LE(errors[errors.size() / 2], 0.1);
  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["init_entries"]["image_targets"], 1);
}

TEST_F(TrackBagImageTargets, WhosePictureCannotBeReadIsNamed) {
  const std::string init = writeText("bad_picture.yaml",
                                     "image_targets:\n  - {id: 2, image: missing.png, size: [0.6, 0.45]}\n");
  const ToolRun r = run("--bag " + quote(good_) + " --init " + quote(init) + " --out-dir " + quote(path("out_bad")));
  EXPECT_EQ(r.status, 1);
  EXPECT_NE(r.err.find("image_targets[0] (id 2): cannot read image '" + dir_ + "/missing.png'"), std::string::npos)
      << r.err;
}

}  // namespace
}  // namespace imt
