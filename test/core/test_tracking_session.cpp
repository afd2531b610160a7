// TrackingSession: the one path of live and offline. The same rendered
// frames go through a live session (frames one by one, the IMU as a late
// driver would deliver it, items given mid-stream at a past frame) and an
// offline one (the whole stream first, then the items, then every frame's
// states); every output must agree. Also: the offline cache reads frames it
// did not keep from its image source, so a tiny image budget changes nothing.
#include "instant_motion_tracking/core/tracking_session.h"

#include "../box_metrics.h"
#include "opencv_threads.h"
#include "scene_test_util.h"

#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <array>
#include <cmath>
#include <cstdio>
#include <functional>
#include <map>
#include <vector>

namespace imt {
namespace {

struct Rendered {
  std::unique_ptr<SceneGenerator> scene;
  std::vector<cv::Mat> frames;
  std::vector<ImuSample> imu;
};

// `target_texture` (a file): the planar target's picture.
Rendered render(const std::string& preset, double duration, std::optional<int> seed = std::nullopt,
                const std::string& target_texture = "") {
  SceneOptions o = test::preset(preset);
  o.duration = duration;
  if (seed) o.seed = *seed;
  for (ScenePlane& p : o.planes)
    if (p.kind == ScenePlane::Kind::kTarget && !target_texture.empty()) p.texture_file = target_texture;
  Rendered r;
  r.scene = test::make(o);
  if (!r.scene) return r;
  for (int i = 0; i < r.scene->frameCount(); ++i) r.frames.push_back(r.scene->renderFrame(i));
  r.imu = r.scene->imuSamples();
  return r;
}

// What to give: a region, a planar target and an anchor at frame `given`,
// handed to the live session once frame `asked` has been analysed.
struct Items {
  int given = 0, asked = 0;
  std::optional<cv::Rect2d> region;
  std::vector<cv::Rect2d> more_regions;  // ids 100, 101, ...
  std::optional<FrameTruth::Target> target;
  std::optional<FrameTruth::Anchor> anchor;
  cv::Mat picture;  // an image target's
  double picture_width_m = 0, picture_height_m = 0;
};

void addItems(TrackingSession& s, const Rendered& r, const Items& items) {
  const double stamp = r.scene->frameStamp(items.given);
  uint32_t id;
  std::string err;
  if (items.region) {
    ASSERT_TRUE(s.addRegion(3, stamp, *items.region, &id, &err)) << err;
  }
  for (size_t i = 0; i < items.more_regions.size(); ++i) {
    ASSERT_TRUE(s.addRegion(static_cast<uint32_t>(100 + i), stamp, items.more_regions[i], &id, &err)) << err;
  }
  if (items.target) {
    ASSERT_TRUE(s.addPlanarTarget(4, stamp, items.target->corners, items.target->width_m, items.target->height_m,
                                  &id, &err))
        << err;
  }
  if (items.anchor) {
    ASSERT_TRUE(s.addAnchor(5, stamp, items.anchor->pixel, items.anchor->T_cam_anchor.translation().norm(), &id, &err))
        << err;
  }
  if (!items.picture.empty()) {
    ASSERT_TRUE(s.addImageTarget(6, stamp, items.picture, items.picture_width_m, items.picture_height_m, &id, &err))
        << err;
  }
}

// Largest difference (px) between two frames' outputs: region boxes, target
// corners, anchor pixels, translations and rotations (m and rad, counted as
// px: all tiny when equal).
double difference(const FrameResult& a, const FrameResult& b) {
  double d = 0;
  auto worse = [&](double v) { d = std::max(d, std::isfinite(v) ? std::abs(v) : INFINITY); };
  if (a.regions.size() != b.regions.size() || a.targets.size() != b.targets.size() ||
      a.anchors.size() != b.anchors.size())
    return INFINITY;
  for (size_t i = 0; i < a.regions.size(); ++i) {
    const cv::Rect2d &p = a.regions[i].box, &q = b.regions[i].box;
    if (a.regions[i].status != b.regions[i].status) return INFINITY;
    for (double v : {p.x - q.x, p.y - q.y, p.width - q.width, p.height - q.height}) worse(v);
  }
  for (size_t i = 0; i < a.targets.size(); ++i) {
    if (a.targets[i].status != b.targets[i].status) return INFINITY;
    for (int k = 0; k < 4; ++k) worse(cv::norm(a.targets[i].corners[k] - b.targets[i].corners[k]));
  }
  for (size_t i = 0; i < a.anchors.size(); ++i) {
    if (a.anchors[i].status != b.anchors[i].status) return INFINITY;
    worse(cv::norm(a.anchors[i].pixel - b.anchors[i].pixel));
    worse((a.anchors[i].T_cam_anchor.translation() - b.anchors[i].T_cam_anchor.translation()).norm());
    worse(Eigen::AngleAxisd(a.anchors[i].T_cam_anchor.linear().transpose() * b.anchors[i].T_cam_anchor.linear()).angle());
  }
  return d;
}

// Live: frames analysed one by one, the IMU fed up to a little past each
// frame (behind it on every third one, as a late driver would), the items
// given at frame `asked`. Returns each frame's result as it came out after
// the items were given, and the frames before by statesAt().
// `give_rotation` false: no IMU-to-camera rotation is given (no tf): the
// session finds it from the video.
std::map<int, FrameResult> runLive(const Rendered& r, const Items& items, const PipelineOptions& o,
                                   bool give_rotation = true) {
  TrackingSession s(o, TrackingSession::Mode::kLive);
  s.setCameraInfo(r.scene->intrinsics());
  s.setKeepImages(true);
  if (give_rotation) {
    EXPECT_TRUE(s.setRotationCamImu(r.scene->options().q_cam_imu));
  }
  std::map<int, FrameResult> out;
  std::map<double, int> index;
  size_t next_imu = 0;
  for (int i = 0; i < static_cast<int>(r.frames.size()); ++i) {
    const double t = r.scene->frameStamp(i);
    index[t] = i;
    while (next_imu < r.imu.size() && r.imu[next_imu].stamp <= t + (i % 3 == 1 ? -0.02 : 0.006))
      s.addImu(r.imu[next_imu++]);
    s.analyze(r.frames[i], t);
    if (i == items.asked) {
      s.takeResults();  // frames tracked before the items existed
      addItems(s, r, items);
    }
    for (FrameResult& fr : s.takeResults())
      if (i > items.asked) out[index[fr.motion.stamp]] = std::move(fr);
  }
  while (next_imu < r.imu.size()) s.addImu(r.imu[next_imu++]);
  s.advance(true);
  for (FrameResult& fr : s.takeResults()) out[index[fr.motion.stamp]] = std::move(fr);
  for (int i = 0; i < static_cast<int>(r.frames.size()); ++i) {
    if (out.count(i)) continue;  // the earlier frames: read back from the cache
    FrameResult fr;
    std::string err;
    EXPECT_TRUE(s.statesAt(r.scene->frameStamp(i), &fr, &err)) << err;
    out[i] = std::move(fr);
  }
  return out;
}

// Offline: every frame (and the IMU in stamp order) first, then the items,
// then each frame's states. `image_memory_mb` bounds the images the cache
// keeps; the rest come from the image source (the rendered frames).
std::map<int, FrameResult> runOffline(const Rendered& r, const Items& items, PipelineOptions o,
                                      double image_memory_mb, int* frames_read_again, bool give_rotation = true) {
  o.planar_tracking.image_memory_mb = image_memory_mb;
  TrackingSession s(o, TrackingSession::Mode::kOffline);
  s.setCameraInfo(r.scene->intrinsics());
  s.setKeepImages(true);
  std::map<double, int> index;
  for (int i = 0; i < static_cast<int>(r.frames.size()); ++i) index[r.scene->frameStamp(i)] = i;
  *frames_read_again = 0;
  s.setImageSource([&](double stamp) {
    ++*frames_read_again;
    return r.frames[index.at(stamp)];
  });
  if (give_rotation) {
    EXPECT_TRUE(s.setRotationCamImu(r.scene->options().q_cam_imu));
  }
  size_t next_imu = 0;
  for (int i = 0; i < static_cast<int>(r.frames.size()); ++i) {
    const double t = r.scene->frameStamp(i);
    while (next_imu < r.imu.size() && r.imu[next_imu].stamp <= t) s.addImu(r.imu[next_imu++]);
    s.analyze(r.frames[i], t);
  }
  while (next_imu < r.imu.size()) s.addImu(r.imu[next_imu++]);
  s.advance(true);
  EXPECT_TRUE(s.takeResults().empty());  // offline, results are read with statesAt()
  addItems(s, r, items);
  std::map<int, FrameResult> out;
  for (int i = 0; i < static_cast<int>(r.frames.size()); ++i) {
    std::string err;
    EXPECT_TRUE(s.statesAt(r.scene->frameStamp(i), &out[i], &err)) << err;
  }
  return out;
}

double worstDifference(const std::map<int, FrameResult>& a, const std::map<int, FrameResult>& b, int* at);

// The live run against the offline one (full image budget): the worst
// difference, printed with `name`.
double liveVsOffline(const char* name, const Rendered& r, const Items& items, const PipelineOptions& o,
                     std::map<int, FrameResult>* offline = nullptr) {
  const auto live = runLive(r, items, o);
  int reread = 0, at = -1;
  const auto off = runOffline(r, items, o, 512, &reread);
  EXPECT_EQ(live.size(), r.frames.size());
  EXPECT_EQ(reread, 0);  // everything fits the budget
  const double d = worstDifference(live, off, &at);
  std::printf("%s: live vs offline worst %.3g px (frame %d)\n", name, d, at);
  if (offline) *offline = off;
  return d;
}

double worstDifference(const std::map<int, FrameResult>& a, const std::map<int, FrameResult>& b, int* at) {
  double worst = 0;
  for (const auto& [i, fa] : a) {
    const auto it = b.find(i);
    const double d = it == b.end() ? INFINITY : difference(fa, it->second);
    if (d > worst) worst = d, *at = i;
  }
  return worst;
}

// An image target given at the newest frame live (frame 30) and at that
// frame's stamp offline: searched on threads of their own, answered at
// fixed frames, so the two agree exactly, not_found before the find
// included.
TEST(TrackingSession, LiveAndOfflineAgreeOnImageTargets) {
  const std::string png = ::testing::TempDir() + "/imt_session_poster.png";
  const cv::Mat picture = proceduralTexture(1024, 7)(cv::Rect(0, 0, 1024, 768)).clone();
  ASSERT_TRUE(cv::imwrite(png, picture));
  const Rendered r = render("poster_orbit", 2.0, std::nullopt, png);
  ASSERT_TRUE(r.scene);
  Items items;
  items.given = items.asked = 30;
  items.picture = picture;
  items.picture_width_m = r.scene->frameTruth(0).targets.at(0).width_m;
  items.picture_height_m = r.scene->frameTruth(0).targets.at(0).height_m;
  std::map<int, FrameResult> offline;
  EXPECT_EQ(liveVsOffline("poster_orbit, image target", r, items, PipelineOptions(), &offline), 0.0);
  int not_found = 0, tracked = 0;
  double worst_rms = 0;
  for (const auto& [i, fr] : offline) {
    if (i < items.given) continue;
    ASSERT_EQ(fr.targets.size(), 1u);
    not_found += fr.targets[0].status == TargetStatus::kNotFound;
    tracked += fr.targets[0].status == TargetStatus::kTracked;
    if (fr.targets[0].status == TargetStatus::kTracked)
      worst_rms = std::max(worst_rms, test::cornerRms(fr.targets[0].corners, r.scene->frameTruth(i).targets.at(0).corners));
  }
  std::printf("poster_orbit, image target: %d frames tracked, corner RMS at worst %.3f px\n", tracked, worst_rms);
  // Not merely the same live and offline, but right: measured 0.017 px at
  // worst (a rendered poster, found and aligned to a fraction of a pixel);
  // 1 px, between the planar tests' bars for the median and the 95th
  // percentile (0.5 and 1.5 px).
  EXPECT_LT(worst_rms, 1.0);
  // Found by the first search: its answer comes detect_interval frames on.
  EXPECT_EQ(not_found, PlanarTargetOptions().detect_interval);
  EXPECT_EQ(tracked + not_found, r.scene->frameCount() - items.given);
  std::remove(png.c_str());
}

// A target given by its corners that the camera loses while blind (frames
// 50-79 flat gray while it moves on) and finds again by its look at
// placement: the searches run on threads of their own and are answered at
// fixed frames, so live and offline agree exactly, found again included.
TEST(TrackingSession, LiveAndOfflineAgreeOnATargetFoundAgain) {
  Rendered r = render("poster_orbit", 4.0);
  ASSERT_TRUE(r.scene);
  for (int i = 50; i < 80; ++i) r.frames[i].setTo(40);
  Items items;
  items.given = items.asked = 10;
  items.target = r.scene->frameTruth(items.given).targets.at(0);
  std::map<int, FrameResult> offline;
  EXPECT_LT(liveVsOffline("poster_orbit blind 1 s, corner target", r, items, PipelineOptions(), &offline),
            1e-9);
  // The poster moved far while the camera was blind ...
  double jump = 0;
  for (int k = 0; k < 4; ++k)
    jump = std::max(jump, cv::norm(r.scene->frameTruth(80).targets.at(0).corners[k] -
                                   r.scene->frameTruth(49).targets.at(0).corners[k]));
  EXPECT_GT(jump, 30) << "the scene should move the poster while blind";
  // ... it is in doubt when the view is back (predicted: the features in the
  // stale quad are not confirmed by its look) ...
  int in_doubt = 0;
  for (int i = 80; i < 90; ++i) in_doubt += offline[i].targets.at(0).status != TargetStatus::kTracked;
  EXPECT_GT(in_doubt, 0);
  // ... and found again: the last second within a pixel (measured 0.11 px;
  // 1 px is the drift-free bar).
  double worst = 0;
  for (int i = r.scene->frameCount() - 30; i < r.scene->frameCount(); ++i) {
    ASSERT_EQ(offline[i].targets.size(), 1u);
    EXPECT_EQ(offline[i].targets[0].status, TargetStatus::kTracked) << "frame " << i;
    worst = std::max(worst, test::cornerRms(offline[i].targets[0].corners,
                                            r.scene->frameTruth(i).targets.at(0).corners));
  }
  std::printf("found again: moved %.0f px while blind, %d of the 10 frames after in doubt; worst "
              "corner error over the last second %.2f px\n",
              jump, in_doubt, worst);
  EXPECT_LT(worst, 1.0);
}

// poster_orbit: a planar target and a region on the poster, given at frame
// 10 once frame 40 is in; the offline image budget holds a few frames only.
TEST(TrackingSession, LiveAndOfflineAgreeOnRegionsAndPlanarTargets) {
  const Rendered r = render("poster_orbit", 2.0);
  ASSERT_TRUE(r.scene);
  Items items;
  items.given = 10;
  items.asked = 40;
  const FrameTruth truth = r.scene->frameTruth(items.given);
  ASSERT_FALSE(truth.targets.empty());
  items.target = truth.targets[0];
  const auto& c = truth.targets[0].corners;
  items.region = cv::Rect2d(c[0], c[2]);
  const PipelineOptions o;
  std::map<int, FrameResult> offline;
  // The same code on the same frames in a different order of calls: equal
  // up to nothing (the arithmetic is the same); 1e-9 px leaves room for none
  // but the last bit.
  EXPECT_LT(liveVsOffline("poster_orbit", r, items, o, &offline), 1e-9);
  // A frame the cache dropped is read again: the alignment sees every frame.
  int reread_few = 0, at_few = -1;
  const auto offline_few = runOffline(r, items, o, 1.0, &reread_few);  // ~3 frames of 640x480
  const double d_few = worstDifference(offline_few, offline, &at_few);
  std::printf("poster_orbit: 1 MB image budget vs 512 MB %.3g px, %d frames read again\n", d_few, reread_few);
  EXPECT_LT(d_few, 1e-9) << "frame " << at_few;
  EXPECT_GT(reread_few, 50);
  // And the planar target is tracked (not merely equally wrong): the corner
  // error at the last frame is small (poster_orbit's bar elsewhere is 1 px).
  const FrameTruth last = r.scene->frameTruth(static_cast<int>(r.frames.size()) - 1);
  ASSERT_EQ(offline.rbegin()->second.targets.size(), 1u);
  double err = 0;
  for (int k = 0; k < 4; ++k)
    err = std::max(err, cv::norm(offline.rbegin()->second.targets[0].corners[k] - last.targets[0].corners[k]));
  EXPECT_LT(err, 1.0);
}

// floor_walk: an anchor (with the IMU) and a region given at frame 20 once
// frame 45 is in, the IMU late on every third frame live.
TEST(TrackingSession, LiveAndOfflineAgreeOnAnchors) {
  const Rendered r = render("floor_walk", 3.0);
  ASSERT_TRUE(r.scene);
  Items items;
  items.given = 20;
  items.asked = 45;
  const FrameTruth truth = r.scene->frameTruth(items.given);
  ASSERT_FALSE(truth.anchors.empty());
  ASSERT_TRUE(truth.anchors[0].in_view);
  items.anchor = truth.anchors[0];
  items.region = cv::Rect2d(truth.anchors[0].pixel - cv::Point2d(40, 30), cv::Size2d(80, 60));
  std::map<int, FrameResult> offline;
  EXPECT_LT(liveVsOffline("floor_walk", r, items, PipelineOptions(), &offline), 1e-9);  // as above
  // The anchor is tracked with the IMU: its status is tracked where in view.
  int tracked = 0, in_view = 0;
  double worst_px = 0;
  for (const auto& [i, fr] : offline) {
    tracked += fr.anchors.size() == 1 && fr.anchors[0].status == AnchorStatus::kTracked;
    const FrameTruth t = r.scene->frameTruth(i);
    if (i < items.given || t.anchors.empty() || !t.anchors[0].in_view || fr.anchors.size() != 1) continue;
    ++in_view;
    EXPECT_EQ(fr.anchors[0].status, AnchorStatus::kTracked) << "frame " << i;
    worst_px = std::max(worst_px, cv::norm(fr.anchors[0].pixel - t.anchors[0].pixel));
  }
  std::printf("floor_walk: anchor tracked on %d frames, in view on %d from its frame on; pixel error at worst %.2f px\n",
              tracked, in_view, worst_px);
  EXPECT_GT(tracked, static_cast<int>(r.frames.size()) / 2);
  EXPECT_GT(in_view, 0);
  // Not merely the same live and offline, but right: measured 0.54 px at
  // worst over these first 2.3 s; the anchors' own bar is a median of 3 px in
  // view (test_anchor_manager.cpp), here held at every frame.
  EXPECT_LT(worst_px, 3.0);

  // The same without the IMU-to-camera rotation (no tf): the session finds
  // it from the video, and the frames before it was found are `calibrating`
  // in both (a rotation applies from the frame whose turn completed it on,
  // not to every frame the offline run reads back later).
  const auto live = runLive(r, items, PipelineOptions(), false);
  int reread = 0, at = -1;
  const auto found = runOffline(r, items, PipelineOptions(), 512, &reread, false);
  const double d = worstDifference(live, found, &at);
  int calibrating = 0;
  tracked = 0;
  for (const auto& [i, fr] : found) {
    if (fr.anchors.size() != 1) continue;
    calibrating += fr.anchors[0].status == AnchorStatus::kCalibrating;
    tracked += fr.anchors[0].status == AnchorStatus::kTracked;
  }
  std::printf("floor_walk without tf: live vs offline worst %.3g (frame %d); %d frames calibrating, %d tracked\n", d,
              at, calibrating, tracked);
  EXPECT_LT(d, 1e-9);  // as above
  EXPECT_GT(calibrating, 0);  // found after the anchor's frame, not before
  EXPECT_GT(tracked, static_cast<int>(r.frames.size()) / 2);
}

// A live session over `r`'s frames with the IMU driver 0.05 s late and an
// anchor given at frame `given`, so that frames wait for their IMU:
// `give(i, t)` hands frame i to `s`, `then(i, t)` runs after it (with
// s.takeResults() taken after both). Returns every result, in order. False
// `anchored`: the anchor was refused (a failure of the test's own).
std::vector<FrameResult> withLateImu(TrackingSession& s, const Rendered& r, int given,
                                     const std::function<void(int, double)>& give,
                                     const std::function<void(int, double)>& then, bool* anchored) {
  s.setCameraInfo(r.scene->intrinsics());
  *anchored = s.setRotationCamImu(r.scene->options().q_cam_imu);
  std::vector<FrameResult> results;
  size_t next_imu = 0;
  for (int i = 0; i < static_cast<int>(r.frames.size()); ++i) {
    const double t = r.scene->frameStamp(i);
    while (next_imu < r.imu.size() && r.imu[next_imu].stamp <= t - 0.05) s.addImu(r.imu[next_imu++]);
    give(i, t);
    if (i == given) {
      const FrameTruth truth = r.scene->frameTruth(given);
      uint32_t id;
      std::string err;
      *anchored = *anchored && !truth.anchors.empty() && s.addAnchor(1, t, truth.anchors[0].pixel, 0, &id, &err);
    }
    then(i, t);
    for (FrameResult& fr : s.takeResults()) results.push_back(std::move(fr));
  }
  while (next_imu < r.imu.size()) s.addImu(r.imu[next_imu++]);
  s.advance(true);
  for (FrameResult& fr : s.takeResults()) results.push_back(std::move(fr));
  return results;
}

// Requests given "now" (stamp 0) while frames wait for their IMU (the
// driver 0.05 s late): they go to the newest frame already through the
// trackers, and the waiting frames keep waiting, so every frame's anchor
// has the IMU. Forcing the waiting frames through (as a refused add_anchor
// once did) gave them status no_imu (rostest anchor_nodelet, frame 20).
TEST(TrackingSession, RequestsForNowLeaveFramesWaitingForTheImu) {
  const Rendered r = render("floor_walk", 1.5);
  ASSERT_TRUE(r.scene);
  TrackingSession s(PipelineOptions(), TrackingSession::Mode::kLive);
  const int given = 10;
  bool anchored = false;
  const std::vector<FrameResult> results = withLateImu(
      s, r, given, [&](int i, double t) { s.analyze(r.frames[i], t); },
      [&](int i, double) {
        if (i <= given) return;
        // Refused and accepted requests for "now" alike.
        uint32_t id;
        std::string err;
        EXPECT_FALSE(s.addAnchor(1, 0, cv::Point2d(100, 100), 0, &id, &err));
        EXPECT_TRUE(s.addRegion(0, 0, cv::Rect2d(100, 100, 60, 50), &id, &err)) << err;
        EXPECT_TRUE(s.removeRegion(id, &err)) << err;
      },
      &anchored);
  ASSERT_TRUE(anchored);
  ASSERT_EQ(results.size(), r.frames.size());  // every frame once, in order
  int with_anchor = 0;
  for (const FrameResult& fr : results) {
    if (fr.anchors.empty()) continue;
    ++with_anchor;
    EXPECT_NE(fr.anchors[0].status, AnchorStatus::kNoImu) << "frame at " << fr.motion.stamp;
  }
  EXPECT_GT(with_anchor, 30);
}

// A caller that reuses one buffer for every frame (a capture loop) while
// frames wait for their IMU (an anchor, the driver 0.05 s late): each frame
// the trackers keep, and each result's frame, is the frame as it was given,
// not what the caller wrote into its buffer after (the regions' look would
// read a later frame, and say nothing).
TEST(TrackingSession, FramesWaitingForTheImuAreKeptAsGiven) {
  const Rendered r = render("floor_walk", 1.0);
  ASSERT_TRUE(r.scene);
  TrackingSession s(PipelineOptions(), TrackingSession::Mode::kLive);
  cv::Mat buffer;  // the caller's one buffer
  int waited = 0;
  bool anchored = false;
  const std::vector<FrameResult> results = withLateImu(
      s, r, 5,
      [&](int i, double t) {
        r.frames[i].copyTo(buffer);
        s.analyze(buffer, t);
      },
      [&](int, double t) { waited += s.cache().empty() || s.cache().newestStamp() < t; }, &anchored);
  ASSERT_TRUE(anchored);
  EXPECT_GT(waited, 10);  // else this tests nothing
  // The results' frames (the overlays'), every one taken after the caller
  // wrote the next frames into its buffer.
  ASSERT_EQ(results.size(), r.frames.size());
  for (size_t i = 0; i < results.size(); ++i)
    EXPECT_EQ(cv::norm(results[i].gray, r.frames[i], cv::NORM_INF), 0.0) << "result " << i;
  const MotionCache& cache = s.cache();
  ASSERT_EQ(cache.size(), r.frames.size());
  for (uint64_t q = cache.firstSeq(); q <= cache.lastSeq(); ++q) {
    const int i = static_cast<int>(q - cache.firstSeq());
    const cv::Mat kept = cache.image(q);
    ASSERT_FALSE(kept.empty()) << "frame " << i;
    EXPECT_EQ(cv::norm(kept, r.frames[i], cv::NORM_INF), 0.0) << "frame " << i << " kept as the caller's buffer became";
  }
}

// The cards scene of the live-vs-offline rostest (seed 2, 4 s): a card as a
// region, the static patch as a planar target and an anchor at its centre,
// given at frame 30 once frame 60 is in.
TEST(TrackingSession, LiveAndOfflineAgreeOnCards) {
  const Rendered r = render("cards", 4.0, 2);
  ASSERT_TRUE(r.scene);
  Items items;
  items.given = 30;
  items.asked = 60;
  const FrameTruth truth = r.scene->frameTruth(items.given);
  ASSERT_GE(truth.regions.size(), 4u);
  items.region = truth.regions[1].box;
  const cv::Rect2d patch = truth.regions[3].box;
  FrameTruth::Target t;
  t.corners = {patch.tl(), cv::Point2d(patch.br().x, patch.y), patch.br(), cv::Point2d(patch.x, patch.br().y)};
  t.width_m = 0.5;
  t.height_m = 0.4;
  items.target = t;
  FrameTruth::Anchor a;
  a.pixel = (patch.tl() + patch.br()) * 0.5;
  a.T_cam_anchor = Eigen::Isometry3d::Identity();
  a.T_cam_anchor.translation() = Eigen::Vector3d(0, 0, 1);
  items.anchor = a;
  // With a fixed gyro bias the anchors agree exactly too.
  PipelineOptions po;
  po.imu.estimate_gyro_bias = false;
  EXPECT_LT(liveVsOffline("cards, fixed gyro bias", r, items, po), 1e-9);  // as above
  int reread = 0, at = -1;
  double d;
  // With the bias estimated (the default), the IMU orientation integrates a
  // still stretch again once it is confirmed (ImuOrientation::reintegrateFrom):
  // a live frame answered before the confirmation keeps the orientation it
  // had, offline sees the corrected one. Regions and planar targets do not
  // use it and stay exact; anchors move by a hair: measured 0.0043 px; 0.02
  // px bounds that and fails on any real divergence (a pixel or more).
  po = PipelineOptions();
  auto live = runLive(r, items, po);
  const auto offline = runOffline(r, items, po, 512, &reread);
  d = worstDifference(live, offline, &at);
  std::printf("cards, estimated gyro bias: live vs offline worst %.3g px (frame %d)\n", d, at);
  EXPECT_LT(d, 0.02) << "frame " << at;
  for (auto& [i, fr] : live) fr.anchors.clear();
  std::map<int, FrameResult> offline_no_anchors = offline;
  for (auto& [i, fr] : offline_no_anchors) fr.anchors.clear();
  d = worstDifference(live, offline_no_anchors, &at);
  EXPECT_LT(d, 1e-9) << "regions and planar targets, frame " << at;
}

// Beyond appearance_budget (8) the regions take turns at their look, and
// with many regions' own corners each frame's pyramid is shared: what a
// region's step does depends on the others. Through the regions given at or
// before the frame stepped into only, so the order of the adds and steps
// (live: each add at once; offline: every add after the whole stream) does
// not matter.
// And the regions stepping into the same frame step side by side on
// OpenCV's threads (RegionManager::stepBatch): here three, more than this 2-core
// machine has, so the regions split unevenly and the threads interleave.
// Each step reads only its own region and what the frame shares, so the
// states are those of one step after another (one thread) to the bit.
TEST(TrackingSession, LiveAndOfflineAgreeOnManyRegions) {
  const Rendered r = render("cards", 3.0, 2);
  ASSERT_TRUE(r.scene);
  // The card's region (given at frame 10) and 24 boxes on the wall about it.
  Items items;
  items.given = 10;
  items.asked = 40;
  items.region = r.scene->frameTruth(items.given).regions[1].box;
  for (int i = 0; i < 24; ++i) items.more_regions.push_back(cv::Rect2d(20 + (i % 6) * 100, 30 + (i / 6) * 110, 60, 50));
  std::map<int, FrameResult> offline, one_thread;
  {
    const test::OpenCvThreads threads(3);
    EXPECT_LT(liveVsOffline("cards, 25 regions", r, items, PipelineOptions(), &offline), 1e-9);  // as above
  }
  {
    const test::OpenCvThreads threads(1);
    int reread = 0;
    one_thread = runOffline(r, items, PipelineOptions(), 512, &reread);
  }
  int at = -1;
  EXPECT_EQ(worstDifference(offline, one_thread, &at), 0.0) << "three threads against one, frame " << at;
  // And the card's region is tracked among them (not merely equally wrong),
  // over the frames where the card is at least half in view: measured 0.962
  // mean IoU; 0.85 is the bar.
  double sum = 0;
  int n = 0;
  for (const auto& [i, fr] : offline) {
    const FrameTruth t = r.scene->frameTruth(i);
    if (t.regions[1].visible_fraction < 0.5) continue;
    for (const RegionState& s : fr.regions)
      if (s.id == 3) sum += test::iouClipped(s.extent(), t.regions[1].box, r.frames[0].size()), ++n;
  }
  ASSERT_GT(n, 0);
  const double iou = sum / n;
  std::printf("cards, 25 regions: the card's region mean IoU %.3f\n", iou);
  EXPECT_GT(iou, 0.85);
}

// Invalid options are refused at construction with validate()'s message
// (every module the same way), never replaced by defaults.
TEST(TrackingSession, InvalidOptionsAreRefusedAtConstruction) {
  PipelineOptions o;
  o.region_tracking.irls_iterations = 0;
  try {
    TrackingSession s(o, TrackingSession::Mode::kLive);
    FAIL() << "constructed with invalid options";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("region_tracking.irls_iterations"), std::string::npos) << e.what();
  }
  o = PipelineOptions();
  o.anchors.region_size = 5;
  EXPECT_THROW(AnchorManager(o.anchors, o.imu, 60, nullptr), std::invalid_argument);
  o = PipelineOptions();
  o.motion_analysis.max_features = -1;
  EXPECT_THROW(MotionAnalyzer{o.motion_analysis}, std::invalid_argument);
  o = PipelineOptions();
  o.planar_tracking.min_points = -1;
  EXPECT_THROW((PlanarTargetManager{o.planar_tracking, nullptr}), std::invalid_argument);
}

TEST(TrackingSession, ItemsAreRefusedWithAMessage) {
  TrackingSession s(PipelineOptions(), TrackingSession::Mode::kLive);
  uint32_t id;
  std::string err;
  EXPECT_FALSE(s.addRegion(1, 0, cv::Rect2d(0, 0, 10, 10), &id, &err));  // no frame yet
  EXPECT_FALSE(err.empty());
  s.analyze(cv::Mat(240, 320, CV_8UC1, cv::Scalar(128)), 1.0);
  err.clear();
  EXPECT_FALSE(s.addRegion(AnchorManager::kAnchorRegionBase, 0, cv::Rect2d(0, 0, 10, 10), &id, &err));
  EXPECT_NE(err.find("reserved"), std::string::npos) << err;
  EXPECT_TRUE(s.addRegion(0, 0, cv::Rect2d(10, 10, 50, 50), &id, &err)) << err;
  ASSERT_TRUE(s.addAnchor(0, 0, cv::Point2d(160, 120), 0, &id, &err)) << err;
  EXPECT_EQ(s.regionCount(), 1u);  // the anchor's own region is not the user's
  EXPECT_EQ(s.anchorCount(), 1u);
  std::vector<RegionState> states;
  ASSERT_TRUE(s.seekRegions(0, {}, &states, &err)) << err;
  EXPECT_EQ(states.size(), 1u);
  EXPECT_FALSE(s.removeRegion(AnchorManager::kAnchorRegionBase, &err));
  // Items beyond what can be tracked (issue 16: these were accepted and
  // carried into the output): sizes, depths, places.
  for (const cv::Rect2d& box : {cv::Rect2d(0, 0, 1e300, 1e300), cv::Rect2d(10, 10, 1e-6, 1e-6),
                                cv::Rect2d(10, 10, 1.5, 40), cv::Rect2d(0, 0, 320 * 5, 50)}) {
    err.clear();
    EXPECT_FALSE(s.addRegion(0, 0, box, &id, &err)) << box;
    EXPECT_NE(err.find("box size"), std::string::npos) << err;
  }
  for (const double depth : {3e38, 1e-30, 2e4}) {
    err.clear();
    EXPECT_FALSE(s.addAnchor(0, 0, cv::Point2d(160, 120), depth, &id, &err)) << depth;
    EXPECT_NE(err.find("depth must be"), std::string::npos) << err;
  }
  err.clear();
  const std::array<cv::Point2d, 4> far = {cv::Point2d(1e6, 1e6), cv::Point2d(1e6 + 100, 1e6),
                                          cv::Point2d(1e6 + 100, 1e6 + 100), cv::Point2d(1e6, 1e6 + 100)};
  EXPECT_FALSE(s.addPlanarTarget(0, 0, far, 0.2, 0.2, &id, &err));
  EXPECT_NE(err.find("outside the 320x240 image"), std::string::npos) << err;
  EXPECT_EQ(s.regionCount(), 1u);
  // Time going back (by time_jump_reset_seconds or more) clears the items,
  // and the result says why.
  s.analyze(cv::Mat(240, 320, CV_8UC1, cv::Scalar(128)), 0.0);
  const auto results = s.takeResults();
  ASSERT_FALSE(results.empty());
  EXPECT_FALSE(results.back().reset.empty());
  EXPECT_EQ(s.regionCount(), 0u);
  EXPECT_EQ(s.anchorCount(), 0u);
}

// region_tracking.max_regions caps the regions (an INIT.yaml with 177k of
// them took 64 s and 2.6 GB for 45 frames).
TEST(TrackingSession, RegionsBeyondMaxRegionsAreRefused) {
  PipelineOptions o;
  o.region_tracking.max_regions = 3;
  TrackingSession s(o, TrackingSession::Mode::kLive);
  s.analyze(cv::Mat(240, 320, CV_8UC1, cv::Scalar(128)), 1.0);
  uint32_t id;
  std::string err;
  for (int i = 0; i < 3; ++i) EXPECT_TRUE(s.addRegion(0, 0, cv::Rect2d(10 + 20 * i, 10, 15, 15), &id, &err)) << err;
  EXPECT_FALSE(s.addRegion(0, 0, cv::Rect2d(100, 10, 15, 15), &id, &err));
  EXPECT_NE(err.find("max_regions"), std::string::npos) << err;
  EXPECT_EQ(s.regionCount(), 3u);
}

// anchors.max_anchors caps the anchors the same way, apart from the regions
// (each anchor's own region is not one of max_regions).
TEST(TrackingSession, AnchorsBeyondMaxAnchorsAreRefused) {
  PipelineOptions o;
  o.anchors.max_anchors = 2;
  o.region_tracking.max_regions = 1;
  TrackingSession s(o, TrackingSession::Mode::kLive);
  s.analyze(cv::Mat(240, 320, CV_8UC1, cv::Scalar(128)), 1.0);
  uint32_t id;
  std::string err;
  EXPECT_TRUE(s.addRegion(0, 0, cv::Rect2d(10, 10, 15, 15), &id, &err)) << err;
  for (int i = 0; i < 2; ++i) EXPECT_TRUE(s.addAnchor(0, 0, cv::Point2d(100 + 40 * i, 120), 0, &id, &err)) << err;
  EXPECT_FALSE(s.addAnchor(0, 0, cv::Point2d(200, 120), 0, &id, &err));
  EXPECT_NE(err.find("anchors.max_anchors"), std::string::npos) << err;
  EXPECT_EQ(s.anchorCount(), 2u);
  o.anchors.max_anchors = 0;
  EXPECT_THROW(TrackingSession(o, TrackingSession::Mode::kLive), std::invalid_argument);
}

// planar_tracking.max_targets caps the planar targets (each costs
// milliseconds per frame), apart from the regions.
TEST(TrackingSession, PlanarTargetsBeyondMaxTargetsAreRefused) {
  PipelineOptions o;
  o.planar_tracking.max_targets = 2;
  o.region_tracking.max_regions = 1;
  TrackingSession s(o, TrackingSession::Mode::kLive);
  cv::Mat texture(240, 320, CV_8UC1);
  cv::randu(texture, 0, 255);
  s.analyze(texture, 1.0);
  uint32_t id;
  std::string err;
  EXPECT_TRUE(s.addRegion(0, 0, cv::Rect2d(10, 10, 15, 15), &id, &err)) << err;
  auto quad = [](double x) {
    return std::array<cv::Point2d, 4>{cv::Point2d(x, 60), cv::Point2d(x + 80, 60), cv::Point2d(x + 80, 140),
                                      cv::Point2d(x, 140)};
  };
  for (int i = 0; i < 2; ++i) EXPECT_TRUE(s.addPlanarTarget(0, 0, quad(20 + 90 * i), 0.2, 0.2, &id, &err)) << err;
  EXPECT_FALSE(s.addPlanarTarget(0, 0, quad(210), 0.2, 0.2, &id, &err));
  EXPECT_NE(err.find("planar_tracking.max_targets"), std::string::npos) << err;
  EXPECT_EQ(s.planarTargetCount(), 2u);
  o.planar_tracking.max_targets = 0;
  EXPECT_THROW(TrackingSession(o, TrackingSession::Mode::kLive), std::invalid_argument);
}

}  // namespace
}  // namespace imt

