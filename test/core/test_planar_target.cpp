// Planar target tracking on synthetic motion data with exact ground truth: a
// poster on a textured wall seen by an orbiting, rolling camera that moves in
// by x2, features with persistent IDs and 0.15 px noise, an occluder sweeping
// across. Only feature IDs and positions reach the tracker.
#include "instant_motion_tracking/core/planar/planar_target.h"
#include "instant_motion_tracking/core/planar/planar_target_manager.h"
#include "instant_motion_tracking/sim/scene.h"

// Internal to the core library (the re-acquisition search), tested directly.
#include "../../src/core/planar/planar_appearance.h"

#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <random>

namespace imt {
namespace {

const int kW = 640, kH = 480;
const double kTw = 0.6, kTh = 0.45;  // poster size (m)

CameraModel intrinsics() { return CameraModel::fromFieldOfView(kW, kH, 60.0); }

// Camera pose in the target frame at frame k of n: distance 1.6 m -> 0.8 m,
// yaw up to 45 degrees, pitch 20 degrees, roll up to 30 degrees.
Eigen::Isometry3d T_target_cam(int k, int n) {
  const double s = static_cast<double>(k) / (n - 1);
  const double d = 1.6 - 0.8 * s;
  const double yaw = 0.785 * std::sin(M_PI * s), pitch = 0.35 * std::sin(2 * M_PI * s);
  const double roll = 0.52 * s;
  const Eigen::Vector3d pos(d * std::sin(yaw) * std::cos(pitch), d * std::sin(pitch),
                            -d * std::cos(yaw) * std::cos(pitch));
  const Eigen::Vector3d z = (-pos).normalized();  // looks at the centre
  const Eigen::Vector3d x = Eigen::Vector3d::UnitY().cross(z).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R << x, y, z;
  Eigen::Isometry3d T = Eigen::Isometry3d::Identity();
  T.linear() = R * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  T.translation() = pos;
  return T;
}

struct Scene {
  int n = 0;
  std::vector<Eigen::Vector3d> points;  // target frame
  std::vector<int> kind;                // 0 poster, 1 wall, 2 occluder
  std::vector<MotionData> md;
  std::vector<std::array<cv::Point2d, 4>> corners;
  std::vector<Eigen::Isometry3d> T_cam_target;
};

Eigen::Vector2d project(const CameraModel& k, const Eigen::Vector3d& p) {
  return {k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy};
}

Scene makeScene(int n, bool occluder, uint32_t seed = 3) {
  Scene sc;
  sc.n = n;
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int i = 0; i < 200; ++i) {
    sc.points.emplace_back(0.5 * kTw * u(rng), 0.5 * kTh * u(rng), 0);
    sc.kind.push_back(0);
  }
  for (int i = 0; i < 600; ++i) {  // the wall around it, 1 cm behind
    const Eigen::Vector3d p(2.0 * u(rng), 1.5 * u(rng), 0.01);
    if (std::abs(p.x()) < kTw / 2 + 0.01 && std::abs(p.y()) < kTh / 2 + 0.01) continue;
    sc.points.push_back(p);
    sc.kind.push_back(1);
  }
  const size_t first_occluder = sc.points.size();
  if (occluder) {
    for (int i = 0; i < 60; ++i) {  // a 0.15 m card 10 cm in front, offsets stored
      sc.points.emplace_back(0.075 * u(rng), 0.075 * u(rng), -0.1);
      sc.kind.push_back(2);
    }
  }
  const CameraModel K = intrinsics();
  std::normal_distribution<double> noise(0, 0.15);
  std::vector<uint32_t> ids(sc.points.size(), 0);
  std::vector<uint16_t> age(sc.points.size(), 0);
  uint32_t next = 1;
  for (int k = 0; k < n; ++k) {
    const Eigen::Isometry3d T_ct = T_target_cam(k, n).inverse();
    sc.T_cam_target.push_back(T_ct);
    std::array<cv::Point2d, 4> c;
    const Eigen::Vector3d tc[4] = {{-kTw / 2, -kTh / 2, 0},
                                   {kTw / 2, -kTh / 2, 0},
                                   {kTw / 2, kTh / 2, 0},
                                   {-kTw / 2, kTh / 2, 0}};
    for (int i = 0; i < 4; ++i) {
      const Eigen::Vector2d p = project(K, T_ct * tc[i]);
      c[i] = cv::Point2d(p.x(), p.y());
    }
    sc.corners.push_back(c);
    // The occluder sweeps across the poster between 40% and 70% of the run.
    const double s = static_cast<double>(k) / (n - 1);
    const Eigen::Vector3d occ_centre(-0.6 + 4.0 * (s - 0.4), 0.02, 0);
    const bool occ_on = occluder && s > 0.4 && s < 0.7;
    std::vector<cv::Point2f> occ_quad;
    if (occ_on) {
      for (auto [dx, dy] : {std::pair{-1, -1}, {1, -1}, {1, 1}, {-1, 1}}) {
        const Eigen::Vector2d p =
            project(K, T_ct * (occ_centre + Eigen::Vector3d(0.075 * dx, 0.075 * dy, -0.1)));
        occ_quad.emplace_back(p.x(), p.y());
      }
    }
    MotionData md;
    md.stamp = 1000 + k / 30.0;
    md.width = kW;
    md.height = kH;
    for (size_t i = 0; i < sc.points.size(); ++i) {
      Eigen::Vector3d pt = sc.points[i];
      if (sc.kind[i] == 2) {
        if (!occ_on) {
          ids[i] = 0;
          continue;
        }
        pt += occ_centre;
      }
      const Eigen::Vector3d q = T_ct * pt;
      Eigen::Vector2d p = project(K, q);
      bool visible = q.z() > 0.05 && p.x() >= 0 && p.y() >= 0 && p.x() < kW && p.y() < kH;
      if (visible && occ_on && sc.kind[i] != 2)
        visible = cv::pointPolygonTest(occ_quad, cv::Point2f(p.x(), p.y()), false) < 0;
      if (!visible || (i >= first_occluder && !occ_on)) {
        ids[i] = 0;
        continue;
      }
      if (ids[i] == 0) {
        ids[i] = next++;
        age[i] = 0;
      } else {
        ++age[i];
      }
      p += Eigen::Vector2d(noise(rng), noise(rng));
      FeatureMotion f;
      f.id = ids[i];
      f.age = age[i];
      f.x = p.x();
      f.y = p.y();
      md.features.push_back(f);
    }
    sc.md.push_back(md);
  }
  return sc;
}

double cornerRms(const std::array<cv::Point2d, 4>& a, const std::array<cv::Point2d, 4>& b) {
  double s = 0;
  for (int i = 0; i < 4; ++i) s += std::pow(cv::norm(a[i] - b[i]), 2);
  return std::sqrt(s / 4);
}

double percentile(std::vector<double> v, double p) {
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(p * (v.size() - 1))];
}

