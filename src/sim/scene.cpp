// SceneGenerator: options validation, textures, rendering of frames, ground
// truth and the IMU stream. Layouts and trajectories: scene_presets.cpp;
// rasterisation: scene_render.cpp; textures: scene_texture.cpp.
#include "instant_motion_tracking/sim/scene.h"

#include "scene_internal.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <set>
#include <sstream>

namespace imt {

using scene_detail::MipTexture;
using scene_detail::PlaneView;
using scene_detail::Polygon;
using scene_detail::showThroughLens;
using scene_detail::drawOrder;
using scene_detail::kGravity;

namespace {


// Collects the first problem as "field: message".
class Checker {
 public:
  template <class T>
  void check(bool ok, const std::string& field, const std::string& what, const T& value) {
    if (ok || !error_.empty()) return;
    std::ostringstream s;
    s << field << " " << what << " (got " << value << ")";
    error_ = s.str();
  }
  void range(const std::string& field, double v, double lo, double hi) {
    std::ostringstream w;
    w << "must be in [" << lo << ", " << hi << "]";
    check(std::isfinite(v) && v >= lo && v <= hi, field, w.str(), v);
  }
  void positive(const std::string& field, double v, double hi) {
    std::ostringstream w;
    w << "must be > 0 and <= " << hi;
    check(std::isfinite(v) && v > 0 && v <= hi, field, w.str(), v);
  }
  const std::string& error() const { return error_; }

