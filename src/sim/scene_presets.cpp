// Scene layouts (presets), camera trajectories and plane motions of the scene
// generator. Every curve is smooth (sums of sinusoids, C2 smootherstep ramps)
// so the IMU stream derived from it is consistent.
#include "scene_internal.h"

#include <algorithm>
#include <cmath>

namespace imt {
namespace scene_detail {
namespace {

constexpr double kDeg = M_PI / 180.0;

double wave(double amplitude, double period, double phase, double t) {
  return amplitude * std::sin(2.0 * M_PI * t / period + phase);
}

// 0 -> 1 with zero first and second derivatives at both ends (C2).
double smootherstep(double x) {
  x = std::clamp(x, 0.0, 1.0);
  return x * x * x * (x * (6 * x - 15) + 10);
}

// 0 before t0, ramps to 1 over `ramp` s, holds `hold` s, ramps back to 0.
double bump(double t, double t0, double ramp, double hold) {
  return smootherstep((t - t0) / ramp) - smootherstep((t - t0 - ramp - hold) / ramp);
}

// R_world_cam of an optical frame looking along `forward` with `up` upwards.
Eigen::Matrix3d lookRotation(const Eigen::Vector3d& forward, const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = forward.normalized();
  const Eigen::Vector3d x = z.cross(up).normalized();
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = z.cross(x);
  R.col(2) = z;
  return R;
}

// Yaw (about the camera's up, -y), pitch (about x, positive looks up) and
// roll (about the optical axis), applied in that order in the camera frame.
Eigen::Matrix3d yawPitchRoll(double yaw, double pitch, double roll) {
  return (Eigen::AngleAxisd(yaw, -Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}

Eigen::Isometry3d pose(const Eigen::Matrix3d& R, const Eigen::Vector3d& p) {
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R;
  T.translation() = p;
  return T;
}

// A camera at distance r from the point c of the wall, at azimuth `az` and
// elevation `el` (rad; 0, 0: straight in front of it), aiming at c + `aim`
// and rolled by `roll` about its optical axis.
Eigen::Isometry3d aroundPoint(const Eigen::Vector3d& c, double az, double el, double r,
                              const Eigen::Vector3d& aim, double roll) {
  const Eigen::Vector3d dir(std::sin(az) * std::cos(el), -std::cos(az) * std::cos(el),
                            std::sin(el));
  const Eigen::Vector3d p = c + r * dir;
  const Eigen::Matrix3d R = lookRotation(c + aim - p, Eigen::Vector3d::UnitZ());
  return pose(R * yawPitchRoll(0, 0, roll), p);
}

// Wall scenes: the camera starts at the origin looking along +y at the wall.
const Eigen::Matrix3d& wallView() {
  static const Eigen::Matrix3d R = lookRotation(Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ());
  return R;
}

// A plane facing the wall-scene camera (plane x = world x, plane y = world
// down, z = world +y, away from the camera) with its centre at `c`.
Eigen::Isometry3d facingCamera(const Eigen::Vector3d& c) { return pose(wallView(), c); }

}  // namespace

bool knownTrajectory(const std::string& name) {
  const auto names = SceneOptions::trajectoryNames();
  return std::find(names.begin(), names.end(), name) != names.end();
}

bool knownPlaneMotion(const std::string& name) {
  return name.empty() || name == "slide" || name == "slide_rotate" || name == "approach" ||
         name == "follow_camera";
}

Eigen::Isometry3d trajectoryPose(const std::string& name, double a, double t) {
  if (name == "pan") {
    const Eigen::Vector3d p(wave(0.5 * a, 8, 0, t), wave(0.6 * a, 9, 0.5, t),
                            wave(0.15 * a, 11, 1.0, t));
    return pose(
        wallView() * yawPitchRoll(wave(6 * kDeg * a, 10, 0.3, t), wave(4 * kDeg * a, 12, 1.1, t),
                                  wave(10 * kDeg * a, 7, 0, t)),
        p);
  }
  if (name == "zoom") {
    return pose(wallView(), Eigen::Vector3d(0, wave(0.6 * a, 9, 0.5, t), 0));
  }
  if (name == "planar") {
    // Looks at a wandering point of the wall from a wandering position:
    // viewing angles up to ~30 deg, so the homography has clear perspective.
    const Eigen::Vector3d p(wave(0.8 * a, 9, 0, t), wave(0.5 * a, 11, 0.4, t),
                            wave(0.4 * a, 13, 1.2, t));
    const Eigen::Vector3d q(wave(0.3 * a, 7, 2.0, t), kWallDistance, wave(0.2 * a, 8, 0.3, t));
    const Eigen::Matrix3d R = lookRotation(q - p, Eigen::Vector3d::UnitZ());
    return pose(R * yawPitchRoll(0, 0, wave(15 * kDeg * a, 12, 0, t)), p);
  }
  if (name == "rotate") {
    return pose(
        wallView() * yawPitchRoll(wave(15 * kDeg * a, 9, 0, t), wave(10 * kDeg * a, 7, 0.6, t),
                                  wave(12 * kDeg * a, 11, 1.3, t)),
        Eigen::Vector3d::Zero());
  }
  if (name == "orbit") {
    // Around the poster centre c: azimuth extremes (+-48 deg) come with the
    // shortest distance (0.8 m), the farthest view (2.4 m) is frontal.
    return aroundPoint(Eigen::Vector3d(0, kWallDistance, 0), wave(48 * kDeg * a, 16, 0, t),
                       wave(20 * kDeg * a, 11, 0.7, t), 1.6 + 0.8 * a * std::cos(2 * M_PI * t / 8),
                       Eigen::Vector3d(wave(0.08 * a, 5, 0, t), 0, wave(0.06 * a, 6, 1.0, t)),
                       wave(30 * kDeg * a, 9, 0.4, t));
  }
  if (name == "walk") {
    // Heading +y at 0.15 m/s, a step bob of 2 cm, pitch -22 +- 10 deg (the
    // horizon enters the top of the view), roll +-5 deg, and a yaw excursion
    // to 50 deg: 2.2 s ramp, 0.1 s hold, 2.2 s back, starting at t = 3 s.
    const Eigen::Vector3d p(wave(0.05 * a, 5, 0, t), -4.0 + 0.15 * a * t,
                            kWalkHeight + wave(0.02 * a, 0.9, 0, t));
    const double yaw = 50 * kDeg * a * bump(t, 3.0, 2.2, 0.1);
    const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
                              wallView() *
                              yawPitchRoll(0, -22 * kDeg + wave(10 * kDeg * a, 3.1, 0.5, t),
                                           wave(5 * kDeg * a, 4.3, 0, t));
    return pose(R, p);
  }
  if (name == "dolly") {
    // Sideways along the wall at 0.75 m/s (x = -3 m at t = 0, 0 at t = 4 s),
    // as from a moving vehicle, with its shake: a bounce of +-2 cm at 1.1 Hz,
    // +-4 cm toward/away, yaw +-1.5, pitch +-1, roll +-1.5 deg.
    const Eigen::Vector3d p(a * (0.75 * (t - 4.0) + wave(0.03, 3.7, 0.2, t)),
                            wave(0.04 * a, 5.3, 0.4, t), wave(0.02 * a, 0.9, 1.0, t));
    return pose(
        wallView() * yawPitchRoll(wave(1.5 * kDeg * a, 2.3, 0, t), wave(1 * kDeg * a, 1.1, 0.7, t),
                                  wave(1.5 * kDeg * a, 3.1, 0.2, t)),
        p);
  }
  if (name == "handheld") {
    // A phone held 0.43..0.67 m from the point (0, 2.5, 0) of the wall,
    // swaying around it (azimuth +-25, elevation +-12, roll +-10 deg), with
    // the hand's tremor on top, in the camera's own frame: +-1.5 deg of yaw,
    // +-1.2 of pitch and +-0.6 of roll at 2.2-5.3 Hz, and +-3 mm.
    const Eigen::Isometry3d sway =
        aroundPoint(Eigen::Vector3d(0, kWallDistance, 0), wave(25 * kDeg * a, 9, 0, t),
                    wave(12 * kDeg * a, 7, 0.7, t), 0.55 + 0.12 * a * std::cos(2 * M_PI * t / 7),
                    Eigen::Vector3d(wave(0.03 * a, 5, 0, t), 0, wave(0.02 * a, 6, 1.0, t)),
                    wave(10 * kDeg * a, 8, 0.4, t));
    const Eigen::Matrix3d tremor =
        yawPitchRoll(wave(1.0 * kDeg * a, 0.27, 0, t) + wave(0.5 * kDeg * a, 0.19, 1.3, t),
                     wave(0.8 * kDeg * a, 0.37, 0.5, t) + wave(0.4 * kDeg * a, 0.23, 2.1, t),
                     wave(0.6 * kDeg * a, 0.45, 1.0, t));
    const Eigen::Vector3d jitter(wave(0.003 * a, 0.33, 0, t), wave(0.003 * a, 0.29, 0.8, t),
                                 wave(0.002 * a, 0.41, 1.7, t));
    return sway * pose(tremor, jitter);
  }
  // "still" (and anything unknown: validate() rejects unknown names).
  return pose(wallView(), Eigen::Vector3d::Zero());
}

Eigen::Isometry3d planeMotion(const ScenePlane& plane, double t) {
  Eigen::Isometry3d M = Eigen::Isometry3d::Identity();
  if (plane.motion.empty()) return M;
  const double A = plane.motion_amplitude;
  const double wt = 2 * M_PI * t / plane.motion_period + plane.motion_phase;
  if (plane.motion == "slide") {
    M.translation() << A * std::sin(wt), 0.3 * A * std::sin(1.3 * wt), 0;
  } else if (plane.motion == "slide_rotate") {
    M.translation() << 0.5 * A * std::sin(wt), 0.15 * A * std::sin(1.3 * wt), 0;
    M.linear() =
        (Eigen::AngleAxisd(15 * kDeg * std::sin(0.8 * wt + 0.5), Eigen::Vector3d::UnitZ()) *
         Eigen::AngleAxisd(10 * kDeg * std::sin(0.6 * wt + 1.0), Eigen::Vector3d::UnitY()))
            .toRotationMatrix();
  } else if (plane.motion == "approach") {
    M.translation() << 0, 0.2 * A * std::sin(wt), -A * 0.5 * (1 - std::cos(wt));
  } else if (plane.motion == "follow_camera") {
    // The shake relative to the camera (SceneGenerator::T_world_plane adds
    // the camera's own motion).
    M.translation() << A * std::sin(wt), 0.6 * A * std::sin(1.7 * wt + 1.0),
        1.5 * A * std::sin(0.45 * wt + 2.0);
    M.linear() = Eigen::AngleAxisd(2 * kDeg * std::sin(1.3 * wt + 0.5), Eigen::Vector3d::UnitZ())
                     .toRotationMatrix();
  }
  return M;
}

bool presetLayout(const std::string& name, SceneOptions* o) {
  o->planes.clear();
  o->anchors.clear();
  // Walls and the floor repeat a 2048 px texture every 3 m (683 px/m: sharp
  // down to ~0.8 m viewing distance, no seams since the texture is periodic).
  auto wall = [&](double w, double h) {
    ScenePlane p;
    p.kind = ScenePlane::Kind::kBackground;
    p.width_m = w;
    p.height_m = h;
    p.T_world_plane = facingCamera(Eigen::Vector3d(0, kWallDistance, 0));
    p.texture_seed = 1;
    p.texture_size = 2048;
    p.texture_tile_m = 3.0;
    o->planes.push_back(p);
    return &o->planes.back();
  };
  // Something on the wall (1 mm in front of it), or a card in front of it.
  auto onWall = [&](ScenePlane::Kind kind, uint32_t id, double x, double z, double w, double h,
                    double depth_in_front) {
    ScenePlane p;
    p.kind = kind;
    p.id = id;
    p.width_m = w;
    p.height_m = h;
    p.T_world_plane = facingCamera(Eigen::Vector3d(x, kWallDistance - depth_in_front, z));
    p.texture_seed = static_cast<int>(o->planes.size()) + 1;
    o->planes.push_back(p);
    return &o->planes.back();
  };

  if (name == "wall_pan" || name == "planar" || name == "rotate" || name == "still") {
    wall(10.0, 7.5);
  } else if (name == "featureless_wall") {
    ScenePlane* w = wall(10.0, 7.5);
    w->flat = true;
    w->flat_gray = 128;
  } else if (name == "cards") {
    wall(10.0, 7.5);
    // Upper half: card 1 starts at the left and sweeps across in front of
    // card 2 and back every 5 s (1 m/s at the centre), each pass occluding
    // card 2 for ~1 s. Lower half: the static textured patch (4),
    // card 3 approaching the camera, the featureless patch (5).
    ScenePlane* c1 = onWall(ScenePlane::Kind::kCard, 1, 0.0, 0.3, 0.45, 0.35, 0.8);
    c1->motion = "slide";
    c1->motion_amplitude = 0.8;
    c1->motion_period = 5.0;
    c1->motion_phase = -M_PI / 2;
    ScenePlane* c2 = onWall(ScenePlane::Kind::kCard, 2, 0.1, 0.25, 0.55, 0.4, 0.5);
    c2->motion = "slide_rotate";
    c2->motion_amplitude = 0.3;
    c2->motion_period = 7.0;
    ScenePlane* c3 = onWall(ScenePlane::Kind::kCard, 3, 0.0, -0.4, 0.5, 0.38, 0.4);
    c3->motion = "approach";
    c3->motion_amplitude = 0.5;
    c3->motion_period = 6.0;
    onWall(ScenePlane::Kind::kCard, 4, -0.8, -0.55, 0.5, 0.4, 0.001);  // static textured patch
    ScenePlane* flat = onWall(ScenePlane::Kind::kFeatureless, 5, 0.8, -0.55, 0.5, 0.4, 0.001);
    flat->flat_gray = 150;
  } else if (name == "region_small") {
    wall(10.0, 7.5);
    // A 6.6 x 16 cm card 0.4 m in front of the wall: ~35 x 85 px at 1280x720,
    // moving about at up to 0.19 m/s (~3 px/frame), against the pan at first.
    ScenePlane* c = onWall(ScenePlane::Kind::kCard, 1, -0.1, -0.05, 0.066, 0.161, 0.4);
    c->motion = "slide";
    c->motion_amplitude = 0.15;
    c->motion_period = 5.0;
    c->motion_phase = M_PI;
  } else if (name == "region_follow") {
    wall(14.0, 9.0);
    // A 25 x 20 cm card 1 m ahead of the camera, riding with it (follow_camera)
    // and shaking: +-3 cm across (+-17 px), +-4.5 cm in depth, +-2 deg roll.
    ScenePlane c;
    c.kind = ScenePlane::Kind::kCard;
    c.id = 1;
    c.width_m = 0.25;
    c.height_m = 0.2;
    c.T_world_plane = trajectoryPose("dolly", o->trajectory_amplitude, 0.0) *
                      Eigen::Translation3d(0.0, 0.05, 1.0);
    c.motion = "follow_camera";
    c.motion_amplitude = 0.03;
    c.motion_period = 2.5;
    c.texture_seed = 2;
    o->planes.push_back(c);
  } else if (name == "region_static_covered") {
    wall(10.0, 7.5);
    // The static patch (1), and card 2 0.5 m in front of the wall: at t = 0
    // it covers the right part of the patch, then moves off to the right
    // (0.4 m/s) and down, and does not come back within 6 s.
    onWall(ScenePlane::Kind::kCard, 1, -0.3, -0.1, 0.5, 0.4, 0.001);
    ScenePlane* c = onWall(ScenePlane::Kind::kCard, 2, 0.045, -0.08, 0.45, 0.35, 0.5);
    c->motion = "slide";
    c->motion_amplitude = 1.0;
    c->motion_period = 16.0;
  } else if (name == "region_midstart") {
    wall(10.0, 7.5);
    // One card 0.6 m in front of the wall: slides +-0.4 m, rolls +-15 deg
    // and tilts +-10 deg (up to ~4 px/frame).
    ScenePlane* c = onWall(ScenePlane::Kind::kCard, 1, 0.0, 0.0, 0.45, 0.35, 0.6);
    c->motion = "slide_rotate";
    c->motion_amplitude = 0.8;
    c->motion_period = 6.0;
  } else if (name == "region_hidden") {
    wall(10.0, 7.5);
    // The target card (1), 0.4 m in front of the wall, slides right behind an
    // opaque textured panel (2) 1 m in front of the wall, turns there (its
    // rightmost point at t = 4 s) and comes back out.
    ScenePlane* c = onWall(ScenePlane::Kind::kCard, 1, -0.3, 0.0, 0.3, 0.24, 0.4);
    c->motion = "slide";
    c->motion_amplitude = 0.5;
    c->motion_period = 10.0;
    c->motion_phase = -0.3 * M_PI;
    onWall(ScenePlane::Kind::kCard, 2, 0.125, 0.0, 0.3, 1.2, 1.0);
  } else if (name == "poster_orbit") {
    wall(14.0, 9.0);
    ScenePlane* poster = onWall(ScenePlane::Kind::kTarget, 1, 0, 0, 0.6, 0.45, 0.001);
    poster->texture_size = 1024;
  } else if (name == "poster_handheld") {
    wall(14.0, 9.0);
    // An A4 page (landscape) on the wall, and a textured card 0.2 m in front
    // of it sweeping across it and back (from the left, +-0.25 m, 6 s).
    ScenePlane* page = onWall(ScenePlane::Kind::kTarget, 1, 0, 0, 0.297, 0.21, 0.001);
    page->texture_size = 1024;
    ScenePlane* card = onWall(ScenePlane::Kind::kCard, 2, 0, 0.02, 0.12, 0.16, 0.2);
    card->texture_seed = 77;
    card->motion = "slide";
    card->motion_amplitude = 0.25;
    card->motion_period = 6.0;
    card->motion_phase = -M_PI / 2;
  } else if (name == "floor_walk") {
    // 12 m across, 20 m along the walk (10 m behind the start: pixels above
    // the horizon would meet it behind the camera if they were not masked).
    ScenePlane floor;
    floor.kind = ScenePlane::Kind::kBackground;
    floor.width_m = 12.0;
    floor.height_m = 20.0;
    // Seen from above: x = world x, y = world -y (texture top is far ahead), z = world down.
    floor.T_world_plane = pose(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()).toRotationMatrix(),
                               Eigen::Vector3d(0, -2.0, 0));
    floor.texture_seed = 1;
    floor.texture_size = 2048;
    floor.texture_tile_m = 3.0;
    o->planes.push_back(floor);
    // The anchor: on the floor near where the optical axis meets it at t = 0.
    const Eigen::Isometry3d T = trajectoryPose("walk", o->trajectory_amplitude, 0.0);
    const Eigen::Vector3d c = T.translation(), d = T.linear().col(2);
    SceneAnchor anchor;
    anchor.id = 1;
    anchor.p_world = c - (c.z() / d.z()) * d + Eigen::Vector3d(0.15, 0.1, 0);
    anchor.placed_at = 0.0;
    o->anchors.push_back(anchor);
  } else {
    return false;
  }
  return true;
}

}  // namespace scene_detail

std::vector<std::string> SceneOptions::presetNames() {
  std::vector<std::string> names = {"wall_pan",        "cards",      "poster_orbit",
                                    "poster_handheld", "floor_walk", "planar",
                                    "rotate",          "still",      "featureless_wall"};
  for (const char* region_class : {"region_small", "region_follow", "region_static_covered",
                                   "region_midstart", "region_hidden"})
    names.push_back(region_class);
  return names;
}

std::vector<std::string> SceneOptions::trajectoryNames() {
  return {"pan", "zoom", "planar", "rotate", "still", "orbit", "walk", "dolly", "handheld"};
}

std::optional<SceneOptions> SceneOptions::fromPreset(const std::string& name) {
  SceneOptions o;  // the defaults are wall_pan's
  o.preset = name;
  // The region_* failure classes: 8 s or less (fast tests), with the motion
  // blur of a half-frame exposure (1/60 s: 1.5-3 px at their speeds).
  auto regionClass = [&o](const std::string& trajectory, double amplitude, double duration) {
    o.trajectory = trajectory;
    o.trajectory_amplitude = amplitude;
    o.duration = duration;
    o.exposure = 0.5 / o.fps;
    o.blur_samples = 4;
  };
  if (name == "wall_pan" || name == "featureless_wall") {
    o.trajectory = "pan";
  } else if (name == "cards") {
    o.trajectory = "pan";
    o.trajectory_amplitude = 0.6;
  } else if (name == "poster_handheld") {
    // Motion blur of a 1/60 s exposure.
    o.trajectory = "handheld";
    o.duration = 10.0;
    o.exposure = 0.5 / o.fps;
    o.blur_samples = 5;
  } else if (name == "poster_orbit") {
    o.trajectory = "orbit";
    o.duration = 20.0;
    o.brightness_amplitude = 0.25;
    o.brightness_period = 7.0;
  } else if (name == "floor_walk") {
    o.trajectory = "walk";
    o.duration = 12.0;
  } else if (name == "planar" || name == "rotate") {
    o.trajectory = name;
  } else if (name == "still") {
    o.trajectory = name;
    o.brightness_amplitude = 0;  // consecutive frames differ by sensor noise only
  } else if (name == "region_small") {
    regionClass("pan", 0.4, 8.0);
    o.width = 1280;
    o.height = 720;
    o.blur_samples = 3;  // ~50 ms per 1280x720 frame, each further sample ~15 ms
  } else if (name == "region_follow") {
    regionClass("dolly", 1.0, 8.0);
  } else if (name == "region_static_covered") {
    regionClass("pan", 0.4, 6.0);
  } else if (name == "region_midstart") {
    regionClass("pan", 0.6, 8.0);
  } else if (name == "region_hidden") {
    regionClass("pan", 0.4, 8.0);
  } else {
    return std::nullopt;
  }
  scene_detail::presetLayout(name, &o);
  return o;
}

}  // namespace imt
