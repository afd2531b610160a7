// The gyro bias seen by the video while the camera moves (issue 14): no
// still moment is needed.
//
// Over a frame interval dt the gyro's turn, bias included, is the camera's
// turn (as the frames show it, turned into the IMU's axes) plus bias * dt.
// So each frame gives the bias as (gyro turn - R_imu_cam camera turn) / dt,
// with the video's noise over dt: about 0.1 deg/s per frame on a rendered
// walk at 30 frames/s, where a bias is typically 0.1-1 deg/s. The estimate
// is a weighted least-squares fit over the last `seconds` of frames
// (weights dt^2: the video's noise is per frame), leaving out frames over 4
// robust deviations from the median on any axis (a passing object, a
// background the turn did not explain), with its standard errors from the
// residuals. Fitted with the bias: the gyro's lateness against the frames,
// and optionally a small correction of R_imu_cam (estimate()). The frames
// keep the camera's turn in its own axes and take the rotation when asked
// (the video's own estimate of it moves as it refines).
//
// The camera's turn comes from the background's motion (AnchorManager):
// rotationFromPlaneHomography() with the IMU's up as the normal where the
// background is the floor (a walking camera: a turn-and-zoom fit reads the
// walk over the floor as a turn about the camera's x axis, as large as a
// bias), rotationFromHomography() where that explains it better (a distant
// scene, a camera turning in place), and no frame where neither explains
// it to within a pixel.
//
// Usage:
//   imt::VideoGyroBias vb(30.0);
//   vb.add(t1, t1 - t0, rotationVector(R_imu0_imu1_raw), theta_cam);
//   if (auto e = vb.estimate(R_imu_cam)) imu.setVideoGyroBias(e->bias, last_used_at, t1);
// Threading: not thread-safe.
#pragma once

#include <Eigen/Core>

#include <deque>
#include <optional>

namespace imt {

class VideoGyroBias {
 public:
  struct Estimate {
    Eigen::Vector3d bias = Eigen::Vector3d::Zero();   // rad/s, IMU frame
    Eigen::Vector3d sigma = Eigen::Vector3d::Zero();  // its standard error per axis, rad/s
    int frames = 0;                                   // frames it rests on (after the outliers left out)
    // s by which the newest frame's offset exceeds the true one: its gyro
    // turns are those of `lateness` s later than the frames' (see estimate()).
    double lateness = 0;
    double lateness_sigma = 0;  // its standard error, s (large when the turn rate hardly changed)
  };
  // Frames needed before an estimate is given.
  static constexpr int kMinFrames = 60;

  // `seconds`: how far back frames count (> 0).
  explicit VideoGyroBias(double seconds) : seconds_(seconds) {}

  // One frame interval ending at t1 (s), dt long: the gyro's turn over it
  // with no bias taken off (rotation vector, rad, IMU frame), read at the
  // camera-IMU time offset `offset` (s: the IMU's stamps less the frames'),
  // and the camera's turn seen in the frames (camera frame). Ignored when
  // not finite, dt not in (0, 1] s, or t1 before the last frame's.
  void add(double t1, double dt, const Eigen::Vector3d& gyro_turn, const Eigen::Vector3d& camera_turn,
           double offset = 0);
  // With the IMU-to-camera rotation R_imu_cam; from kMinFrames frames on,
  // none before. The gyro's lateness against the frames (what is left of
  // the camera-IMU time offset) is fitted with the bias: a lateness s reads
  // as a bias of s times the turn rate's change, which over a few seconds
  // of a walk does not average out. Frames read at another offset than the
  // newest frame's (the offset was re-estimated meanwhile) have the
  // difference, times their turn rate's change, taken out first: the
  // lateness is the newest offset's, and the frames need not be dropped when
  // the offset moves. refine_rotation: R_imu_cam is itself an
  // estimate (the video's): a small correction of it is fitted too (an
  // error e in the rotation reads as a bias of e times the turn rate: a walk
  // that keeps turning one way would carry it into the bias).
  std::optional<Estimate> estimate(const Eigen::Matrix3d& R_imu_cam, bool refine_rotation = false) const;
  size_t frames() const { return frames_.size(); }
  // The offset the newest frame was read at (0 with none): the lateness's reference.
  double newestOffset() const { return frames_.empty() ? 0.0 : frames_.back().offset; }
  void clear() { frames_.clear(); }

 private:
  struct Frame {
    double t1 = 0, dt = 0, offset = 0;
    Eigen::Vector3d gyro = Eigen::Vector3d::Zero(), camera = Eigen::Vector3d::Zero();  // the turns, rad
  };
  double seconds_;
  std::deque<Frame> frames_;
};

}  // namespace imt
