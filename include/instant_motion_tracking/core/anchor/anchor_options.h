// Anchor (paper 3.4) options. One struct, each field documented once in visit();
// config/default.yaml is generated from it.
#pragma once

#include <Eigen/Geometry>

#include <string>

namespace imt {

// config/default.yaml: section `anchors:`.
struct AnchorOptions {
  // Each field is documented once, in visit() below (config/default.yaml is
  // generated from it: track_bag --print-default-config).
  double region_size = 0.2;
  double default_depth = 1.0;
  double imu_wait_seconds = 0.1;
  double imu_reset_seconds = 1.0;
  std::string rotation_cam_imu;
  std::string surface = "horizontal";
  double imu_time_offset = 0.0;
  bool estimate_imu_time_offset = true;
  double rolling_shutter_readout = 0.0;
  int max_anchors = 256;

  template <class V>
  void visit(V& v) {
    v("region_size", region_size,
      "side of the square region tracked around the tap, fraction of the shorter image side");
    v("default_depth", default_depth,
      "m; distance along the tap's ray when an add_anchor request gives depth 0");
    v("imu_wait_seconds", imu_wait_seconds,
      "s of frames a frame's anchors wait for the IMU to pass its stamp (live; then no_imu)");
    v("imu_reset_seconds", imu_reset_seconds,
      "s; an IMU stamp this far behind the newest restarts the orientation (bag loop); smaller "
      "steps back are dropped");
    v("rotation_cam_imu", rotation_cam_imu,
      "\"qx qy qz qw\": the IMU frame's rotation in the camera optical frame, overriding "
      "/tf_static; \"\" = from tf");
    v("surface", surface,
      "what anchors sit on, for the range from the region's scale: horizontal (floor, table: the "
      "paper's assumption; tilt from the IMU) | facing (a patch facing the camera)");
    v("imu_time_offset", imu_time_offset,
      "s; an image stamped t was taken when the IMU's clock read t + this (late driver stamps, a rolling "
      "shutter's middle row); the start value when estimated");
    v("estimate_imu_time_offset", estimate_imu_time_offset,
      "use the offset the video shows (always estimated and reported). The changes of the camera's turn "
      "rate aligned with the gyro's (within +-0.1 s, over the last 20 s of frames, refitted every 2 s) "
      "move it only beyond 50 ms once the gyro bias's fit reads it (imu.video_bias), since a camera moving "
      "over a near plane biases them (+14 ms on the rendered floor walk); the bias fit refines it (where "
      "the video found the IMU-to-camera rotation, once its last two fits agree); false: imu_time_offset "
      "as given");
    v("rolling_shutter_readout", rolling_shutter_readout,
      "s from the first image row's read to the last's (a phone's rolling shutter: about a frame period); 0 = "
      "a global shutter. Where the IMU-to-camera rotation is read from the features' epipolar lines (a camera "
      "that travels as it turns), each row's gyro turn is taken at its own time, imu_time_offset at the middle row");
    v("max_anchors", max_anchors,
      "anchors tracked at most; add_anchor and INIT.yaml are refused beyond (each tracks a region of its own, "
      "not counted in region_tracking.max_regions)");
  }
  // Empty when usable, else "anchors.<field>: must be ... (got ...)".
  std::string validate() const;
  // The parsed rotation_cam_imu; false when it is empty (or malformed).
  bool rotationCamImu(Eigen::Quaterniond* q) const;
};

}  // namespace imt
