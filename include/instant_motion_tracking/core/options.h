// The options of the whole pipeline (PipelineOptions), composed of one
// options struct per module, each in its own header beside the module
// (motion/, region/, planar/, anchor/). Each field is documented once, in its
// struct's visit(); every loader (YAML for track_bag, the ROS parameter server
// for the nodelets, ros/params.h, through the same YAML loader) walks them
// through visit(), taking every default from the struct itself, and
// config/default.yaml is generated from them (track_bag --print-default-config).
// Modules validate their options at construction (validate(); an invalid
// option throws, it is never replaced by a default).
//
// A visitor provides:
//   void operator()(const char* name, T& field, const char* doc);  // T: int, double, bool, std::string
//   template <class S> void section(const char* name, S& sub);     // a nested struct
#pragma once

#include "instant_motion_tracking/core/anchor/anchor_options.h"
#include "instant_motion_tracking/core/anchor/imu_options.h"
#include "instant_motion_tracking/core/motion/motion_analysis_options.h"
#include "instant_motion_tracking/core/planar/planar_target_options.h"
#include "instant_motion_tracking/core/region/region_tracker_options.h"

#include <string>

namespace imt {

// The whole pipeline: shared by the nodelets and track_bag.
struct PipelineOptions {
  // Each field is documented once, in visit() below (config/default.yaml is
  // generated from it: track_bag --print-default-config).
  double cache_seconds = 10.0;
  double default_hfov_deg = 60.0;
  bool image_rectified = false;
  double time_jump_reset_seconds = 1.0;
  MotionAnalysisOptions motion_analysis;
  RegionTrackerOptions region_tracking;
  PlanarTargetOptions planar_tracking;
  ImuOptions imu;
  AnchorOptions anchors;

  template <class V>
  void visit(V& v) {
    v("cache_seconds", cache_seconds,
      "s of motion data kept, for regions added in the past and seek_regions");
    v("default_hfov_deg", default_hfov_deg,
      "horizontal field of view (deg) assumed when there is no camera_info");
    v("image_rectified", image_rectified,
      "true: images already rectified (image_rect): camera_info's P is used, D ignored; false: "
      "camera_info's K and D (plumb_bob, rational_polynomial, equidistant honoured)");
    v("time_jump_reset_seconds", time_jump_reset_seconds,
      "s; a frame stamped this far or farther behind the newest restarts tracking (a bag loop, a restarted "
      "driver); a frame with the newest's stamp, or less far behind, is dropped with a warning");
    v.section("motion_analysis", motion_analysis);
    v.section("region_tracking", region_tracking);
    v.section("planar_tracking", planar_tracking);
    v.section("imu", imu);
    v.section("anchors", anchors);
  }
  std::string validate() const;
};

}  // namespace imt
