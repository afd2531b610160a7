// Rostest node: plays a generated bag through a MotionAnalysisNodelet running
// in a nodelet manager (test/rostest/motion_analysis_nodelet.test) and checks
// that motion_data arrives for every image, in order, with the image stamps.
// With ~compressed (png or jpeg; test/rostest/motion_analysis_compressed.test)
// the bag holds only /camera/image_raw/compressed, and the nodelet's
// ~image_transport is compressed.
#include "instant_motion_tracking/MotionData.h"

#include "rostest_util.h"

#include <gtest/gtest.h>
#include <ros/ros.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <cstdlib>
#include <string>
#include <vector>

namespace {

std::string makeTempDir() {
  char tmpl[] = "/tmp/imt_rostest_XXXXXX";
  const char* dir = mkdtemp(tmpl);
  return dir ? dir : "";
}

using imt::test::spinUntil;
using imt::test::stopPlayer;

TEST(MotionAnalysisNodelet, MotionDataArrivesWithTheImageStamps) {
  const std::string dir = makeTempDir();
  ASSERT_FALSE(dir.empty());
  const std::string bag_path = dir + "/scene.bag";
  const std::string compressed = ros::NodeHandle("~").param<std::string>("compressed", "");
  const std::string topic = compressed.empty() ? "/camera/image_raw" : "/camera/image_raw/compressed";
  const std::string make_scene = std::string(IMT_BIN_DIR) + "/make_scene";
  const std::string cmd = make_scene +
                          " --preset wall_pan --duration 3 --width 320 --height 240 --seed 3 --quiet" +
                          (compressed.empty() ? "" : " --compressed " + compressed) + " --out " + bag_path +
                          " > " + dir + "/make_scene.log 2>&1";
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;

  // The image stamps and frame ids the bag holds.
  std::vector<ros::Time> stamps;
  std::string frame_id;
  {
    rosbag::Bag bag(bag_path);
    ASSERT_EQ(rosbag::View(bag, rosbag::TopicQuery(compressed.empty() ? "/camera/image_raw/compressed"
                                                                        : "/camera/image_raw")).size(), 0u)
        << "the bag should hold one image topic";
    for (const rosbag::MessageInstance& m : rosbag::View(bag, rosbag::TopicQuery(topic))) {
      std_msgs::Header header;
      if (const auto img = m.instantiate<sensor_msgs::Image>()) header = img->header;
      else if (const auto c = m.instantiate<sensor_msgs::CompressedImage>()) header = c->header;
      else FAIL() << "not an image on " << topic;
      stamps.push_back(header.stamp);
      frame_id = header.frame_id;
    }
  }
  ASSERT_EQ(stamps.size(), 90u);  // 3 s at the preset's 30 fps

  ros::NodeHandle nh;
  std::vector<instant_motion_tracking::MotionData> received;
  ros::Subscriber sub = nh.subscribe<instant_motion_tracking::MotionData>(
      "motion_data", 1000, [&](const instant_motion_tracking::MotionDataConstPtr& m) { received.push_back(*m); });
  ASSERT_TRUE(spinUntil([&] { return sub.getNumPublishers() > 0; }, 60.0))
      << "the nodelet never advertised motion_data";

  // Play only the images, once the (lazy) nodelet has subscribed to them.
  const pid_t player = imt::test::playTopics(bag_path, {topic});
  ASSERT_GT(player, 0);
  const bool all = spinUntil([&] { return received.size() >= stamps.size(); }, 60.0);
  spinUntil([] { return false; }, 0.5);  // anything extra would show up now
  stopPlayer(player);
  ASSERT_TRUE(all) << "received " << received.size() << " of " << stamps.size() << " motion_data messages";

  ASSERT_EQ(received.size(), stamps.size());
  for (size_t i = 0; i < stamps.size(); ++i) {
    EXPECT_EQ(received[i].header.stamp, stamps[i]) << "message " << i;
    EXPECT_EQ(received[i].header.frame_id, frame_id);
    EXPECT_EQ(received[i].width, 320u);
    EXPECT_EQ(received[i].height, 240u);
    EXPECT_LE(received[i].model, instant_motion_tracking::MotionData::MODEL_HOMOGRAPHY);
  }
  std::system(("rm -rf " + dir).c_str());
}

}  // namespace

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_motion_data_stamps");
  ros::NodeHandle nh;  // keep the node alive for the whole run
  return RUN_ALL_TESTS();
}
