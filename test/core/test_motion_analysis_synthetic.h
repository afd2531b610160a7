// Self-contained synthetic frames for the motion-analysis tests and benchmark:
// a textured plane seen under a known per-frame homography, optionally with
// opaque textured cards moving independently on top, plus sensor noise.
// Ground truth in our pixel convention (origin at the top-left pixel corner).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <string>
#include <vector>

namespace imt {
namespace synthetic {

// Texture with detail at all scales: octaves of smooth noise plus random
// strokes and blocks (corners), deterministic in `seed`.
inline cv::Mat texture(int w, int h, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat acc(h, w, CV_32F, cv::Scalar(0));
  for (int s = 3, k = 0; s <= 96; s *= 2, ++k) {
    cv::Mat n(h / s + 3, w / s + 3, CV_32F);
    rng.fill(n, cv::RNG::NORMAL, 0, 1.0);
    cv::Mat u;
    cv::resize(n, u, cv::Size(w + 3 * s, h + 3 * s), 0, 0, cv::INTER_CUBIC);
    acc += u(cv::Rect(s, s, w, h)) * (0.6 + 0.15 * k);
  }
  cv::normalize(acc, acc, 40, 215, cv::NORM_MINMAX);
  cv::Mat out;
  acc.convertTo(out, CV_8U);
  const int strokes = w * h / 3000;
  for (int i = 0; i < strokes; ++i) {
    const cv::Point a(rng.uniform(0, w), rng.uniform(0, h));
    const int g = rng.uniform(0, 256);
    if (i % 2) {
      const cv::Point b = a + cv::Point(rng.uniform(-40, 40), rng.uniform(-40, 40));
      cv::line(out, a, b, cv::Scalar(g), rng.uniform(1, 4), cv::LINE_AA);
    } else {
      cv::rectangle(out, cv::Rect(a.x, a.y, rng.uniform(4, 24), rng.uniform(4, 24)), cv::Scalar(g),
                    cv::FILLED);
    }
  }
  cv::GaussianBlur(out, out, cv::Size(0, 0), 0.8);  // band-limit: warps stay alias-free
  return out;
}

// Shift between OpenCV's pixel-centre convention and ours.
inline Eigen::Matrix3d toOurs() {
  Eigen::Matrix3d T = Eigen::Matrix3d::Identity();
  T(0, 2) = T(1, 2) = 0.5;
  return T;
}

inline cv::Mat toCv(const Eigen::Matrix3d& H) {
  cv::Mat m(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) m.at<double>(r, c) = H(r, c);
  return m;
}

inline Eigen::Vector2d apply(const Eigen::Matrix3d& H, const Eigen::Vector2d& p) {
  const Eigen::Vector3d q = H * p.homogeneous();
  return q.hnormalized();
}

struct Frame {
  cv::Mat image;               // CV_8UC1
  Eigen::Matrix3d H_prev_cur;  // background, previous -> current (ours); identity for frame 0
  std::vector<cv::Rect2d> card_boxes;  // bounding boxes of the cards in this frame (ours)
};

// Camera motions the tests exercise (all exact homographies of a plane).
enum class Motion { kStill, kPan, kRoll, kZoom, kPerspective, kMixed };

inline const char* motionName(Motion m) {
  switch (m) {
    case Motion::kStill:
      return "still";
    case Motion::kPan:
      return "pan";
    case Motion::kRoll:
      return "roll";
    case Motion::kZoom:
      return "zoom";
    case Motion::kPerspective:
      return "perspective";
    case Motion::kMixed:
      return "mixed";
  }
  return "?";
}

// Renders `n` frames of w x h: the background texture (a plane) under camera
// motion `motion`, `cards` independently moving cards (together about 10% of
// the frame each), Gaussian noise of `noise` grey levels.
class Scene {
 public:
  Scene(Motion motion, int n, int w, int h, int cards, uint64_t seed, double noise = 2.0)
      : motion_(motion), w_(w), h_(h) {
    const int tw = 3 * w, th = 3 * h;
    bg_ = texture(tw, th, seed);
    cv::RNG rng(seed * 7 + 1);
    for (int c = 0; c < cards; ++c) card_tex_.push_back(texture(w / 3, h / 3, seed * 31 + c));
    Eigen::Matrix3d prev_bg;
    for (int i = 0; i < n; ++i) {
      // Background: texture (OpenCV coords) -> frame (OpenCV coords).
      const Eigen::Matrix3d M = cameraAt(i, tw, th);
      cv::Mat img;
      cv::warpPerspective(bg_, img, toCv(M), cv::Size(w, h), cv::INTER_LINEAR, cv::BORDER_REFLECT);
      Frame f;
      const Eigen::Matrix3d M_ours = toOurs() * M * toOurs().inverse();
      f.H_prev_cur =
          i == 0 ? Eigen::Matrix3d::Identity() : Eigen::Matrix3d(M_ours * prev_bg.inverse());
      f.H_prev_cur /= f.H_prev_cur(2, 2);
      prev_bg = M_ours;
      for (int c = 0; c < cards; ++c) {
        // Each card slides on its own Lissajous path and rotates slowly.
        const double t = i / 30.0;
        const double cx =
            w * (0.25 + 0.25 * c) + 0.12 * w * std::sin(2 * M_PI * (0.35 + 0.1 * c) * t + c);
        const double cy =
            h * (0.35 + 0.15 * (c % 2)) + 0.12 * h * std::cos(2 * M_PI * (0.25 + 0.07 * c) * t);
        const double ang = 0.15 * std::sin(2 * M_PI * 0.2 * t + c);
        const cv::Mat& tex = card_tex_[c];
        Eigen::Matrix3d C;
        C << std::cos(ang), -std::sin(ang), cx, std::sin(ang), std::cos(ang), cy, 0, 0, 1;
        Eigen::Matrix3d Tc = Eigen::Matrix3d::Identity();
        Tc(0, 2) = -0.5 * (tex.cols - 1);
        Tc(1, 2) = -0.5 * (tex.rows - 1);
        const Eigen::Matrix3d Mc = C * Tc;
        cv::Mat card, mask;
        cv::warpPerspective(tex, card, toCv(Mc), cv::Size(w, h), cv::INTER_LINEAR,
                            cv::BORDER_CONSTANT);
        cv::warpPerspective(cv::Mat(tex.size(), CV_8U, cv::Scalar(255)), mask, toCv(Mc),
                            cv::Size(w, h), cv::INTER_LINEAR, cv::BORDER_CONSTANT);
        // Alpha blend along the anti-aliased edge.
        cv::Mat a, imgf, cardf;
        mask.convertTo(a, CV_32F, 1 / 255.0);
        img.convertTo(imgf, CV_32F);
        card.convertTo(cardf, CV_32F);
        imgf = imgf.mul(1 - a) + cardf.mul(a);
        imgf.convertTo(img, CV_8U);
        double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
        for (const auto& corner :
             {Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(tex.cols - 0.5, -0.5),
              Eigen::Vector2d(tex.cols - 0.5, tex.rows - 0.5),
              Eigen::Vector2d(-0.5, tex.rows - 0.5)}) {
          const Eigen::Vector2d q = apply(Mc, corner) + Eigen::Vector2d(0.5, 0.5);
          x0 = std::min(x0, q.x()), y0 = std::min(y0, q.y()), x1 = std::max(x1, q.x()),
          y1 = std::max(y1, q.y());
        }
        f.card_boxes.emplace_back(x0, y0, x1 - x0, y1 - y0);
      }
      if (noise > 0) {
        cv::Mat nz(h, w, CV_16S);
        rng.fill(nz, cv::RNG::NORMAL, 0, noise);
        cv::Mat img16;
        img.convertTo(img16, CV_16S);
        img16 += nz;
        img16.convertTo(img, CV_8U);
      }
      f.image = img;
      frames_.push_back(std::move(f));
    }
  }

