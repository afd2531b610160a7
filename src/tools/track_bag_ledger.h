// What a track_bag run dropped, refused, restarted or read again, counted as
// the frames and messages come and turned into the run's notes and
// summary.json's counts at the end. Header-only, like track_bag_util.h: it
// serves the one tool.
#pragma once

#include "instant_motion_tracking/core/tracking_session.h"
#include "instant_motion_tracking/io/csv_writer.h"
#include "track_bag_util.h"

#include <nlohmann/json.hpp>

#include <map>
#include <string>

namespace imt::track_bag {

// The counts of one run. Frame indices are the bag's (BagImage::index).
class RunLedger {
 public:
  // A frame that could not be decoded: not a frame of the run.
  void malformedFrame(int index, const std::string& reason, const std::string& where) {
    noteDrop(&malformed_, reason, where);
    dropped_at_[index] = "frame " + std::to_string(index) + " was dropped: " + reason;
  }
  // A frame the time rules dropped (a repeated stamp or one slightly behind).
  void timeDrop(int index, const std::string& why) {
    if (first_time_drop_.empty()) first_time_drop_ = "frame " + std::to_string(index) + ": " + why;
    dropped_at_.emplace(index, "frame " + std::to_string(index) + " was dropped by the time rules");
  }
  // Why the frame is not in the run, or "" when it is.
  std::string whyDropped(int index) const {
    const auto d = dropped_at_.find(index);
    return d == dropped_at_.end() ? "" : d->second;
  }
  int malformedCount() const { return total(malformed_); }
  const DropInfo& firstMalformed() const { return *inOrder(malformed_).front(); }

  void analysisReset(const std::string& reason, int index, double stamp) {
    Reset& r = resets_[reason];
    if (r.count++ == 0) {
      r.first_frame = index;
      r.first_stamp = stamp;
    }
  }
  void decoderWarning(const std::string& where_and_what) {
    if (decoder_warnings_++ == 0) first_decoder_warning_ = where_and_what;
  }
  void cameraInfoRefused(const std::string& why, const std::string& where) { noteDrop(&info_refused_, why, where); }
  // An IMU message with NaN/Inf values.
  void imuDropped(double stamp) {
    if (imu_dropped_++ == 0) imu_first_dropped_ = stamp;
  }
  // What the session did with a usable IMU sample.
  void imuUsed(imt::ImuInput outcome) {
    ++imu_used_;
    ++imu_outcomes_[outcome];
  }
  void frameModel(const std::string& model) { ++model_counts_[model]; }
  void frameReadAgain() { ++rereads_; }

  // One warning per kind of trouble, with its count and its first place.
  // `time_drops` are the session's counts of what timeDrop() saw.
  void addNotes(const imt::TrackingSession::TimeDrops& time_drops, Notes* notes) const {
    for (const auto& [reason, r] : resets_)
      notes->warn("motion analysis reset " + std::to_string(r.count) + " time(s): " + reason + " (first at frame " +
                  std::to_string(r.first_frame) + ", stamp " + imt::formatFixed(r.first_stamp, 6) + ")");
    if (decoder_warnings_)
      notes->warn("the image decoder complained about " + std::to_string(decoder_warnings_) +
                  " compressed frame(s) (first: " + first_decoder_warning_ + ")");
    if (imu_dropped_)
      notes->warn("dropped " + std::to_string(imu_dropped_) + " IMU sample(s) with NaN/Inf values "
                  "(first at stamp " + imt::formatFixed(imu_first_dropped_, 6) + ")");
    if (const int gaps = count(imt::ImuInput::kGap))
      notes->warn("the IMU stream has " + std::to_string(gaps) + " gap(s) longer than imu.max_gap_seconds " +
                  "(no anchor orientation inside them; roll and pitch re-levelled after each)");
    if (const int dropped = count(imt::ImuInput::kDropped))
      notes->warn("the IMU orientation dropped " + std::to_string(dropped) + " sample(s) (NaN or out of order)");
    if (const int restarts = count(imt::ImuInput::kReset))
      notes->warn("the IMU orientation restarted " + std::to_string(restarts) + " time(s) (IMU time jumped back)");
    for (const DropInfo* d : inOrder(malformed_))
      notes->warn(std::to_string(d->count) + " malformed frame(s) dropped: " + d->first_reason + " (first: " +
                  d->first_where + ")");
    for (const DropInfo* d : inOrder(info_refused_))
      notes->warn(std::to_string(d->count) + " camera_info message(s) refused: " + d->first_reason + " (first at " +
                  d->first_where + ")");
    if (time_drops.duplicate + time_drops.behind > 0)
      notes->warn(std::to_string(time_drops.duplicate + time_drops.behind) + " frame(s) dropped by the time rules (" +
                  std::to_string(time_drops.duplicate) + " repeated stamps, " + std::to_string(time_drops.behind) +
                  " slightly behind the newest; first: " + first_time_drop_ + ")");
  }

  // The counts' entries of summary.json's details (interface.md).
  void addDetails(const imt::TrackingSession::TimeDrops& time_drops, nlohmann::json* d) const {
    (*d)["imu_samples"] = imu_used_;
    (*d)["imu_dropped"] = imu_dropped_;
    (*d)["frames_dropped"] = {{"duplicate_stamp", time_drops.duplicate},
                              {"stamp_behind", time_drops.behind},
                              {"malformed_image", malformedCount()}};
    (*d)["camera_info_refused"] = total(info_refused_);
    (*d)["frames_read_again"] = rereads_;
    (*d)["models"] = model_counts_;
    nlohmann::json resets = nlohmann::json::object();
    for (const auto& [reason, r] : resets_) resets[reason] = r.count;
    (*d)["resets"] = resets;
  }

 private:
  struct Reset {
    int count = 0;
    int first_frame = 0;
    double first_stamp = 0;
  };
  int count(imt::ImuInput outcome) const {
    const auto it = imu_outcomes_.find(outcome);
    return it == imu_outcomes_.end() ? 0 : it->second;
  }

  Drops malformed_, info_refused_;
  std::map<int, std::string> dropped_at_;  // frame index -> why that frame is not in the run
  std::string first_time_drop_;            // the first frame the time rules dropped, and why
  std::map<std::string, Reset> resets_;
  int decoder_warnings_ = 0;
  std::string first_decoder_warning_;
  std::map<imt::ImuInput, int> imu_outcomes_;
  int imu_used_ = 0, imu_dropped_ = 0;
  double imu_first_dropped_ = 0;
  std::map<std::string, int> model_counts_;
  int rereads_ = 0;
};

}  // namespace imt::track_bag
