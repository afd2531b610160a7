// track_bag on bad input: a non-zero status and one line on stderr naming
// the problem, never a crash or a hang (see track_bag_fixture.h).
#include "track_bag_fixture.h"

namespace imt {
namespace {

// --- bad inputs: non-zero status, one line on stderr naming the problem -------

struct BadCase {
  const char* name;
  // Returns the arguments; may write files first.
  std::function<std::string(const std::string& dir, const std::string& good)> args;
  std::string message;  // expected in the error line (after "track_bag: error: ")
  int status = 1;
  std::string env;
};

void PrintTo(const BadCase& c, std::ostream* os) { *os << c.name; }

class TrackBagBadInput : public TrackBag, public ::testing::WithParamInterface<BadCase> {};

TEST_P(TrackBagBadInput, FailsWithOneLineNamingTheProblem) {
  const BadCase& c = GetParam();
  const ToolRun r = run(c.args(dir_, good_), c.env);
  ASSERT_NE(r.status, 124) << "timed out (hang)";
  EXPECT_EQ(r.status, c.status) << r.err;
  ASSERT_EQ(r.errLines().size(), 1u) << r.err;
  const std::string line = r.errLines()[0];
  EXPECT_EQ(line.rfind("track_bag: error: ", 0), 0u) << line;
  EXPECT_NE(line.find(c.message), std::string::npos) << "got:      " << line << "\nexpected: " << c.message;
  EXPECT_EQ(r.out, "");
}

std::string q(const std::string& s) { return quote(s); }

std::string withBag(const std::string& dir, const std::string& name, const BagSpec& spec,
                    const std::string& extra = "") {
  writeBag(dir + "/" + name, spec);
  return "--bag " + q(dir + "/" + name) + " --out-dir " + q(dir + "/out_bad") + " " + extra;
}

std::string withInit(const std::string& dir, const std::string& good, const std::string& yaml) {
  std::ofstream(dir + "/bad_init.yaml") << yaml;
  return "--bag " + q(good) + " --init " + q(dir + "/bad_init.yaml") + " --out-dir " +
         q(dir + "/out_bad");
}

BagSpec rawWithEncoding(const std::string& e) {
  BagSpec s;
  s.bad_frame = 3;
  s.bad_encoding = e;
  return s;
}

std::vector<BadCase> badCases() {
  using D = const std::string&;
  std::vector<BadCase> v;
  auto add = [&](const char* name, std::function<std::string(D, D)> args, std::string message,
                 int status = 1, std::string env = "") {
    v.push_back({name, std::move(args), std::move(message), status, std::move(env)});
  };
  // The bag itself.
  add("nonexistent_bag", [](D d, D) { return "--bag " + q(d + "/nope.bag") + " --out-dir " + q(d + "/o"); },
      "cannot open bag '/", 1);
  add("truncated_bag", [](D d, D good) {
        const std::string bytes = readFile(good);
        std::ofstream(d + "/truncated.bag", std::ios::binary) << bytes.substr(0, bytes.size() / 2);
        return "--bag " + q(d + "/truncated.bag") + " --out-dir " + q(d + "/o");
      },
      "truncated.bag' (not a rosbag, or truncated)");
  add("text_file_named_bag", [](D d, D) {
        std::ofstream(d + "/text.bag") << "hello, I am not a bag\n";
        return "--bag " + q(d + "/text.bag") + " --out-dir " + q(d + "/o");
      },
      "text.bag' (not a rosbag, or truncated): Error reading version line");
  add("unindexed_bag", [](D d, D good) {
        // A recording that was never closed: index_pos still 0 in the header.
        std::string bytes = readFile(good);
        const size_t at = bytes.find("index_pos=");
        if (at != std::string::npos) bytes.replace(at + 10, 8, std::string(8, '\0'));
        std::ofstream(d + "/unindexed.bag", std::ios::binary) << bytes;
        return "--bag " + q(d + "/unindexed.bag") + " --out-dir " + q(d + "/o");
      },
      "unindexed.bag' is not indexed");
  add("directory_as_bag", [](D d, D) { return "--bag " + q(d) + " --out-dir " + q(d + "/o"); },
      "not a regular file");
  // Topics.
  add("no_image_topic", [](D d, D) {
        BagSpec s;
        s.frames = 0;  // IMU-less, image-less: only /tf_static
        return withBag(d, "no_image.bag", s);
      },
      "no_image.bag' has no sensor_msgs/Image or sensor_msgs/CompressedImage topic");
  add("two_image_topics", [](D d, D) {
        BagSpec s;
        s.extra = [](rosbag::Bag& bag) {
          bag.write("/cam2/image_raw", ros::Time(1000.0),
                    rawImage(frameImage(0, 16, 12), "mono8", std_msgs::Header()));
        };
        return withBag(d, "two_images.bag", s);
      },
      "has several image topics (/cam/image_raw, /cam2/image_raw): choose one with --image-topic");
  add("image_topic_not_in_bag", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --image-topic /nope";
      },
      "image topic '/nope' is not in the bag (image topics: /cam/image_raw)");
  add("image_topic_of_other_type", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --image-topic /imu/data";
      },
      "topic '/imu/data' is a sensor_msgs/Imu, not a sensor_msgs/Image or sensor_msgs/CompressedImage");
  add("camera_info_topic_not_in_bag", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --camera-info-topic /x/camera_info";
      },
      "camera_info topic '/x/camera_info' is not in the bag");
  add("imu_topic_not_in_bag", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --imu-topic /imu2";
      },
      "IMU topic '/imu2' is not in the bag (Imu topics: /imu/data)");
  add("two_imu_topics", [](D d, D) {
        BagSpec s;
        s.extra = [](rosbag::Bag& bag) {
          sensor_msgs::Imu m;
          bag.write("/imu2", ros::Time(1000.0), m);
        };
        return withBag(d, "two_imus.bag", s);
      },
      "has several sensor_msgs/Imu topics (/imu/data, /imu2): choose one with --imu-topic");
  // Images: a bag without one usable frame (a malformed frame among good
  // ones is dropped, as live: TrackBagMalformedFrame below).
  add("every_image_malformed", [](D d, D) {
        BagSpec s;
        s.edit_image = [](int, sensor_msgs::Image& m) { m.encoding = "32FC1"; };
        return withBag(d, "all_bad.bag", s);
      },
      "no usable image on /cam/image_raw: all 20 frame(s) are malformed (first: frame 0 (stamp 1000.000000) on "
      "/cam/image_raw: unsupported image encoding '32FC1' (supported: mono8, mono16, bgr8, rgb8, bgra8, rgba8))");
  add("only_compressed_image_corrupt", [](D d, D) {
        BagSpec s;
        s.compressed = "png";
        s.frames = 1;
        s.corrupt_frame = 0;
        return withBag(d, "only_corrupt.bag", s);
      },
      "no usable image on /cam/image_raw/compressed: all 1 frame(s) are malformed (first: frame 0 (stamp "
      "1000.000000) on /cam/image_raw/compressed: cannot decode the compressed image (format 'mono8; png compressed "
      "mono8'");
  add("init_at_a_malformed_frame", [](D d, D) {
        std::ofstream(d + "/init_frame3.yaml") << "regions:\n  - {id: 1, stamp: 1000.1, box: [40, 30, 50, 40]}\n";
        return withBag(d, "bad_frame3.bag", rawWithEncoding("32FC1"), "--init " + q(d + "/init_frame3.yaml"));
      },
      "init_frame3.yaml: regions (id 1): stamp 1000.100000 is not within half a frame of any cached frame (frame 3 "
      "was dropped: unsupported image encoding '32FC1'");
  // INIT.yaml.
  add("init_missing_file", [](D d, D good) {
        return "--bag " + q(good) + " --init " + q(d + "/nope.yaml") + " --out-dir " + q(d + "/o");
      },
      "nope.yaml: cannot open the init file");
  add("init_invalid_yaml", [](D d, D g) { return withInit(d, g, "regions: [\n  - id: 1\n"); },
      "bad_init.yaml: invalid YAML at line 2, column 3");
  add("init_missing_field", [](D d, D g) { return withInit(d, g, "regions:\n  - {id: 7, stamp: 1000}\n"); },
      "bad_init.yaml: regions[0] (id 7): missing field 'box'");
  add("init_wrong_length", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 7, stamp: 1000, box: [1, 2, 3]}\n");
      },
      "bad_init.yaml: regions[0] (id 7): box must have 4 numbers, got 3");
  add("init_non_positive_size", [](D d, D g) {
        return withInit(d, g, "planar_targets:\n  - {id: 1, stamp: 1000, corners: [[0, 0], [9, 0], [9, 9], [0, 9]], size: [0.2, -1]}\n");
      },
      "bad_init.yaml: planar_targets[0] (id 1): target size must be positive (got 0.200000 x -1.000000 m)");
  add("init_non_positive_depth", [](D d, D g) {
        return withInit(d, g, "anchors:\n  - {id: 1, stamp: 1000, point: [5, 5], depth: -2}\n");
      },
      "bad_init.yaml: anchors[0] (id 1): depth must be positive and within 0.01 .. 10000 m (0 = anchors.default_depth), got -2");
  add("init_nan", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 7, stamp: 1000, box: [1, .nan, 3, 4]}\n");
      },
      "bad_init.yaml: regions[0] (id 7): box has a NaN or infinite value");
  add("init_duplicate_id", [](D d, D g) {
        return withInit(d, g, "anchors:\n  - {id: 1, stamp: 1000, point: [5, 5]}\n  - {id: 1, stamp: 1000.1, point: [6, 6]}\n");
      },
      "bad_init.yaml: anchors[1] (id 1): anchor id 1 is already tracked (also anchors[0])");
  add("init_bad_id", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 2.5, stamp: 1000, box: [1, 2, 3, 4]}\n");
      },
      "bad_init.yaml: regions[0]: id must be a positive integer, got '2.5'");
  add("init_unknown_key", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 7, stamp: 1000, bbox: [1, 2, 3, 4]}\n");
      },
      "bad_init.yaml: regions[0] (id 7): unknown key 'bbox' (expected id, stamp, box)");
  add("init_unknown_list", [](D d, D g) { return withInit(d, g, "targets: []\n"); },
      "bad_init.yaml: unknown list 'targets' (expected regions, planar_targets, image_targets, anchors)");
  add("init_empty", [](D d, D g) { return withInit(d, g, ""); },
      "bad_init.yaml: empty (expected a mapping with regions, planar_targets, image_targets and/or anchors)");
  add("init_stamp_outside_bag", [](D d, D g) {
        return withInit(d, g, "regions:\n  - {id: 7, stamp: 1234.5, box: [1, 2, 3, 4]}\n");
      },
      "bad_init.yaml: regions[0] (id 7): stamp 1234.5 is outside the bag (frames 1000.000000 .. 1000.633333)");
  // Options and configuration.
  add("missing_out_dir", [](D, D good) { return "--bag " + q(good); }, "missing --out-dir (see --help)", 2);
  add("missing_bag", [](D d, D) { return "--out-dir " + q(d + "/o"); }, "missing --bag (see --help)", 2);
  add("unknown_option", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --frobnicate 3";
      },
      "unknown option '--frobnicate' (see --help)", 2);
  add("stray_argument", [](D d, D good) { return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " extra"; },
      "unexpected argument 'extra'", 2);
  add("option_without_value", [](D, D good) { return "--out-dir /tmp/x --bag"; },
      "option --bag needs a value", 2);
  add("option_twice", [](D d, D good) {
        return "--bag " + q(good) + " --bag " + q(good) + " --out-dir " + q(d + "/o");
      },
      "option --bag given twice", 2);
  add("bad_start", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --start soon";
      },
      "--start: expected a non-negative number of seconds, got 'soon'", 2);
  add("end_before_start", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --start 2 --end 1";
      },
      "--end 1 must be after --start 2", 2);
  add("start_past_the_end", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --start 5";
      },
      "--start 5.000 s is past the end of bag '");
  add("window_without_frames", [](D d, D good) {
        // Frames at 0.6 s and 0.6333 s after the start: none in 0.61 .. 0.62.
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --start 0.61 --end 0.62";
      },
      "no image messages on /cam/image_raw between 0.610 s and 0.620 s after the bag's start");
  add("bad_config", [](D d, D good) {
        std::ofstream(d + "/bad_config.yaml") << "nonsense: 1\n";
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --config " + q(d + "/bad_config.yaml");
      },
      "bad_config.yaml: unknown parameter 'nonsense'");
  add("config_missing", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --config " + q(d + "/nope_config.yaml");
      },
      "nope_config.yaml: cannot open the config file");
  add("default_config_not_found", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o");
      },
      "cannot find config/default.yaml of package instant_motion_tracking (source the workspace's "
      "setup.bash, or pass --config FILE)",
      1, "env -u ROS_PACKAGE_PATH");
  add("out_dir_is_a_file", [](D d, D good) {
        std::ofstream(d + "/a_file") << "x";
        return "--bag " + q(good) + " --out-dir " + q(d + "/a_file");
      },
      "cannot create --out-dir '");
  add("out_bag_unwritable", [](D d, D good) {
        return "--bag " + q(good) + " --out-dir " + q(d + "/o") + " --out-bag " + q(d + "/no/such/dir/out.bag");
      },
      "cannot create --out-bag '");
  add("out_bag_is_the_input", [](D d, D good) {
        fs::copy_file(good, d + "/copy.bag", fs::copy_options::overwrite_existing);
        return "--bag " + q(d + "/copy.bag") + " --out-dir " + q(d + "/o") + " --out-bag " + q(d + "/./copy.bag");
      },
      "/./copy.bag' is the input bag");
  return v;
}

