// End-to-end tests of the track_bag tool: small bags written here with the
// rosbag C++ API, the built binary run on them, its exit status, stderr and
// output files checked. Every run is wrapped in `timeout 60`, so a hang fails
// (status 124) instead of blocking the suite.
#include "track_bag_fixture.h"

#include <cstdio>

namespace imt {
namespace {

// --- good runs ----------------------------------------------------------------

// Every supported image kind gives one camera_motion row per frame, stamped
// with the frame's header stamp, and the other CSVs with their headers.
struct ImageKind {
  const char* name;
  const char* encoding;
  const char* compressed;
};

void PrintTo(const ImageKind& k, std::ostream* os) { *os << k.name; }

class TrackBagImageKinds : public TrackBag, public ::testing::WithParamInterface<ImageKind> {};

TEST_P(TrackBagImageKinds, WritesOneCameraMotionRowPerFrame) {
  BagSpec spec;
  spec.encoding = GetParam().encoding;
  spec.compressed = GetParam().compressed;
  const std::string bag = makeBag(std::string(GetParam().name) + ".bag", spec);
  const std::string out = path(std::string("out_") + GetParam().name);
  const ToolRun r = run("--bag " + quote(bag) + " --out-dir " + quote(out) + " --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.err, "");  // nothing to warn about in a clean bag without --init

  const auto rows = readCsv(out + "/camera_motion.csv");
  ASSERT_EQ(rows.size(), 1u + spec.frames);
  EXPECT_EQ(readFile(out + "/camera_motion.csv").substr(0, std::string(kHeaderCameraMotion).size() + 1),
            std::string(kHeaderCameraMotion) + "\n");
  for (int i = 0; i < spec.frames; ++i) {
    const auto& row = rows[1 + i];
    ASSERT_EQ(row.size(), 13u) << "row " << i;
    // Stamps are the header stamps, written with 9 decimals (spec: >= 6).
    EXPECT_EQ(row[0], formatFixed(ros::Time(frameStamp(spec, i)).toSec(), 9));
    const std::string model = row[1];
    EXPECT_TRUE(model == "invalid" || model == "translation" || model == "similarity" ||
                model == "homography")
        << model;
    EXPECT_EQ(row[10], "1") << "H(2,2) = 1";
    if (i == 0) {
      // First frame: invalid with the identity (spec).
      EXPECT_EQ(model, "invalid");
      EXPECT_EQ(std::vector<std::string>(row.begin() + 2, row.begin() + 11),
                (std::vector<std::string>{"1", "0", "0", "0", "1", "0", "0", "0", "1"}));
    } else if (model != "invalid") {
      // The texture moves 1 px left per frame. 0.25 px: sub-pixel LK on a
      // blurred random texture (JPEG included) is far better than that; a
      // sign or axis error would be off by >= 1 px.
      EXPECT_NEAR(std::stod(row[4]), -1.0, 0.25) << "frame " << i;
      EXPECT_NEAR(std::stod(row[7]), 0.0, 0.25) << "frame " << i;
    }
  }
  EXPECT_EQ(readFile(out + "/regions.csv"),
            "stamp,id,x,y,width,height,status,confidence,angle,rect_width,rect_height\n");
  EXPECT_EQ(readFile(out + "/planar_targets.csv"),
            "stamp,id,x0,y0,x1,y1,x2,y2,x3,y3,tx,ty,tz,qx,qy,qz,qw,status\n");
  EXPECT_EQ(readFile(out + "/anchors.csv"), "stamp,id,u,v,tx,ty,tz,qx,qy,qz,qw,status\n");

  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["frames"], spec.frames);
  EXPECT_GT(j["seconds"].get<double>(), 0.0);
  EXPECT_GT(j["frames_per_second"].get<double>(), 0.0);
  EXPECT_TRUE(j["stages"].contains("motion_analysis"));
  EXPECT_TRUE(j["stages"].contains("decode"));
  EXPECT_EQ(j["image_topic"], spec.compressed.empty() ? "/cam/image_raw" : "/cam/image_raw/compressed");
  // The sibling camera_info is found for the compressed topic too.
  EXPECT_EQ(j["camera_info_topic"], "/cam/camera_info");
  EXPECT_EQ(j["intrinsics"]["source"], "camera_info");
  EXPECT_DOUBLE_EQ(j["intrinsics"]["fx"].get<double>(), 100.0);
  // CameraInfo's principal point (OpenCV pixel centres) + 0.5 = ours: the centre.
  EXPECT_DOUBLE_EQ(j["intrinsics"]["cx"].get<double>(), spec.width / 2.0);
  EXPECT_EQ(j["imu_samples"], 7 * spec.frames);
}

INSTANTIATE_TEST_SUITE_P(Each, TrackBagImageKinds,
                         ::testing::Values(ImageKind{"mono8", "mono8", ""},
                                           ImageKind{"mono16", "mono16", ""},
                                           ImageKind{"bgr8", "bgr8", ""},
                                           ImageKind{"rgba8", "rgba8", ""},
                                           ImageKind{"png", "mono8", "png"},
                                           ImageKind{"jpeg", "mono8", "jpeg"}),
                         [](const auto& info) { return std::string(info.param.name); });

TEST_F(TrackBag, InitEntriesAtAnyFrameOutBagAndRotationFromTfStatic) {
  // Entries given at a middle frame (stamp copied with 6 decimals, as from a
  // CSV) and at the last one.
  const std::string init = writeText("init_ok.yaml",
                                     "regions:\n"
                                     "  - {id: 1, stamp: 1000.333333, box: [10, 10, 40, 30]}\n"
                                     "planar_targets:\n"
                                     "  - {id: 1, stamp: 1000.6333333333, corners: [[10, 10], [50, 12], [48, 40], [12, 38]], size: [0.2, 0.15]}\n"
                                     "anchors:\n"
                                     "  - {id: 2, stamp: 1000.1, point: [80, 60]}\n");
  const std::string out = path("out_init");
  const std::string out_bag = path("out_init.bag");
  const ToolRun r = run("--bag " + quote(good_) + " --init " + quote(init) + " --out-dir " +
                    quote(out) + " --out-bag " + quote(out_bag));
  ASSERT_EQ(r.status, 0) << r.err;
  // Nothing to say; no progress bar (stderr is a file, not a terminal).
  EXPECT_EQ(r.errLines(), std::vector<std::string>{}) << r.err;
  // The anchor (given at frame 3) has a row for every frame; at its own frame
  // it sits at the tapped pixel, 1 m (the default depth) along its ray.
  const auto anchors = readCsv(out + "/anchors.csv");
  ASSERT_EQ(anchors.size(), 1u + 20);
  EXPECT_EQ(anchors[1 + 3][1], "2");
  EXPECT_NEAR(std::stod(anchors[1 + 3][2]), 80.0, 1e-6);
  EXPECT_NEAR(std::stod(anchors[1 + 3][3]), 60.0, 1e-6);
  const double tx = std::stod(anchors[1 + 3][4]), ty = std::stod(anchors[1 + 3][5]), tz = std::stod(anchors[1 + 3][6]);
  EXPECT_NEAR(std::sqrt(tx * tx + ty * ty + tz * tz), 1.0, 1e-6);
  // The region (given at frame 10) and the planar target (given at the last
  // frame) have a row for every frame of the bag, backwards and forwards.
  const auto regions = readCsv(out + "/regions.csv");
  ASSERT_EQ(regions.size(), 1u + 20);
  for (int i = 0; i < 20; ++i) {
    EXPECT_EQ(regions[1 + i][0], formatFixed(ros::Time(1000.0 + i / 30.0).toSec(), 9)) << i;
    EXPECT_EQ(regions[1 + i][1], "1");
  }
  EXPECT_EQ(regions[1 + 10][2], "10");  // the given box at its own frame
  EXPECT_EQ(regions[1 + 10][5], "30");
  const auto targets = readCsv(out + "/planar_targets.csv");
  ASSERT_EQ(targets.size(), 1u + 20);
  EXPECT_EQ(targets[20][2], "10");  // corner x0 at the given (last) frame

  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["init_entries"]["regions"], 1);
  // R_cam_imu = Rz(90 deg) from /tf_static (cam_optical -> imu_link); 1e-9:
  // only float rounding of sin/cos(pi/4) and the quaternion -> matrix.
  const double expected[3][3] = {{0, -1, 0}, {1, 0, 0}, {0, 0, 1}};
  ASSERT_TRUE(j["R_cam_imu"].is_array()) << j.dump();
  EXPECT_EQ(j["R_cam_imu_source"], "tf");
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b)
      EXPECT_NEAR(j["R_cam_imu"][a][b].get<double>(), expected[a][b], 1e-9) << a << "," << b;

