// track_bag's RunLedger (src/tools/track_bag_ledger.h): what a run dropped,
// refused, restarted or read again, as counted, as summary.json gives it and
// as the notes say it. The tool's own tests (test_track_bag*.cpp) run it on
// bags; these pin the bookkeeping itself.
#include "../../src/tools/track_bag_ledger.h"

#include <gtest/gtest.h>

#include <algorithm>

namespace {

using imt::track_bag::Notes;
using imt::track_bag::RunLedger;

bool hasLine(const Notes& notes, const std::string& part) {
  return std::any_of(notes.lines.begin(), notes.lines.end(),
                     [&](const std::string& l) { return l.find(part) != std::string::npos; });
}

TEST(TrackBagLedger, CountsWhatARunDroppedAndSaysItOncePerCause) {
  RunLedger ledger;
  ledger.malformedFrame(3, "image 2x2 has 3 bytes, expected 4", "frame 3 on /cam");
  ledger.malformedFrame(9, "image 2x2 has 1 bytes, expected 4", "frame 9 on /cam");
  ledger.timeDrop(5, "stamp repeated");
  ledger.timeDrop(7, "stamp behind");
  ledger.analysisReset("time went backwards", 11, 1000.5);
  ledger.analysisReset("time went backwards", 20, 1001.0);
  ledger.decoderWarning("frame 2 on /cam: Corrupt JPEG data");
  ledger.decoderWarning("frame 4 on /cam: Corrupt JPEG data");
  ledger.cameraInfoRefused("K has a NaN", "stamp 1000.000000");
  ledger.imuDropped(999.25);
  ledger.imuUsed(imt::ImuInput::kAccepted);
  ledger.imuUsed(imt::ImuInput::kGap);
  ledger.frameModel("homography");
  ledger.frameModel("homography");
  ledger.frameModel("translation");
  ledger.frameReadAgain();

  EXPECT_EQ(ledger.malformedCount(), 2);
  EXPECT_EQ(ledger.firstMalformed().first_where, "frame 3 on /cam");
  EXPECT_EQ(ledger.whyDropped(3), "frame 3 was dropped: image 2x2 has 3 bytes, expected 4");
  EXPECT_EQ(ledger.whyDropped(5), "frame 5 was dropped by the time rules");
  EXPECT_EQ(ledger.whyDropped(4), "");  // decoded with a warning: a frame of the run

  imt::TrackingSession::TimeDrops time_drops;
  time_drops.duplicate = 1;
  time_drops.behind = 1;
  nlohmann::json d;
  ledger.addDetails(time_drops, &d);
  EXPECT_EQ(d["imu_samples"], 2);
  EXPECT_EQ(d["imu_dropped"], 1);
  EXPECT_EQ(d["frames_dropped"]["malformed_image"], 2);
  EXPECT_EQ(d["frames_dropped"]["duplicate_stamp"], 1);
  EXPECT_EQ(d["frames_dropped"]["stamp_behind"], 1);
  EXPECT_EQ(d["camera_info_refused"], 1);
  EXPECT_EQ(d["frames_read_again"], 1);
  EXPECT_EQ(d["models"]["homography"], 2);
  EXPECT_EQ(d["models"]["translation"], 1);
  EXPECT_EQ(d["resets"]["time went backwards"], 2);

  Notes notes;
  ledger.addNotes(time_drops, &notes);
  // Both malformed frames have one cause (the numbers left out): one warning.
  EXPECT_TRUE(hasLine(notes, "2 malformed frame(s) dropped: image 2x2 has 3 bytes, expected 4 (first: frame 3 on /cam)"));
  EXPECT_TRUE(hasLine(notes, "motion analysis reset 2 time(s): time went backwards (first at frame 11, stamp 1000.500000)"));
  EXPECT_TRUE(hasLine(notes, "complained about 2 compressed frame(s) (first: frame 2 on /cam: Corrupt JPEG data)"));
  EXPECT_TRUE(hasLine(notes, "1 camera_info message(s) refused: K has a NaN (first at stamp 1000.000000)"));
  EXPECT_TRUE(hasLine(notes, "dropped 1 IMU sample(s) with NaN/Inf values (first at stamp 999.250000)"));
  EXPECT_TRUE(hasLine(notes, "the IMU stream has 1 gap(s)"));
  EXPECT_TRUE(hasLine(notes, "2 frame(s) dropped by the time rules (1 repeated stamps, 1 slightly behind the newest; "
                             "first: frame 5: stamp repeated)"));
  EXPECT_FALSE(hasLine(notes, "IMU orientation restarted"));
  EXPECT_EQ(notes.lines.size(), 7u);
}

TEST(TrackBagLedger, AQuietRunSaysNothing) {
  RunLedger ledger;
  ledger.imuUsed(imt::ImuInput::kAccepted);
  ledger.frameModel("homography");
  Notes notes;
  ledger.addNotes({}, &notes);
  EXPECT_TRUE(notes.lines.empty());
  nlohmann::json d;
  ledger.addDetails({}, &d);
  EXPECT_EQ(d["frames_dropped"]["malformed_image"], 0);
  EXPECT_EQ(d["resets"], nlohmann::json::object());
  EXPECT_EQ(ledger.whyDropped(0), "");
}

}  // namespace