namespace imt {
namespace {

// Issue 16's time rules. Before them, a bag with every second image stamp
// repeated gave 15 full resets in 45 frames, each wiping every region.
// cards (no IMU needed): a region on card 1, given at frame 0, live.
// Repeated and slightly late stamps are dropped, a jump back resets, a jump
// forward beyond the cache is a gap (counted, tracked across).
TEST(TrackingSession, RepeatedAndSlightlyLateStampsAreDroppedNotResets) {
  const Rendered r = render("cards", 2.0, 2);
  ASSERT_TRUE(r.scene);
  const FrameTruth f0 = r.scene->frameTruth(0);
  const FrameTruth::Region* card = nullptr;
  for (const auto& reg : f0.regions)
    if (reg.id == 1) card = &reg;
  ASSERT_NE(card, nullptr);
  // `extra(k)`: stamps fed after frame k's own (each a copy of frame k's image).
  size_t gaps = 0;
  auto run = [&](const std::function<std::vector<double>(int, double)>& extra, int* resets, double* iou) {
    TrackingSession s(PipelineOptions(), TrackingSession::Mode::kLive);
    std::string err;
    uint32_t id = 0;
    *resets = 0;
    double sum = 0;
    int n = 0;
    for (int k = 0; k < static_cast<int>(r.frames.size()); ++k) {
      const double t = r.scene->frameStamp(k);
      std::vector<double> stamps = {t};
      for (double e : extra(k, t)) stamps.push_back(e);
      for (double stamp : stamps) {
        s.analyze(r.frames[k], stamp);
        s.advance(true);
        for (const FrameResult& fr : s.takeResults()) {
          *resets += !fr.reset.empty();
          for (const RegionState& st : fr.regions) {
            if (st.id != id || fr.motion.stamp != t) continue;
            for (const auto& reg : r.scene->frameTruth(k).regions)
              if (reg.id == 1 && reg.visible_fraction > 0.5) {
                sum += st.status == RegionStatus::kLost ? 0 : test::iou(st.extent(), reg.box);
                ++n;
              }
          }
        }
      }
      if (k == 0) {
        EXPECT_TRUE(s.addRegion(0, t, card->box, &id, &err)) << err;
      }
    }
    *iou = n ? sum / n : 0;
    gaps = s.timeGaps();
    return s.timeDrops();
  };
  int resets = 0;
  double clean = 0, iou = 0;
  run([](int, double) { return std::vector<double>{}; }, &resets, &clean);
  EXPECT_EQ(resets, 0);
  // The comparisons below hold only if the card is tracked at all: measured
  // 0.769 on this short half-size render (a lost or left-behind region
  // scores under 0.4); the tracker's accuracy itself is held to the issue's
  // 0.85 elsewhere (test_region_scenes.cpp).
  EXPECT_GT(clean, 0.7);
  // Every frame's stamp given twice: the copies are dropped.
  TrackingSession::TimeDrops d = run([](int, double t) { return std::vector<double>{t}; }, &resets, &iou);
  std::printf("card 1: mean IoU %.3f; every stamp twice: %.3f, %zu dropped, %d resets\n", clean, iou, d.duplicate,
              resets);
  EXPECT_EQ(resets, 0);
  EXPECT_EQ(d.duplicate, r.frames.size());
  EXPECT_NEAR(iou, clean, 1e-9);  // the dropped copies change nothing
  // A frame 5 ms behind after every fifth: dropped too.
  d = run([](int k, double t) { return k % 5 == 4 ? std::vector<double>{t - 0.005} : std::vector<double>{}; },
          &resets, &iou);
  EXPECT_EQ(resets, 0);
  EXPECT_EQ(d.behind, r.frames.size() / 5);
  EXPECT_NEAR(iou, clean, 1e-9);
  // A jump back by time_jump_reset_seconds (1 s) or more is a restart.
  d = run([&](int k, double t) { return k == 40 ? std::vector<double>{t - 1.0} : std::vector<double>{}; }, &resets,
          &iou);
  EXPECT_GE(resets, 1);
  EXPECT_EQ(d.behind + d.duplicate, 0u);
  EXPECT_EQ(gaps, 0u);
  // A jump forward beyond the cache (cache_seconds, 10 s) from frame 40 on:
  // a gap, counted and tracked across, not a reset.
  int gap_resets = 0;
  double gap_iou = 0;
  TrackingSession s(PipelineOptions(), TrackingSession::Mode::kLive);
  uint32_t id = 0;
  std::string err;
  double sum = 0;
  int n = 0;
  for (int k = 0; k < static_cast<int>(r.frames.size()); ++k) {
    const double t = r.scene->frameStamp(k) + (k >= 40 ? 12.0 : 0.0);
    s.analyze(r.frames[k], t);
    if (k == 40) {
      EXPECT_NE(s.lastGap().find("a gap, tracked across"), std::string::npos) << s.lastGap();
    } else {
      EXPECT_EQ(s.lastGap(), "") << k;
    }
    s.advance(true);
    for (const FrameResult& fr : s.takeResults()) {
      gap_resets += !fr.reset.empty();
      for (const RegionState& st : fr.regions)
        for (const auto& reg : r.scene->frameTruth(k).regions)
          if (st.id == id && reg.id == 1 && reg.visible_fraction > 0.5) {
            sum += st.status == RegionStatus::kLost ? 0 : test::iou(st.extent(), reg.box);
            ++n;
          }
    }
    if (k == 0) {
      EXPECT_TRUE(s.addRegion(0, t, card->box, &id, &err)) << err;
    }
  }
  gap_iou = n ? sum / n : 0;
  std::printf("a 12 s gap at frame 40: mean IoU %.3f (%.3f without), %zu gap(s), %d resets\n", gap_iou, clean,
              s.timeGaps(), gap_resets);
  EXPECT_EQ(s.timeGaps(), 1u);
  EXPECT_EQ(gap_resets, 0);
  // The frames on either side are consecutive images: the card is tracked
  // across as well as without the gap (its velocity is scaled by the step's
  // length, which the gap makes 360 frames long: within 0.05).
  EXPECT_NEAR(gap_iou, clean, 0.05);
  EXPECT_GT(gap_iou, 0.7);  // measured 0.777: tracked across, as above
}

}  // namespace
}  // namespace imt
