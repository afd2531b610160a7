// Files written next to a generated scene: the ground-truth JSON and an
// INIT.yaml that asks track_bag to track the scene's regions, targets and
// anchors. No ROS.
//
// Ground-truth JSON layout (one object):
//   preset, seed, width, height, fps, start_time, frame_id,
//   intrinsics {fx, fy, cx, cy,          (our pixel convention: docs/conventions.md)
//               distortion_model, D}     ("none" and [] without a lens; pixels below are
//                                         image pixels, through the lens)
//   q_cam_imu [qx, qy, qz, qw]           (R_cam_imu)
//   frames [ { index, stamp, T_world_cam {t:[x,y,z], q:[qx,qy,qz,qw]},
//              background_homography [9] | null   (previous -> current, row-major),
//              regions [ {id, box:[x,y,w,h], box_unclipped:[...], visible_fraction, featureless} ],
//              planar_targets [ {id, corners:[[x,y]x4], t:[..], q:[..], size:[w,h]} ],
//              anchors [ {id, pixel:[u,v], in_view, placed, t:[..], q:[..]} ] } ]
#pragma once

#include "instant_motion_tracking/sim/scene.h"

#include <string>

namespace imt {

// Writes the ground truth of every frame of `scene` to `path` (JSON).
bool writeSceneTruth(const SceneGenerator& scene, const std::string& frame_id,
                     const std::string& path, std::string* error);

// Writes an INIT.yaml with every region, planar target and anchor of the
// scene, each given at frame `frame_index` (its truth there).
bool writeSceneInit(const SceneGenerator& scene, int frame_index, const std::string& path,
                    std::string* error);

}  // namespace imt