 private:
  std::string error_;
};

bool finitePose(const Eigen::Isometry3d& T) {
  return T.matrix().allFinite() &&
         (T.linear().transpose() * T.linear() - Eigen::Matrix3d::Identity()).norm() < 1e-6 &&
         T.linear().determinant() > 0;
}

// Procedural texture size for a plane: tiled planes get square textures
// (auto 2048); others `texture_size` along the longer side (auto ~400 px/m,
// 512..3072) and the other side in proportion (multiples of 16 keep the
// octave noise periodic).
cv::Size textureSize(const ScenePlane& p) {
  if (p.texture_tile_m > 0) {
    const int n = p.texture_size > 0 ? p.texture_size : 2048;
    return cv::Size(n, n);
  }
  const double longer = std::max(p.width_m, p.height_m);
  int n = p.texture_size;
  if (n <= 0) n = std::clamp(static_cast<int>(std::lround(400 * longer / 64.0)) * 64, 512, 3072);
  const int m = std::max(
      16, static_cast<int>(std::lround(n * std::min(p.width_m, p.height_m) / longer / 16)) * 16);
  return p.width_m >= p.height_m ? cv::Size(n, m) : cv::Size(m, n);
}

}  // namespace

// ---------------------------------------------------------------------------
// The camera: pinhole of hfov_deg plus the lens distortion.

namespace {

// Points along the image's border (our pixels), every `step` px.
std::vector<cv::Point2d> borderPoints(int w, int h, double step) {
  std::vector<cv::Point2d> pts;
  for (double x = 0; x <= w; x += step) {
    pts.emplace_back(x, 0);
    pts.emplace_back(x, h);
  }
  for (double y = 0; y <= h; y += step) {
    pts.emplace_back(0, y);
    pts.emplace_back(w, y);
  }
  return pts;
}

// The scene's camera model; false (*why) when the distortion is unknown,
// malformed, or not one-to-one over the image (a polynomial folding back:
// image border points must come back from distort(undistort(p)) within 0.01 px).
bool lensModel(const SceneOptions& o, std::string* why, CameraModel* out = nullptr) {
  CameraModel k = CameraModel::fromFieldOfView(o.width, o.height, o.hfov_deg);
  CameraModel::Distortion d;
  if (!CameraModel::parseDistortion(o.distortion_model, &d)) {
    *why = "unknown distortion_model '" + o.distortion_model + "'";
    return false;
  }
  if (!k.setDistortion(d, o.distortion, why)) return false;
  if (k.valid && k.hasDistortion()) {
    const std::vector<cv::Point2d> border = borderPoints(o.width, o.height, 8.0);
    std::vector<cv::Point2d> back = border;
    k.undistort(&back);
    k.distort(&back);
    for (size_t i = 0; i < border.size(); ++i) {
      if (!(cv::norm(back[i] - border[i]) < 0.01)) {
        *why = "distortion is not invertible at the image border";
        return false;
      }
    }
  }
  if (out) *out = k;
  return true;
}

}  // namespace

namespace scene_detail {

// Where the lens shows ideal pixel `p`. Inside `field` (the ideal pixels of
// the image's own field, where the lens is one-to-one) the distortion;
// beyond it a polynomial lens folds back, so points outside continue from
// the field's border with unit slope (outside the image either way).
cv::Point2d showThroughLens(const CameraModel& k, const cv::Rect& field, const cv::Point2d& p) {
  if (!k.hasDistortion() || !(std::isfinite(p.x) && std::isfinite(p.y))) return p;
  const cv::Point2d c(k.cx, k.cy);
  const cv::Point2d d = p - c;
  // The largest s in [0, 1] with c + s d inside the field.
  double s = 1.0;
  if (d.x > 0) s = std::min(s, (field.x + field.width - c.x) / d.x);
  if (d.x < 0) s = std::min(s, (field.x - c.x) / d.x);
  if (d.y > 0) s = std::min(s, (field.y + field.height - c.y) / d.y);
  if (d.y < 0) s = std::min(s, (field.y - c.y) / d.y);
  if (s >= 1.0) return k.distort(p);
  const cv::Point2d b = c + std::max(0.0, s) * d;
  return k.distort(b) + (p - b);
}

}  // namespace scene_detail

// ---------------------------------------------------------------------------
// SceneOptions::validate

std::string SceneOptions::validate() const {
  Checker c;
  if (planes.empty()) {
    // The preset's layout will be used: it only makes sense with its trajectory.
    const std::optional<SceneOptions> p = fromPreset(preset);
    c.check(p.has_value(), "preset", "is not a known preset (and planes is empty)", preset);
    if (p) {
      c.check(p->trajectory == trajectory, "trajectory",
              "does not suit the layout of preset '" + preset + "' (use SceneOptions::fromPreset)",
              trajectory);
    }
  }
  c.positive("duration", duration, 24 * 3600.0);
  c.positive("fps", fps, 1000.0);
  c.range("width", width, 16, 8192);
  c.range("height", height, 16, 8192);
  c.check(hfov_deg > 1 && hfov_deg < 179, "hfov_deg", "must be in (1, 179)", hfov_deg);
  {
    std::string why;
    const bool lens_ok = lensModel(*this, &why);
    c.check(lens_ok, "distortion", why, "'" + distortion_model + "'");
  }
  c.range("start_time", start_time, 0, 1e10);
  c.range("supersample", supersample, 1, 8);
  c.range("noise_sigma", noise_sigma, 0, 100);
  c.range("brightness_amplitude", brightness_amplitude, 0, 0.9);
  c.positive("brightness_period", brightness_period, 1e6);
  c.range("exposure", exposure, 0, fps > 0 ? 1.0 / fps : 0.0);
  c.range("blur_samples", blur_samples, exposure > 0 ? 2 : 1, 64);
  c.range("void_gray", void_gray, 0, 255);
  c.positive("imu_rate", imu_rate, 10000.0);
  c.range("gyro_noise", gyro_noise, 0, 10);
  c.range("accel_noise", accel_noise, 0, 100);
  c.check(gyro_bias.allFinite() && gyro_bias.norm() < 10, "gyro_bias",
          "must be finite and < 10 rad/s", gyro_bias.transpose());
  c.check(q_cam_imu.coeffs().allFinite() && std::abs(q_cam_imu.norm() - 1) < 1e-3, "q_cam_imu",
          "must be a unit quaternion", q_cam_imu.coeffs().transpose());
  c.check(scene_detail::knownTrajectory(trajectory), "trajectory", "is not a known trajectory",
          trajectory);
  c.range("trajectory_amplitude", trajectory_amplitude, 0, 3);
  std::set<uint32_t> region_ids, target_ids, anchor_ids;
  for (size_t i = 0; i < planes.size(); ++i) {
    const ScenePlane& p = planes[i];
    const std::string f = "planes[" + std::to_string(i) + "].";
    c.positive(f + "width_m", p.width_m, 1e4);
    c.positive(f + "height_m", p.height_m, 1e4);
    c.check(finitePose(p.T_world_plane), f + "T_world_plane", "must be a finite rigid transform",
            p.T_world_plane.matrix().row(0));
    c.check(scene_detail::knownPlaneMotion(p.motion), f + "motion",
            "must be one of \"\", slide, slide_rotate, approach, follow_camera", p.motion);
    c.positive(f + "motion_period", p.motion_period, 1e6);
    c.range(f + "motion_amplitude", p.motion_amplitude, -100, 100);
    c.range(f + "motion_phase", p.motion_phase, -1e6, 1e6);
    c.range(f + "flat_gray", p.flat_gray, 0, 255);
    c.range(f + "texture_tile_m", p.texture_tile_m, 0, 1e4);
    c.check(p.texture_tile_m == 0 || std::max(p.width_m, p.height_m) / p.texture_tile_m < 1000,
            f + "texture_tile_m", "gives more than 1000 tiles along the plane", p.texture_tile_m);
    c.check(p.texture_size == 0 || (p.texture_size >= 16 && p.texture_size <= 8192),
            f + "texture_size", "must be 0 (auto) or in [16, 8192]", p.texture_size);
    if (p.kind == ScenePlane::Kind::kTarget) {
      c.check(p.id != 0, f + "id", "must be non-zero for a target", p.id);
      c.check(target_ids.insert(p.id).second, f + "id", "duplicates another target's id", p.id);
    } else if (p.id != 0) {
      c.check(region_ids.insert(p.id).second, f + "id", "duplicates another region's id", p.id);
    }
  }
  for (size_t i = 0; i < anchors.size(); ++i) {
    const SceneAnchor& a = anchors[i];
    const std::string f = "anchors[" + std::to_string(i) + "].";
    c.check(a.id != 0, f + "id", "must be non-zero", a.id);
    c.check(anchor_ids.insert(a.id).second, f + "id", "duplicates another anchor's id", a.id);
    c.check(a.p_world.allFinite(), f + "p_world", "must be finite", a.p_world.transpose());
    c.range(f + "placed_at", a.placed_at, 0, duration);
  }
  return c.error();
}

// ---------------------------------------------------------------------------
// SceneGenerator


SceneGenerator::SceneGenerator(const SceneOptions& options) : options_(options) {}
SceneGenerator::~SceneGenerator() = default;

std::unique_ptr<SceneGenerator> SceneGenerator::create(const SceneOptions& options,
                                                       std::string* error) {
  auto fail = [&](const std::string& e) {
    if (error) *error = e;
    return std::unique_ptr<SceneGenerator>();
  };
  const std::string e = options.validate();
  if (!e.empty()) return fail(e);
  SceneOptions o = options;
  if (o.planes.empty()) {
    const bool keep_anchors = !o.anchors.empty();
    const std::vector<SceneAnchor> anchors = o.anchors;
    scene_detail::presetLayout(o.preset, &o);
    if (keep_anchors) o.anchors = anchors;
    const std::string e2 = o.validate();
    if (!e2.empty()) return fail(e2);
  }
  o.q_cam_imu.normalize();

  auto impl = std::make_shared<Impl>();
  std::string lens_error;
  if (!lensModel(o, &lens_error, &impl->K)) return fail("distortion: " + lens_error);
  if (impl->K.hasDistortion()) {
    // The canvas: the undistorted image border's bounding box, plus a margin
    // for the bilinear lookup.
    std::vector<cv::Point2d> border = borderPoints(o.width, o.height, 2.0);
    impl->K.undistort(&border);
    double x0 = 0, y0 = 0, x1 = o.width, y1 = o.height;
    for (const cv::Point2d& p : border) {
      x0 = std::min(x0, p.x), x1 = std::max(x1, p.x);
      y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
    }
    const int l = static_cast<int>(std::floor(x0)) - 2, t = static_cast<int>(std::floor(y0)) - 2;
    impl->canvas = cv::Rect(l, t, static_cast<int>(std::ceil(x1)) + 2 - l,
                            static_cast<int>(std::ceil(y1)) + 2 - t);
    if (impl->canvas.width > 4 * o.width || impl->canvas.height > 4 * o.height)
      return fail("distortion: the lens sees more than 4x the pinhole's field; not rendered");
    std::vector<cv::Point2d> centres;
    centres.reserve(static_cast<size_t>(o.width) * o.height);
    for (int r = 0; r < o.height; ++r)
      for (int c = 0; c < o.width; ++c) centres.emplace_back(c + 0.5, r + 0.5);
    impl->K.undistort(&centres);
    impl->lens_map_x.create(o.height, o.width, CV_32FC1);
    impl->lens_map_y.create(o.height, o.width, CV_32FC1);
    for (int r = 0; r < o.height; ++r) {
      for (int c = 0; c < o.width; ++c) {
        const cv::Point2d& p = centres[static_cast<size_t>(r) * o.width + c];
        impl->lens_map_x.at<float>(r, c) = static_cast<float>(p.x - impl->canvas.x - 0.5);
        impl->lens_map_y.at<float>(r, c) = static_cast<float>(p.y - impl->canvas.y - 0.5);
      }
    }
  }
  size_t next_file = 0, backgrounds = 0;
  for (size_t i = 0; i < o.planes.size(); ++i) {
    const ScenePlane& p = o.planes[i];
    if (p.kind == ScenePlane::Kind::kBackground) {
      ++backgrounds;
      impl->background = static_cast<int>(i);
    }
    if (p.isFlat()) {
      impl->textures.emplace_back();
      continue;
    }
    std::string file = p.texture_file;
    std::string field = "planes[" + std::to_string(i) + "].texture_file";
    if (file.empty() && !o.texture_files.empty() &&
        (p.kind == ScenePlane::Kind::kBackground || p.kind == ScenePlane::Kind::kCard)) {
      field = "texture_files[" + std::to_string(next_file % o.texture_files.size()) + "]";
      file = o.texture_files[next_file++ % o.texture_files.size()];
    }
    const bool periodic = p.texture_tile_m > 0;
    if (!file.empty()) {
      const cv::Mat tex = cv::imread(file, cv::IMREAD_GRAYSCALE);
      if (tex.empty() || tex.cols < 2 || tex.rows < 2)
        return fail(field + " cannot be read as an image: '" + file + "'");
      impl->textures.push_back(
          std::make_shared<const MipTexture>(scene_detail::buildMips(tex, periodic)));
    } else {
      impl->textures.push_back(scene_detail::proceduralMips(
          textureSize(p), scene_detail::mixSeed(o.seed, p.texture_seed), periodic));
    }
  }
  if (backgrounds != 1) impl->background = -1;

  std::unique_ptr<SceneGenerator> gen(new SceneGenerator(o));
  for (const SceneAnchor& a : o.anchors) {
    // Anchor frame: z up, x the viewing direction at placement levelled, y = z x x.
    const Eigen::Matrix3d R_wc = gen->T_world_cam(a.placed_at).linear();
    Eigen::Vector3d x = R_wc.col(2);
    x.z() = 0;
    if (x.norm() < 1e-6) {  // looking straight down/up: use the image's up direction
      x = -R_wc.col(1);
      x.z() = 0;
    }
    x.normalize();
    Eigen::Matrix3d R;
    R.col(0) = x;
    R.col(2) = Eigen::Vector3d::UnitZ();
    R.col(1) = R.col(2).cross(x);
    impl->R_world_anchor.push_back(R);
  }
  gen->impl_ = impl;
  return gen;
}

int SceneGenerator::frameCount() const {
  return std::max(1, static_cast<int>(std::floor(options_.duration * options_.fps + 1e-6)));
}

double SceneGenerator::frameStamp(int i) const { return options_.start_time + i / options_.fps; }

CameraModel SceneGenerator::intrinsics() const { return impl_->K; }

Eigen::Isometry3d SceneGenerator::T_world_cam(double t) const {
  return scene_detail::trajectoryPose(options_.trajectory, options_.trajectory_amplitude, t);
}

Eigen::Isometry3d SceneGenerator::T_world_plane(size_t plane, double t) const {
  const ScenePlane& p = options_.planes.at(plane);
  if (p.motion == "follow_camera")  // rigidly with the camera from its pose at t = 0
    return T_world_cam(t) * T_world_cam(0).inverse() * p.T_world_plane *
           scene_detail::planeMotion(p, t);
  return p.T_world_plane * scene_detail::planeMotion(p, t);
}

double SceneGenerator::brightnessGain(double t) const {
  return 1.0 + options_.brightness_amplitude * std::sin(2 * M_PI * t / options_.brightness_period);
}

std::optional<cv::Point2d> SceneGenerator::project(const Eigen::Vector3d& p_world, double t) const {
  const Eigen::Vector3d p = T_world_cam(t).inverse() * p_world;
  if (p.z() <= 0) return std::nullopt;
  const CameraModel& K = impl_->K;
  return showThroughLens(K, impl_->canvas,
                         cv::Point2d(K.fx * p.x() / p.z() + K.cx, K.fy * p.y() / p.z() + K.cy));
}

namespace scene_detail {

// Painter's order: backgrounds first, the rest far to near (by centre depth),
// then fixed up so that a plane whose centre lies on the camera's side of
// another plane is painted after it.
std::vector<size_t> drawOrder(const std::vector<ScenePlane>& planes,
                              const std::vector<Eigen::Isometry3d>& T_cam_plane) {
  std::vector<size_t> order(planes.size());
  for (size_t i = 0; i < order.size(); ++i) order[i] = i;
  auto isBackground = [&](size_t i) { return planes[i].kind == ScenePlane::Kind::kBackground; };
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    if (isBackground(a) != isBackground(b)) return isBackground(a);
    return T_cam_plane[a].translation().z() > T_cam_plane[b].translation().z();
  });
  // `a` must precede `b`: b's centre is on the camera's side of a's plane.
  auto precedes = [&](size_t a, size_t b) {
    const Eigen::Isometry3d T_a_cam = T_cam_plane[a].inverse();
    const double cam = T_a_cam.translation().z();
    const double other = (T_a_cam * T_cam_plane[b].translation()).z();
    return std::abs(other) > 1e-6 && (cam > 0) == (other > 0);
  };
  for (size_t pass = 0; pass < order.size(); ++pass) {
    bool swapped = false;
    for (size_t i = 0; i + 1 < order.size(); ++i) {
      const size_t a = order[i], b = order[i + 1];
      if (isBackground(a) != isBackground(b)) continue;
      if (precedes(b, a) && !precedes(a, b)) {
        std::swap(order[i], order[i + 1]);
        swapped = true;
      }
    }
    if (!swapped) break;
  }
  return order;
}

}  // namespace scene_detail