INSTANTIATE_TEST_SUITE_P(Each, TrackBagBadInput, ::testing::ValuesIn(badCases()),
                         [](const auto& info) { return std::string(info.param.name); });

// --- a malformed frame among good ones: dropped, as live (issue 16) ----------
// The run goes on (status 0); one warning per cause, with its count and the
// first frame; summary.json frames_dropped.malformed_image; no row for the
// frame. Before, the first such frame stopped the run (status 1).

struct MalformedCase {
  const char* name;
  BagSpec spec;
  int dropped;                        // frames dropped as malformed
  std::vector<std::string> warnings;  // stderr, in order
};

void PrintTo(const MalformedCase& c, std::ostream* os) { *os << c.name; }

class TrackBagMalformedFrame : public TrackBag, public ::testing::WithParamInterface<MalformedCase> {};

TEST_P(TrackBagMalformedFrame, IsDroppedWarnedOncePerCauseAndCounted) {
  const MalformedCase& c = GetParam();
  const std::string out = path(std::string("out_malformed_") + c.name);
  const ToolRun r = run("--bag " + quote(makeBag(std::string(c.name) + ".bag", c.spec)) + " --out-dir " + quote(out));
  ASSERT_NE(r.status, 124) << "timed out (hang)";
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(), c.warnings);
  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  const int frames = c.spec.frames + (c.spec.extra ? 1 : 0);
  EXPECT_EQ(j["frames_dropped"]["malformed_image"], c.dropped);
  EXPECT_EQ(j["frames"], frames - c.dropped);
  EXPECT_EQ(readCsv(out + "/camera_motion.csv").size(), 1u + frames - c.dropped);
  EXPECT_EQ(j["messages"].size(), c.warnings.size());
}