struct TrackRun {
  std::vector<double> corner_err, rot_deg, trans_rel;
};

TrackRun track(const Scene& sc, const std::string& model) {
  PlanarTargetOptions opt;
  opt.model = model;
  std::string err;
  auto t =
      PlanarTargetTracker::create(opt, 1, sc.corners[0], kTw, kTh, intrinsics(), sc.md[0], &err);
  EXPECT_TRUE(t) << err;
  TrackRun r;
  if (!t) return r;
  for (int k = 1; k < sc.n; ++k) {
    const PlanarTargetState& s = t->step(sc.md[k], Eigen::Matrix3d::Identity(), false);
    EXPECT_EQ(s.status, TargetStatus::kTracked) << "frame " << k;
    r.corner_err.push_back(cornerRms(s.corners, sc.corners[k]));
    const Eigen::AngleAxisd dR(sc.T_cam_target[k].linear().transpose() * s.T_cam_target.linear());
    r.rot_deg.push_back(std::abs(dR.angle()) * 180 / M_PI);
    r.trans_rel.push_back((s.T_cam_target.translation() - sc.T_cam_target[k].translation()).norm() /
                          sc.T_cam_target[k].translation().norm());
  }
  return r;
}

TEST(PlanarTarget, RigidPoseTracksThePosterWithoutDrift) {
  const Scene sc = makeScene(300, true);
  const TrackRun r = track(sc, "perspective");
  ASSERT_FALSE(r.corner_err.empty());
  std::printf(
      "perspective: corner RMS median %.3f p95 %.3f last %.3f px; rotation median %.3f deg; "
      "translation median %.3f%%\n",
      percentile(r.corner_err, 0.5), percentile(r.corner_err, 0.95), r.corner_err.back(),
      percentile(r.rot_deg, 0.5), 100 * percentile(r.trans_rel, 0.5));
  // The targets (POT alignment error and pose error).
  EXPECT_LT(percentile(r.corner_err, 0.5), 0.5);
  EXPECT_LT(percentile(r.corner_err, 0.95), 1.5);
  EXPECT_LT(r.corner_err.back(), 1.0);
  EXPECT_LT(percentile(r.rot_deg, 0.5), 0.5);
  EXPECT_LT(percentile(r.trans_rel, 0.5), 0.01);
}