cv::Mat SceneGenerator::renderAt(double t) const {
  const SceneOptions& o = options_;
  const int ss = o.supersample;
  // Without distortion the canvas is the image; with it, the pinhole view of
  // the lens's whole field (remapped through the lens below).
  const bool lens = impl_->K.hasDistortion();
  const cv::Size canvas_size = lens ? impl_->canvas.size() : cv::Size(o.width, o.height);
  const int cw = canvas_size.width * ss, ch = canvas_size.height * ss;
  Eigen::Matrix3d Kc = impl_->K.K();
  if (lens) {
    Kc(0, 2) -= impl_->canvas.x;
    Kc(1, 2) -= impl_->canvas.y;
  }
  Kc.topRows<2>() *= ss;

  auto renderInstant = [&](double tt) {
    cv::Mat canvas(ch, cw, CV_32FC1, cv::Scalar(o.void_gray));
    const Eigen::Isometry3d T_cam_world = T_world_cam(tt).inverse();
    std::vector<Eigen::Isometry3d> T_cam_plane(o.planes.size());
    for (size_t i = 0; i < o.planes.size(); ++i)
      T_cam_plane[i] = T_cam_world * T_world_plane(i, tt);
    for (size_t i : drawOrder(o.planes, T_cam_plane)) {
      const ScenePlane& p = o.planes[i];
      const PlaneView view =
          scene_detail::makePlaneView(Kc, T_cam_plane[i], p.width_m, p.height_m, cw, ch);
      scene_detail::PlaneLook look;
      look.texture = impl_->textures[i].get();
      look.width_m = p.width_m;
      look.height_m = p.height_m;
      look.tile_w_m = p.texture_tile_m;
      look.flat_gray = p.flat_gray;
      scene_detail::paintPlane(view, look, &canvas);
    }
    if (ss > 1) cv::resize(canvas, canvas, canvas_size, 0, 0, cv::INTER_AREA);
    if (lens) {
      cv::Mat seen;
      cv::remap(canvas, seen, impl_->lens_map_x, impl_->lens_map_y, cv::INTER_LINEAR,
                cv::BORDER_CONSTANT, cv::Scalar(o.void_gray));
      return seen;
    }
    return canvas;
  };

  cv::Mat img;
  if (o.exposure > 0) {
    const int n = o.blur_samples;
    img = cv::Mat::zeros(o.height, o.width, CV_32FC1);
    for (int k = 0; k < n; ++k) img += renderInstant(t + o.exposure * (double(k) / (n - 1) - 0.5));
    img *= 1.0 / n;
  } else {
    img = renderInstant(t);
  }
  img *= brightnessGain(t);
  if (o.noise_sigma > 0) {
    cv::RNG rng(
        scene_detail::mixSeed(o.seed, static_cast<uint64_t>(std::llround(t * o.fps)) + 0x5eed));
    cv::Mat noise(img.size(), CV_32FC1);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, o.noise_sigma);
    img += noise;
  }
  cv::Mat out;
  img.convertTo(out, CV_8UC1);  // rounds and saturates
  return out;
}

cv::Mat SceneGenerator::renderFrame(int i) const { return renderAt(i / options_.fps); }

std::optional<Eigen::Matrix3d> SceneGenerator::backgroundHomography(int from, int to) const {
  if (impl_->background < 0 || impl_->K.hasDistortion()) return std::nullopt;
  const size_t b = static_cast<size_t>(impl_->background);
  const Eigen::Matrix3d K = impl_->K.K();
  auto G = [&](int i) {  // plane metres -> image pixels (homogeneous)
    const double t = i / options_.fps;
    const Eigen::Isometry3d T = T_world_cam(t).inverse() * T_world_plane(b, t);
    Eigen::Matrix3d M;
    M << T.linear().col(0), T.linear().col(1), T.translation();
    return Eigen::Matrix3d(K * M);
  };
  Eigen::Matrix3d H = G(to) * G(from).inverse();
  H /= H(2, 2);
  return H;
}

}  // namespace imt