  // The output bag holds one /motion_data per frame with the image's header.
  rosbag::Bag bag(out_bag, rosbag::bagmode::Read);
  rosbag::View view(bag, rosbag::TopicQuery("/motion_data"));
  std::vector<double> stamps;
  for (const rosbag::MessageInstance& m : view) {
    const auto md = m.instantiate<instant_motion_tracking::MotionData>();
    ASSERT_TRUE(md);
    EXPECT_EQ(md->header.frame_id, "cam_optical");
    EXPECT_EQ(md->width, 160u);
    stamps.push_back(md->header.stamp.toSec());
  }
  ASSERT_EQ(stamps.size(), 20u);
  for (int i = 0; i < 20; ++i) EXPECT_NEAR(stamps[i], 1000.0 + i / 30.0, 1e-9);

  // ...one /anchors per frame, as anchors.csv says (1e-6: the CSV's decimals),
  // and each frame's /tf carries anchor_2 (and planar_target_1) under the image frame.
  int i = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery("/anchors"))) {
    const auto a = m.instantiate<instant_motion_tracking::AnchorArray>();
    ASSERT_TRUE(a);
    ASSERT_LT(i, 20);
    EXPECT_EQ(a->header.frame_id, "cam_optical");
    EXPECT_NEAR(a->header.stamp.toSec(), 1000.0 + i / 30.0, 1e-9);
    ASSERT_EQ(a->anchors.size(), 1u);
    EXPECT_EQ(a->anchors[0].id, 2u);
    EXPECT_EQ(a->anchors[0].status, anchors[1 + i][11]);
    if (anchors[1 + i][11] != "lost") {
      EXPECT_NEAR(a->anchors[0].u, std::stod(anchors[1 + i][2]), 1e-3);
      EXPECT_NEAR(a->anchors[0].pose.position.z, std::stod(anchors[1 + i][6]), 1e-6);
    }
    ++i;
  }
  EXPECT_EQ(i, 20);
  int anchor_tf = 0, target_tf = 0;
  for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery("/tf"))) {
    const auto tf = m.instantiate<tf2_msgs::TFMessage>();
    ASSERT_TRUE(tf);
    for (const auto& t : tf->transforms) {
      EXPECT_EQ(t.header.frame_id, "cam_optical");
      anchor_tf += t.child_frame_id == "anchor_2";
      target_tf += t.child_frame_id == "planar_target_1";
    }
  }
  int anchor_rows_with_pose = 0;
  for (int k = 0; k < 20; ++k) anchor_rows_with_pose += anchors[1 + k][11] != "lost";
  EXPECT_EQ(anchor_tf, anchor_rows_with_pose);
  EXPECT_GT(anchor_tf, 0);
  EXPECT_GT(target_tf, 0);
}