TEST(PlanarTarget, ChainedHomographyForComparison) {
  const Scene sc = makeScene(300, true);
  const TrackRun h = track(sc, "homography");
  const TrackRun p = track(sc, "perspective");
  ASSERT_FALSE(h.corner_err.empty());
  std::printf("homography: corner RMS median %.3f p95 %.3f last %.3f px\n",
              percentile(h.corner_err, 0.5), percentile(h.corner_err, 0.95), h.corner_err.back());
  // Chained homographies accumulate drift; the rigid pose does not (paper, Fig. 2).
  EXPECT_GT(h.corner_err.back(), p.corner_err.back());
}

TEST(PlanarTargetManager, TargetGivenMidSequenceIsTrackedBothWays) {
  const Scene sc = makeScene(120, false);
  MotionCache cache(0.0);  // keep everything, as track_bag does
  PlanarTargetManager m{PlanarTargetOptions(), &cache};
  std::string err;
  for (const MotionData& md : sc.md) ASSERT_TRUE(cache.push(md, &err));
  uint32_t id = 0;
  ASSERT_TRUE(m.add(0, sc.md[60].stamp, sc.corners[60], kTw, kTh, intrinsics(), &id, &err))
      << err;
  EXPECT_EQ(id, 1u);
  std::vector<double> e;
  for (uint64_t seq = cache.firstSeq(); seq <= cache.lastSeq(); ++seq) {
    std::vector<PlanarTargetState> states;
    ASSERT_TRUE(m.statesAt(cache.at(seq).stamp, {id}, &states, &err)) << err;
    const PlanarTargetState& s = states.at(0);
    EXPECT_DOUBLE_EQ(s.stamp, cache.at(seq).stamp);
    e.push_back(cornerRms(s.corners, sc.corners[seq - cache.firstSeq()]));
  }
  // Same bar as the forward-only test: no drift in either direction.
  EXPECT_LT(percentile(e, 0.5), 0.5);
  EXPECT_LT(e.front(), 1.0);
  EXPECT_LT(e.back(), 1.0);
  EXPECT_FALSE(m.add(1, 0, sc.corners[60], kTw, kTh, intrinsics(), &id, &err));
  EXPECT_NE(err.find("already tracked"), std::string::npos);
  EXPECT_FALSE(m.remove(9, &err));
  EXPECT_NE(err.find("unknown planar target id 9"), std::string::npos);
}