std::vector<MalformedCase> malformedCases() {
  const std::string kFrame3 = "(first: frame 3 (stamp 1000.100000) on /cam/image_raw)";
  std::vector<MalformedCase> v;
  {
    BagSpec s = rawWithEncoding("32FC1");
    v.push_back({"encoding_32FC1", s, 1,
                 {"track_bag: warning: 1 malformed frame(s) dropped: unsupported image encoding '32FC1' (supported: "
                  "mono8, mono16, bgr8, rgb8, bgra8, rgba8) " + kFrame3}});
  }
  {
    BagSpec s = rawWithEncoding("yuv422");
    v.push_back({"encoding_yuv422", s, 1,
                 {"track_bag: warning: 1 malformed frame(s) dropped: unsupported image encoding 'yuv422' (supported: "
                  "mono8, mono16, bgr8, rgb8, bgra8, rgba8) " + kFrame3}});
  }
  {
    BagSpec s;
    s.compressed = "png";
    s.corrupt_frame = 2;
    v.push_back({"corrupt_compressed_image", s, 1,
                 {"track_bag: warning: 1 malformed frame(s) dropped: cannot decode the compressed image (format "
                  "'mono8; png compressed mono8', 13525 bytes) [libpng warning: ZZZZ: chunk data is too large;libpng "
                  "error: PNG input buffer is incomplete] (first: frame 2 (stamp 1000.066667) on "
                  "/cam/image_raw/compressed)"}});
  }
  {
    BagSpec s;
    s.extra = [](rosbag::Bag& bag) {
      sensor_msgs::Image m = rawImage(frameImage(0, 160, 120), "mono8", std_msgs::Header());
      m.header.stamp = ros::Time(1001.0);
      m.height = 240;  // claims twice the rows it has
      bag.write("/cam/image_raw", ros::Time(1001.0), m);
    };
    v.push_back({"image_data_shorter_than_claimed", s, 1,
                 {"track_bag: warning: 1 malformed frame(s) dropped: image data has 19200 bytes, step x height is "
                  "38400 (first: frame 20 (stamp 1001.000000) on /cam/image_raw)"}});
  }
  {
    // Several causes, several frames each: one line per cause with its
    // count, in the order they first came (the data cut at different
    // lengths is one cause).
    BagSpec s;
    s.edit_image = [](int i, sensor_msgs::Image& m) {
      if (i == 4 || i == 9 || i == 15) m.step = m.width - 1;             // a row is 160 bytes
      if (i == 6 || i == 11) m.data.resize(m.data.size() / (i == 6 ? 2 : 3));  // truncated
    };
    v.push_back({"steps_and_truncations", s, 5,
                 {"track_bag: warning: 3 malformed frame(s) dropped: image step 159 is shorter than a row (160 px of "
                  "mono8 = 160 bytes) (first: frame 4 (stamp 1000.133333) on /cam/image_raw)",
                  "track_bag: warning: 2 malformed frame(s) dropped: image data has 9600 bytes, step x height is "
                  "19200 (first: frame 6 (stamp 1000.200000) on /cam/image_raw)"}});
  }
  return v;
}

INSTANTIATE_TEST_SUITE_P(Each, TrackBagMalformedFrame, ::testing::ValuesIn(malformedCases()),
                         [](const auto& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace imt