TEST_F(TrackBag, StartAndEndSelectAWindowOfTheBag) {
  // Bag times 1000 + i/30: from 0.2 s to 0.4 s after the first message are
  // frames 6..12 (0.2 = 6/30, 0.4 = 12/30; rosbag's window is inclusive).
  const std::string out = path("out_window");
  const ToolRun r = run("--bag " + quote(good_) + " --out-dir " + quote(out) +
                    " --start 0.19 --end=0.41 --quiet");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto rows = readCsv(out + "/camera_motion.csv");
  ASSERT_EQ(rows.size(), 1u + 7);
  EXPECT_EQ(rows[1][0], formatFixed(ros::Time(1000.0 + 6 / 30.0).toSec(), 9));
  EXPECT_EQ(rows[1][1], "invalid");  // the window's first frame is a first frame
  EXPECT_EQ(rows[7][0], formatFixed(ros::Time(1000.0 + 12 / 30.0).toSec(), 9));

  // An init stamp outside the window is outside what is processed.
  const std::string init = writeText("init_window.yaml",
                                     "regions:\n  - {id: 1, stamp: 1000.0, box: [1, 1, 5, 5]}\n");
  const ToolRun bad = run("--bag " + quote(good_) + " --init " + quote(init) + " --out-dir " +
                      quote(out) + " --start 0.19 --end 0.41");
  EXPECT_EQ(bad.status, 1);
  EXPECT_EQ(bad.err, "track_bag: error: " + init +
                         ": regions[0] (id 1): stamp 1000 is outside the part of the bag given "
                         "by --start/--end (frames 1000.200000 .. 1000.400000)\n");
}