TEST(PlanarTargetManager, BadRequestsAreNamedEvenBeforeAnyFrame) {
  MotionCache empty(10.0);
  PlanarTargetManager m{PlanarTargetOptions(), &empty};
  uint32_t id;
  std::string err;
  const std::array<cv::Point2d, 4> bowtie = {
      cv::Point2d(100, 100), {200, 200}, {200, 100}, {100, 200}};
  EXPECT_FALSE(m.add(0, 0, bowtie, 0.3, 0.2, intrinsics(), &id, &err));
  EXPECT_NE(err.find("convex"), std::string::npos) << err;
  const std::array<cv::Point2d, 4> good = {
      cv::Point2d(100, 100), {200, 100}, {200, 180}, {100, 180}};
  EXPECT_FALSE(m.add(0, 0, good, -1, 0.2, intrinsics(), &id, &err));
  EXPECT_NE(err.find("size must be positive"), std::string::npos) << err;
  EXPECT_FALSE(m.add(0, 0, good, 0.3, 0.2, intrinsics(), &id, &err));
  EXPECT_NE(err.find("no motion data"), std::string::npos) << err;
}

TEST(PlanarTarget, BadQuadsAndSizesAreRefused) {
  const Scene sc = makeScene(2, false);
  std::string err;
  auto mk = [&](std::array<cv::Point2d, 4> c, double w, double h) {
    return PlanarTargetTracker::create(PlanarTargetOptions(), 1, c, w, h, intrinsics(), sc.md[0],
                                       &err);
  };
  const auto good = sc.corners[0];
  EXPECT_TRUE(mk(good, kTw, kTh)) << err;
  EXPECT_FALSE(mk(good, 0, kTh));
  EXPECT_NE(err.find("size must be positive"), std::string::npos) << err;
  EXPECT_FALSE(mk(good, kTw, -1));
  auto bowtie = good;
  std::swap(bowtie[1], bowtie[2]);
  EXPECT_FALSE(mk(bowtie, kTw, kTh));
  EXPECT_NE(err.find("convex"), std::string::npos) << err;
  // Mirrored (TL, BL, BR, TR): refused here as INIT.yaml refuses it (once
  // accepted, Ceres failed on every frame).
  const std::array<cv::Point2d, 4> mirrored = {good[0], good[3], good[2], good[1]};
  EXPECT_FALSE(mk(mirrored, kTw, kTh));
  EXPECT_NE(err.find("counter-clockwise"), std::string::npos) << err;
  auto line = good;
  line[2] = (line[1] + line[3]) * 0.5;
  EXPECT_FALSE(mk(line, kTw, kTh));
  auto same = good;
  same[1] = same[0];
  EXPECT_FALSE(mk(same, kTw, kTh));
  EXPECT_NE(err.find("coincide"), std::string::npos) << err;
  auto nan = good;
  nan[3].x = NAN;
  EXPECT_FALSE(mk(nan, kTw, kTh));
  EXPECT_NE(err.find("NaN"), std::string::npos) << err;
  PlanarTargetOptions bad;
  bad.model = "affine";
  EXPECT_FALSE(PlanarTargetTracker::create(bad, 1, good, kTw, kTh, intrinsics(), sc.md[0], &err));
  EXPECT_NE(err.find("perspective or homography"), std::string::npos) << err;
}

