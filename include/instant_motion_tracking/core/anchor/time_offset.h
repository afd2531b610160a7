// The offset between the camera's and the IMU's stamps (issue 14): an
// image stamped t was taken when the IMU's clock read t + offset. Drivers
// stamp late by 5-50 ms, and a rolling shutter's middle row is read half a
// readout after the frame's start; the gyro's rotation must be read at the
// image's moment, or every turn is attributed to the wrong frames.
//
// Found by aligning the camera's turn rate with the gyro's: over a stretch
// of frames, the angle the camera turned between consecutive frames (from
// the video, cameraTurn()) and the angle the gyro integrated between the same
// stamps shifted by a candidate offset are compared by the correlation of
// their changes from one frame interval to the next (the slow part of the
// motion, which any offset matches about as well, drops out), and the offset
// with the highest correlation wins (every 4 ms, then every ms around the
// best, refined by a parabola through the peak). Angles, not vectors: the
// IMU-to-camera rotation need not be known. The camera must turn at a
// varying rate (a handheld camera does; a still or steadily panning one
// cannot show an offset). Measured: 14.2 ms on the real phone clip
// (correlation 0.95, 0.45 at 0 ms); on the rendered floor walk any IMU delay
// to 0.1 ms, plus a bias of +13.6 ms: the floor's flow as the camera moves
// over it reads as a turn that follows the camera's pitch angle, not its
// rate, as a phase shift would (AnchorManager applies it by default,
// anchors.estimate_imu_time_offset, and only beyond the gyro bias fit's
// reach once that fit reads the lateness itself).
//
// Usage (AnchorManager does this):
//   imt::TimeOffsetEstimator est;
//   est.add(t0, t1, theta_cam.norm());  // each frame interval the video read as a turn
//   const imt::TimeOffsetFit f = est.fit([&](double s0, double s1, double* angle) { ...gyro... });
//   if (f.found) use(f.offset);
// Threading: not thread-safe.
#pragma once

#include <cstddef>
#include <deque>
#include <functional>

namespace imt {

struct TimeOffsetFit {
  bool found = false;        // a clear peak inside the search range, over enough turns
  double offset = 0;         // s; IMU stamp = image stamp + offset
  // At the offset: Pearson correlation of the angles' changes from one frame
  // interval to the next (of the angles themselves when too few are consecutive).
  double correlation = -1;
  double at_zero = -1;       // the same at offset 0 (for reports)
  int turns = 0;             // frame intervals compared
};

class TimeOffsetEstimator {
 public:
  struct Options {
    double max_offset = 0.1;      // s searched either way
    int min_turns = 60;           // frame intervals before a fit (2 s at 30 frames/s)
    double min_correlation = 0.8; // at the peak
    double min_spread = 0.002;    // rad; standard deviation of the camera's angles (varying turns)
    size_t max_turns = 600;       // the most recent intervals kept
  };
  TimeOffsetEstimator() = default;
  explicit TimeOffsetEstimator(const Options& o) : options_(o) {}

  // The camera's turn angle (rad) between the frames stamped t0 < t1.
  void add(double t0, double t1, double angle);
  // `gyroAngle(s0, s1, &angle)`: the gyro's turn angle between IMU stamps s0
  // and s1, false where it has none (then the interval is left out).
  TimeOffsetFit fit(const std::function<bool(double, double, double*)>& gyroAngle) const;
  size_t turns() const { return turns_.size(); }
  void clear() { turns_.clear(); }
  const Options& options() const { return options_; }

 private:
  struct Turn {
    double t0, t1, angle;
  };
  Options options_;
  std::deque<Turn> turns_;
};

}  // namespace imt