// The time rules (issue 16): a repeated stamp and one slightly behind are
// dropped (not analysed, not written; counted in summary.json, one warning
// naming the first); a jump back of time_jump_reset_seconds (1 s) or more
// resets. Before, the repeated stamp reset the analysis and every item.
TEST_F(TrackBag, StampsRepeatingOrSlightlyBehindAreDroppedAJumpBackResets) {
  BagSpec spec;
  spec.frames = 12;
  for (int i = 0; i < spec.frames; ++i) spec.stamps.push_back(1000.0 + i / 30.0);
  spec.stamps[3] = spec.stamps[2] - 0.005;  // slightly behind
  spec.stamps[5] = spec.stamps[4];          // repeated
  spec.stamps[9] = spec.stamps[8] - 2.0;    // a jump back
  const std::string out = path("out_backwards");
  const ToolRun r = run("--bag " + quote(makeBag("backwards.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  ASSERT_EQ(r.errLines().size(), 2u) << r.err;
  EXPECT_EQ(r.errLines()[0].rfind("track_bag: warning: motion analysis reset 1 time", 0), 0u) << r.err;
  EXPECT_EQ(r.errLines()[1].rfind("track_bag: warning: 2 frame(s) dropped by the time rules (1 repeated stamps, 1 "
                                  "slightly behind the newest; first: frame 3: ",
                                  0),
            0u)
      << r.err;
  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["frames_dropped"]["duplicate_stamp"], 1);
  EXPECT_EQ(j["frames_dropped"]["stamp_behind"], 1);
  EXPECT_EQ(j["frame_gaps"], 0);  // the jump back is a restart, not a gap
  // Frames 3 and 5 are not written; frame 9 (the 8th written) is, its
  // analysis restarted.
  const auto rows = readCsv(out + "/camera_motion.csv");
  ASSERT_EQ(rows.size(), 1u + spec.frames - 2);
  EXPECT_EQ(rows[1 + 7][0], formatFixed(ros::Time(spec.stamps[9]).toSec(), 9));
  EXPECT_EQ(rows[1 + 7][1], "invalid");
  EXPECT_NE(rows[1 + 3][1], "invalid");  // frame 4 follows frame 2: no restart
}

// The frames use the field of view; every camera_info message is refused
// (counted as live: summary.json camera_info_refused, one warning).
TEST_F(TrackBag, FrameSizeOtherThanCameraInfoWarnsOnceAndUsesTheFieldOfView) {
  BagSpec spec;
  spec.info_width = 320;
  spec.info_height = 240;
  const std::string out = path("out_size");
  const ToolRun r = run("--bag " + quote(makeBag("size.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(),
            (std::vector<std::string>{
                "track_bag: warning: image size 160x120 (first at frame 0) differs from "
                "/cam/camera_info's 320x240; intrinsics from default_hfov_deg 60 deg for it",
                // Frame 0 is read before its camera_info (same bag time): all 20 refused.
                "track_bag: warning: 20 camera_info message(s) refused: camera_info size 320x240 differs from the "
                "images' 160x120 (first at stamp 1000.000000)"}));
  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["camera_info_refused"], 20);
  EXPECT_EQ(j["intrinsics"]["source"], "field_of_view");
  // fx = (w / 2) / tan(hfov / 2) = 80 / tan(30 deg); 1e-9: closed form.
  EXPECT_NEAR(j["intrinsics"]["fx"].get<double>(), 80.0 / std::tan(M_PI / 6), 1e-9);
}

// A camera_info mutated in mid-bag (found by fuzzing: it was skipped
// silently) is refused as live: one warning per cause with its count,
// summary.json camera_info_refused; the camera model stays the good one.
TEST_F(TrackBag, RefusedCameraInfoIsWarnedOncePerCauseAndCounted) {
  BagSpec spec;
  spec.edit_info = [](int i, sensor_msgs::CameraInfo& m) {
    if (i == 5) m.K[4] = std::numeric_limits<double>::quiet_NaN();
    if (i == 8 || i == 9) m.K.fill(0.0);
    if (i == 12) m.K[0] = 1e300;
  };
  const std::string out = path("out_info_refused");
  const ToolRun r = run("--bag " + quote(makeBag("info_refused.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(),
            (std::vector<std::string>{
                "track_bag: warning: 1 camera_info message(s) refused: camera_info K has a NaN or infinite entry "
                "(first at stamp 1000.166667)",
                "track_bag: warning: 2 camera_info message(s) refused: camera_info K has no usable focal length "
                "(first at stamp 1000.266667)",
                "track_bag: warning: 1 camera_info message(s) refused: camera_info K focal length (fx 1e+300, fy 100) "
                "is implausible for a 160x120 image (from 0.001 to 1000 times its size) (first at stamp "
                "1000.400000)"}));
  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["camera_info_refused"], 4);
  EXPECT_EQ(j["intrinsics"]["source"], "camera_info");
  EXPECT_EQ(j["intrinsics"]["fx"], 100);  // the good messages' K, kept
  EXPECT_EQ(readCsv(out + "/camera_motion.csv").size(), 1u + spec.frames);  // no frame lost
}

TEST_F(TrackBag, NoCameraInfoNoTfAndNanImuAreNotedOnce) {
  BagSpec spec;
  spec.camera_info = false;
  spec.tf_static = false;
  spec.imu_nan = 3;
  const std::string out = path("out_noinfo");
  const ToolRun r = run("--bag " + quote(makeBag("noinfo.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(),
            (std::vector<std::string>{
                "track_bag: note: no camera_info topic; intrinsics from default_hfov_deg 60 deg",
                "track_bag: warning: dropped 3 IMU sample(s) with NaN/Inf values (first at stamp 1000.000000)",
                "track_bag: warning: IMU-to-camera rotation unknown (no transform between 'cam_optical' and "
                "'imu_link' in the bag (it has no /tf_static or /tf)) and not found from the video (it needs "
                "turns about two axes): anchors are calibrating (translation only)"}));
  const nlohmann::json j = nlohmann::json::parse(readFile(out + "/summary.json"));
  EXPECT_EQ(j["imu_samples"], 7 * spec.frames - 3);
  EXPECT_EQ(j["imu_dropped"], 3);
  EXPECT_TRUE(j["R_cam_imu"].is_null());
  EXPECT_EQ(j["R_cam_imu_source"], "none");
  ASSERT_TRUE(j.contains("R_cam_imu_epipolar"));  // null: no epipolar fit on a bag this short (40 frames needed)
  EXPECT_TRUE(j["R_cam_imu_epipolar"].is_null());
  EXPECT_TRUE(j["camera_info_topic"].is_null());
  EXPECT_EQ(j["intrinsics"]["source"], "field_of_view");
}

TEST_F(TrackBag, AnchorsWithoutImuAreTranslationOnly) {
  BagSpec spec;
  spec.imu = false;
  const std::string init = writeText("init_anchor.yaml", "anchors:\n  - {id: 4, stamp: 1000.0, point: [80, 60], depth: 2.0}\n");
  const std::string out = path("out_noimu");
  const ToolRun r = run("--bag " + quote(makeBag("noimu.bag", spec)) + " --init " + quote(init) +
                        " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(), (std::vector<std::string>{
                              "track_bag: warning: no usable IMU in the bag: anchors are translation-only (status no_imu)"}));
  const auto rows = readCsv(out + "/anchors.csv");
  ASSERT_EQ(rows.size(), 1u + spec.frames);
  for (size_t i = 1; i < rows.size(); ++i) EXPECT_EQ(rows[i][11], "no_imu") << i;
  // At its frame: the tapped pixel, 2 m along its ray (the given depth).
  const double tx = std::stod(rows[1][4]), ty = std::stod(rows[1][5]), tz = std::stod(rows[1][6]);
  EXPECT_NEAR(std::sqrt(tx * tx + ty * ty + tz * tz), 2.0, 1e-6);
}

// A still view of texture A for 20 frames, then 70 frames of an unrelated
// still view B, then A again (110 frames): a region given on A stops looking
// like itself, is lost, and is found again when A is back.
BagSpec lostAndFoundSpec() {
  BagSpec spec;
  spec.frames = 110;
  const cv::Mat a = frameImage(0, spec.width, spec.height);
  cv::Mat b;
  cv::flip(frameImage(300, spec.width, spec.height), b, -1);
  spec.image = [a, b](int i) { return i < 20 || i >= 90 ? a : b; };
  return spec;
}

TEST_F(TrackBag, RegionLostAndFoundAgainIsNotedWithItsReason) {
  const BagSpec spec = lostAndFoundSpec();
  const std::string init = writeText("init_lost.yaml", "regions:\n  - {id: 1, stamp: 1000.0, box: [40, 30, 50, 40]}\n");
  const std::string out = path("out_lost");
  const ToolRun r = run("--bag " + quote(makeBag("lost.bag", spec)) + " --init " + quote(init) + " --out-dir " +
                        quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  const auto rows = readCsv(out + "/regions.csv");
  ASSERT_EQ(rows.size(), 1u + spec.frames);
  int lost_at = -1, found_at = -1;
  for (int i = 1; i <= spec.frames; ++i) {
    if (rows[i][6] == "lost" && lost_at < 0) lost_at = i - 1;
    if (rows[i][6] == "tracked" && lost_at >= 0 && found_at < 0) found_at = i - 1;
  }
  // Lost while B is in view (after appearance_lost_frames or three times
  // that), found on A's first frame back (its look matches exactly there).
  EXPECT_GT(lost_at, 20);
  EXPECT_LT(lost_at, 90);
  EXPECT_EQ(found_at, 90);
  EXPECT_NEAR(std::stod(rows[1 + found_at][2]), 40.0, 1.0);
  EXPECT_NEAR(std::stod(rows[1 + found_at][3]), 30.0, 1.0);
  bool said_lost = false, said_found = false;
  for (const std::string& l : r.errLines()) {
    said_lost = said_lost || l.find("note: region 1 lost at stamp") != std::string::npos;
    said_found = said_found || (l.find("note: region 1 tracked again at stamp") != std::string::npos &&
                                l.find("re-acquired by its appearance") != std::string::npos);
  }
  EXPECT_TRUE(said_lost) << r.err;
  EXPECT_TRUE(said_found) << r.err;
}

// The same bag with an image budget of one frame: the regions' look reads
// the frames the cache dropped again from the bag, so the region is tracked
// exactly as with every frame kept (live has every frame). Without them it
// ran on motion data alone through the dropped frames: no look taken at
// frame 0, never lost while B is in view.
TEST_F(TrackBag, RegionsReadTheFramesBeyondTheImageBudgetAgain) {
  const BagSpec spec = lostAndFoundSpec();
  const std::string bag = makeBag("budget.bag", spec);
  const std::string init =
      writeText("init_budget.yaml", "regions:\n  - {id: 1, stamp: 1000.0, box: [40, 30, 50, 40]}\n");
  // One 160 x 120 gray frame is 0.018 MB.
  std::string config = readFile(kSourceDir + "/config/default.yaml");
  const std::string key = "image_memory_mb: 512.0";
  ASSERT_NE(config.find(key), std::string::npos);
  config.replace(config.find(key), key.size(), "image_memory_mb: 0.02");
  const std::string small = writeText("budget.yaml", config);
  const ToolRun full = run("--bag " + quote(bag) + " --init " + quote(init) + " --out-dir " + quote(path("out_full")));
  const ToolRun few = run("--bag " + quote(bag) + " --init " + quote(init) + " --config " + quote(small) +
                          " --out-dir " + quote(path("out_few")));
  ASSERT_EQ(full.status, 0) << full.err;
  ASSERT_EQ(few.status, 0) << few.err;
  const nlohmann::json jf = nlohmann::json::parse(readFile(path("out_full") + "/summary.json"));
  const nlohmann::json jb = nlohmann::json::parse(readFile(path("out_few") + "/summary.json"));
  EXPECT_EQ(jf["frames_read_again"].get<int>(), 0);
  std::printf("one-frame image budget: %d frames read again\n", jb["frames_read_again"].get<int>());
  EXPECT_GT(jb["frames_read_again"].get<int>(), 100);  // measured 237: the 110 frames, some more than once
  const auto rows_full = readCsv(path("out_full") + "/regions.csv");
  const auto rows_few = readCsv(path("out_few") + "/regions.csv");
  ASSERT_EQ(rows_full.size(), 1u + spec.frames);
  ASSERT_EQ(rows_few.size(), rows_full.size());
  for (size_t i = 0; i < rows_full.size(); ++i) ASSERT_EQ(rows_few[i], rows_full[i]) << "regions.csv row " << i;
  // And the look did its work in both: lost while B is in view, found on
  // A's first frame back.
  int lost = 0;
  for (int i = 1; i <= spec.frames; ++i) lost += rows_few[i][6] == "lost";
  EXPECT_GT(lost, 0);
  EXPECT_EQ(rows_few[1 + 90][6], "tracked");
}

TEST_F(TrackBag, DecoderWarningsBecomeOneCountedWarning) {
  // libpng decodes a PNG whose ancillary tEXt chunk has a bad CRC and prints
  // "libpng warning: tEXt: CRC error" on stderr; the tool captures that and
  // reports it once, counted, after the run.
  BagSpec spec;
  spec.compressed = "png";
  spec.crc_warning_frame = 4;
  const std::string out = path("out_png_warning");
  const ToolRun r = run("--bag " + quote(makeBag("png_warning.bag", spec)) + " --out-dir " + quote(out));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(r.errLines(),
            std::vector<std::string>{
                "track_bag: warning: the image decoder complained about 1 compressed frame(s) "
                "(first: frame 4 (stamp 1000.133333) on /cam/image_raw/compressed: libpng warning: "
                "tEXt: CRC error)"});
  EXPECT_EQ(readCsv(out + "/camera_motion.csv").size(), 1u + spec.frames);
}

TEST_F(TrackBag, ChoosesTheImageTopicGivenWhenThereAreSeveral) {
  BagSpec spec;
  spec.extra = [](rosbag::Bag& bag) {
    sensor_msgs::Image m = rawImage(frameImage(0, 16, 12), "mono8", std_msgs::Header());
    m.header.stamp = ros::Time(2000.0);
    bag.write("/other/image", ros::Time(1000.0), m);
  };
  const std::string bag = makeBag("two_topics_ok.bag", spec);
  const std::string out = path("out_two");
  // Without the leading slash too: matched to the bag's absolute name.
  const ToolRun r = run("--bag " + quote(bag) + " --out-dir " + quote(out) +
                    " --image-topic other/image --camera-info-topic /cam/camera_info");
  ASSERT_EQ(r.status, 0) << r.err;
  const auto rows = readCsv(out + "/camera_motion.csv");
  ASSERT_EQ(rows.size(), 2u);
  EXPECT_EQ(rows[1][0], "2000.000000000");
  // The given camera_info (160x120) does not match the 16x12 frame: warned.
  EXPECT_NE(r.err.find("differs from /cam/camera_info's 160x120"), std::string::npos) << r.err;
}

TEST_F(TrackBag, HelpGoesToStdoutWithStatusZero) {
  const ToolRun r = run("--help");
  EXPECT_EQ(r.status, 0);
  EXPECT_EQ(r.err, "");
  for (const char* opt : {"--bag", "--init", "--out-dir", "--image-topic", "--camera-info-topic",
                          "--imu-topic", "--config", "--out-bag", "--start", "--end", "--quiet"})
    EXPECT_NE(r.out.find(opt), std::string::npos) << opt;
}

TEST_F(TrackBag, ProgressBarOnATerminalOnlyAndNotWithQuiet) {
  // `script` gives the tool a pseudo-terminal for stdout and stderr.
  if (std::system("command -v script >/dev/null 2>&1") != 0) GTEST_SKIP() << "no script(1)";
  const std::string out = path("out_tty");
  const std::string log = path("tty.log");
  auto onTty = [&](const std::string& extra) {
    const std::string inner = "ROS_PACKAGE_PATH=" + kSourceDir + " timeout 60 " + kBin + " --bag " +
                              good_ + " --out-dir " + out + extra;
    const std::string cmd = "script -qec " + quote(inner) + " " + quote(log) + " >/dev/null 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0);
    return readFile(log);
  };
  const std::string shown = onTty("");
  EXPECT_NE(shown.find("20/20 frames"), std::string::npos) << shown;
  const std::string quiet = onTty(" --quiet");
  EXPECT_EQ(quiet.find("frames"), std::string::npos) << quiet;
}

}  // namespace
}  // namespace imt