// The re-acquisition search (planar_detail::searchTemplate): a 64 x 48
// template (a procedural texture) placed at a known shift in a window widened
// by 16 px, with noise; the shift is found to a quarter of a pixel (the
// parabola through the peak's neighbours is biased by up to 0.2 px here;
// the ECC alignment that starts from it does the rest) even with the left 40%
// of the target covered by other texture (the covered tiles are reported as
// not seen), and a repeated pattern gives no clear answer.
TEST(PlanarSearch, FindsTheShiftOfAHalfCoveredTargetAndRefusesARepeatedPattern) {
  using planar_detail::searchTemplate;
  const int margin = 16;
  cv::Mat texture, other;
  proceduralTexture(256, 5).convertTo(texture, CV_32F);
  proceduralTexture(256, 6).convertTo(other, CV_32F);
  const cv::Rect inner(100, 80, 64, 48);
  const cv::Mat tpl = texture(inner).clone();
  const cv::Mat mask(tpl.size(), CV_8U, cv::Scalar(255));
  std::mt19937 rng(3);
  std::normal_distribution<float> noise(0, 2);
  for (const cv::Point shift : {cv::Point(0, 0), cv::Point(7, -5), cv::Point(-13, 11)}) {
    // The window shows the texture moved by -shift: the template is found at +shift.
    const cv::Rect around(inner.x - margin - shift.x, inner.y - margin - shift.y,
                          inner.width + 2 * margin, inner.height + 2 * margin);
    cv::Mat window = texture(around).clone();
    const cv::Rect cover(0, 0, margin + shift.x + static_cast<int>(0.4 * tpl.cols), window.rows);
    other(cv::Rect(0, 0, cover.width, cover.height)).copyTo(window(cover));
    for (auto it = window.begin<float>(); it != window.end<float>(); ++it) *it += noise(rng);
    const planar_detail::SearchMatch m = searchTemplate(tpl, mask, window, margin);
    EXPECT_NEAR(m.shift.x, shift.x, 0.25) << shift;
    EXPECT_NEAR(m.shift.y, shift.y, 0.25) << shift;
    if (std::getenv("IMT_TEST_TRACE"))
      std::printf("shift %d %d found %.3f %.3f score %.3f second %.3f\n", shift.x, shift.y,
                  m.shift.x, m.shift.y, m.score, m.second);
    // Measured: score 0.90-0.95, 0.35-0.41 above the best elsewhere (the
    // defaults ask for 0.6 and 0.15).
    EXPECT_GT(m.score, 0.85) << shift;
    EXPECT_GT(m.score - m.second, 0.25) << shift;
    EXPECT_EQ(m.seen.at<uchar>(tpl.rows / 2, 2), 0) << shift;  // the covered side
    EXPECT_EQ(m.seen.at<uchar>(tpl.rows / 2, tpl.cols - 3), 255) << shift;
  }
  // Stripes with a 12 px period: every period matches as well.
  cv::Mat stripes(tpl.rows + 2 * margin, tpl.cols + 2 * margin, CV_32F);
  for (int r = 0; r < stripes.rows; ++r)
    for (int c = 0; c < stripes.cols; ++c)
      stripes.at<float>(r, c) = 128 + 60 * std::sin(2 * M_PI * c / 12.0) + noise(rng);
  const cv::Mat striped = stripes(cv::Rect(margin, margin, tpl.cols, tpl.rows)).clone();
  const planar_detail::SearchMatch m = searchTemplate(striped, mask, stripes, margin);
  EXPECT_LT(m.score - m.second, PlanarTargetOptions().refine_search_margin);
}