  const std::vector<Frame>& frames() const { return frames_; }

 private:
  // Texture -> frame mapping at frame i (OpenCV pixel convention).
  Eigen::Matrix3d cameraAt(int i, int tw, int th) const {
    const double t = i / 30.0;  // s at 30 fps
    double tx = 0, ty = 0, ang = 0, scale = 1, px = 0, py = 0;
    switch (motion_) {
      case Motion::kStill:
        break;
      case Motion::kPan:
        tx = -120 * t * w_ / 640.0, ty = -40 * std::sin(2 * t) * w_ / 640.0;
        break;
      case Motion::kRoll:
        ang = 0.35 * std::sin(1.5 * t);
        break;
      case Motion::kZoom:
        scale = 1.0 + 0.25 * std::sin(1.2 * t);
        break;
      case Motion::kPerspective:
        px = 0.25 * std::sin(1.3 * t) / w_, py = 0.2 * std::sin(0.9 * t + 1) / w_;
        tx = -60 * t * w_ / 640.0;
        break;
      case Motion::kMixed:
        tx = -100 * t * w_ / 640.0, ty = 30 * std::sin(1.7 * t) * w_ / 640.0;
        ang = 0.2 * std::sin(1.1 * t), scale = 1.0 + 0.15 * std::sin(0.8 * t);
        px = 0.15 * std::sin(1.3 * t) / w_;
        break;
    }
    // Centre the texture on the frame centre, apply the motion about the
    // frame centre, then the perspective terms.
    Eigen::Matrix3d Tc = Eigen::Matrix3d::Identity();
    Tc(0, 2) = -0.5 * tw;
    Tc(1, 2) = -0.5 * th;
    Eigen::Matrix3d S;
    S << scale * std::cos(ang), -scale * std::sin(ang), tx, scale * std::sin(ang),
        scale * std::cos(ang), ty, 0, 0, 1;
    Eigen::Matrix3d P = Eigen::Matrix3d::Identity();
    P(2, 0) = px;
    P(2, 1) = py;
    Eigen::Matrix3d Tf = Eigen::Matrix3d::Identity();
    Tf(0, 2) = 0.5 * w_;
    Tf(1, 2) = 0.5 * h_;
    return Tf * P * S * Tc;
  }

  Motion motion_;
  int w_, h_;
  cv::Mat bg_;
  std::vector<cv::Mat> card_tex_;
  std::vector<Frame> frames_;
};

}  // namespace synthetic
}  // namespace imt