// The alignment's own ECC (planar_detail::alignEcc, inverse compositional)
// against a known warp and against OpenCV's findTransformECC, which
// maximises the same correlation forward-additively: a 96 x 72 template (a
// procedural texture) and the frame on its grid moved by a known homography
// or affine map, with noise; then with the left 40% of the frame covered by
// other texture and masked out; then a frame that shows something else.
TEST(PlanarEcc, FindsAKnownWarpAsFindTransformEccDoes) {
  using planar_detail::alignEcc;
  cv::Mat texture, other;
  proceduralTexture(256, 5).convertTo(texture, CV_32F);
  proceduralTexture(256, 6).convertTo(other, CV_32F);
  const cv::Rect inner(80, 90, 96, 72);
  const cv::Mat tpl = texture(inner).clone();
  const planar_detail::EccTemplate t = planar_detail::EccTemplate::from(tpl);
  const cv::Mat all(tpl.size(), CV_8U, cv::Scalar(255));
  cv::Mat left_covered = all.clone();
  left_covered(cv::Rect(0, 0, static_cast<int>(0.4 * tpl.cols), tpl.rows)) = 0;
  const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-6);
  std::mt19937 rng(7);
  std::normal_distribution<float> noise(0, 2);
  // Farthest a template corner lands from where `C` puts it.
  auto cornerError = [&](const Eigen::Matrix3d& C, const Eigen::Matrix3d& truth) {
    double worst = 0;
    for (const Eigen::Vector3d& x : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(tpl.cols - 1, 0, 1),
                                     Eigen::Vector3d(tpl.cols - 1, tpl.rows - 1, 1),
                                     Eigen::Vector3d(0, tpl.rows - 1, 1)})
      worst = std::max(worst, ((C * x).hnormalized() - (truth * x).hnormalized()).norm());
    return worst;
  };
  const double a = 0.03;  // rad
  Eigen::Matrix3d homography, affine;
  homography << 1.02 * std::cos(a), -std::sin(a), 2.3, std::sin(a), 0.99 * std::cos(a), -1.7, 2e-4, -1e-4, 1;
  affine << 0.98, 0.02, -1.4, -0.03, 1.01, 2.2, 0, 0, 1;
  for (const bool is_affine : {false, true}) {
    const Eigen::Matrix3d& C = is_affine ? affine : homography;  // template pixel -> frame pixel
    for (const bool covered : {false, true}) {
      // The frame on the template's grid: at y it shows the texture's pixel C^-1 y.
      Eigen::Matrix3d to_texture = Eigen::Matrix3d::Identity();
      to_texture(0, 2) = inner.x;
      to_texture(1, 2) = inner.y;
      cv::Mat frame;
      cv::warpPerspective(texture, frame, planar_detail::toMatx(to_texture * C.inverse()), tpl.size(),
                          cv::INTER_LINEAR | cv::WARP_INVERSE_MAP);
      const cv::Mat& mask = covered ? left_covered : all;
      if (covered) other(cv::Rect(0, 0, tpl.cols, tpl.rows)).copyTo(frame, ~left_covered);
      for (auto it = frame.begin<float>(); it != frame.end<float>(); ++it) *it += noise(rng);
      Eigen::Matrix3d found = Eigen::Matrix3d::Identity();
      double rho = 0;
      ASSERT_TRUE(alignEcc(t, frame, all, mask, is_affine, criteria, &found, &rho));
      cv::Mat cv_warp = cv::Mat::eye(is_affine ? 2 : 3, 3, CV_32F);
      cv::findTransformECC(tpl, frame, cv_warp, is_affine ? cv::MOTION_AFFINE : cv::MOTION_HOMOGRAPHY,
                           criteria, mask, 5);
      Eigen::Matrix3d opencv = Eigen::Matrix3d::Identity();
      for (int r = 0; r < cv_warp.rows; ++r)
        for (int c = 0; c < 3; ++c) opencv(r, c) = cv_warp.at<float>(r, c);
      const double ours = cornerError(found, C), theirs = cornerError(opencv, C);
      if (std::getenv("IMT_TEST_TRACE"))
        std::printf("ecc %s%s: corners off by %.4f px (findTransformECC %.4f), rho %.4f\n",
                    is_affine ? "affine" : "homography", covered ? ", 40% covered" : "", ours, theirs, rho);
      // The warp moves the corners by up to 4 px. Measured worst corner
      // 0.05-0.13 px (findTransformECC 0.07-0.52: it lets the masked pixels'
      // neighbours in); corners extrapolate the fit, more so with 40%
      // covered, and the noise alone leaves a few hundredths.
      EXPECT_LT(ours, 0.25) << is_affine << covered;
      EXPECT_LT(ours, theirs + 0.05) << is_affine << covered;
      EXPECT_GT(rho, 0.95) << is_affine << covered;
    }
  }
  // A frame that shows another texture: no alignment worth the name.
  cv::Mat unrelated = other(inner).clone();
  Eigen::Matrix3d found = Eigen::Matrix3d::Identity();
  double rho = 0;
  const bool converged = alignEcc(t, unrelated, all, all, false, criteria, &found, &rho);
  EXPECT_TRUE(!converged || rho < 0.3) << rho;
}

}  // namespace
}  // namespace imt
