// The planar targets' ECC alignment (see planar_appearance.h): the enhanced
// correlation coefficient of findTransformECC, maximised inverse
// compositionally, so that what depends on the template alone is computed
// once per target (EccTemplate) or once per alignment (the mask's sums), and
// an iteration costs one warp of the frame and nine dot products.
#include "planar_appearance.h"

#include <Eigen/Dense>
#include <opencv2/imgproc.hpp>

#include <cmath>

namespace imt {
namespace planar_detail {
namespace {

// Normalised grid coordinates (x - cx) / s -> pixels, as a 3x3 matrix.
Eigen::Matrix3d fromNormalised(const EccTemplate& t) {
  Eigen::Matrix3d N;
  N << t.s, 0, t.cx, 0, t.s, t.cy, 0, 0, 1;
  return N;
}

// The warp's parameters (normalised grid coordinates) as a matrix:
// [[1 + p0, p1, p2], [p3, 1 + p4, p5], [p6, p7, 1]] (p6, p7 = 0: affine).
Eigen::Matrix3d paramWarp(const Eigen::VectorXd& p) {
  Eigen::Matrix3d W = Eigen::Matrix3d::Identity();
  W(0, 0) += p(0);
  W(0, 1) = p(1);
  W(0, 2) = p(2);
  W(1, 0) = p(3);
  W(1, 1) += p(4);
  W(1, 2) = p(5);
  if (p.size() == 8) {
    W(2, 0) = p(6);
    W(2, 1) = p(7);
  }
  return W;
}

// The pixels of `mask` (255 where the template counts) that count, as
// findTransformECC erodes its mask by the smoothing's reach: those 95% of
// whose 5x5 Gaussian neighbourhood is in `mask` (and so their 3x3
// neighbourhood wholly), but not on the grid's border (255 / 0).
cv::Mat smoothedMask(const cv::Mat& mask) {
  cv::Mat f, out;
  mask.convertTo(f, CV_32F, 1.0 / 255);
  cv::GaussianBlur(f, f, cv::Size(5, 5), 0, 0);
  cv::compare(f, 0.95, out, cv::CMP_GT);
  cv::rectangle(out, cv::Rect(0, 0, out.cols, out.rows), cv::Scalar(0));  // 1 px wide
  return out;
}

// Everything of one alignment that depends on the template and the mask
// only: the steepest-descent images (masked: zero outside), the masked
// template, their zero-mean inner products, and what the update solves with
// them alone (the Hessian's factors, H^-1 b and the template's residual).
struct MaskedTemplate {
  std::vector<cv::Mat> sd;  // d template / d p_k, times the mask
  cv::Mat tpl;              // smoothed template times the mask
  double n = 0;             // pixels in the mask
  Eigen::MatrixXd H;        // zero-mean sd^T sd
  Eigen::VectorXd b;        // zero-mean sd^T tpl
  double tt = 0;            // zero-mean |tpl|^2
  Eigen::LDLT<Eigen::MatrixXd> H_ldlt;
  Eigen::VectorXd Hb;       // H^-1 b
  double lambda_n = 0;      // tt - b^T H^-1 b

  MaskedTemplate(const EccTemplate& t, const cv::Mat& mask, int params) {
    n = cv::countNonZero(mask);
    cv::Mat mf;
    mask.convertTo(mf, CV_32F, 1.0 / 255);
    cv::Mat gx, gy;
    cv::multiply(t.gx, mf, gx, t.s);  // d/dx of the normalised coordinate
    cv::multiply(t.gy, mf, gy, t.s);
    sd.resize(params);
    sd[0] = gx.mul(t.xn);
    sd[1] = gx.mul(t.yn);
    sd[2] = gx;
    sd[3] = gy.mul(t.xn);
    sd[4] = gy.mul(t.yn);
    sd[5] = gy;
    if (params == 8) {
      const cv::Mat r = sd[0] + sd[4];
      sd[6] = -r.mul(t.xn);
      sd[7] = -r.mul(t.yn);
    }
    cv::multiply(t.smoothed, mf, tpl);
    Eigen::VectorXd mean(params);
    for (int k = 0; k < params; ++k) mean(k) = cv::sum(sd[k])[0] / n;
    const double mean_t = cv::sum(tpl)[0] / n;
    H.resize(params, params);
    b.resize(params);
    for (int j = 0; j < params; ++j) {
      for (int k = j; k < params; ++k) H(j, k) = H(k, j) = sd[j].dot(sd[k]) - n * mean(j) * mean(k);
      b(j) = sd[j].dot(tpl) - n * mean(j) * mean_t;
    }
    tt = tpl.dot(tpl) - n * mean_t * mean_t;
    H_ldlt.compute(H);
    Hb = H_ldlt.solve(b);
    lambda_n = tt - b.dot(Hb);
  }
};

}  // namespace

EccTemplate EccTemplate::from(const cv::Mat& tpl) {
  EccTemplate t;
  cv::GaussianBlur(tpl, t.smoothed, cv::Size(5, 5), 0, 0);
  const cv::Matx13f dx(-0.5f, 0.0f, 0.5f);
  cv::filter2D(t.smoothed, t.gx, -1, dx);
  cv::filter2D(t.smoothed, t.gy, -1, dx.t());
  t.cx = 0.5 * (tpl.cols - 1);
  t.cy = 0.5 * (tpl.rows - 1);
  t.s = 0.5 * std::max(tpl.cols, tpl.rows);
  t.xn.create(tpl.size(), CV_32F);
  t.yn.create(tpl.size(), CV_32F);
  for (int r = 0; r < tpl.rows; ++r) {
    float* px = t.xn.ptr<float>(r);
    float* py = t.yn.ptr<float>(r);
    for (int c = 0; c < tpl.cols; ++c) {
      px[c] = static_cast<float>((c - t.cx) / t.s);
      py[c] = static_cast<float>((r - t.cy) / t.s);
    }
  }
  return t;
}

bool alignEcc(const EccTemplate& t, const cv::Mat& image, const cv::Mat& image_valid, const cv::Mat& mask,
              bool affine, const cv::TermCriteria& criteria, Eigen::Matrix3d* warp, double* rho_out) {
  const int params = affine ? 6 : 8;
  *rho_out = 0;
  cv::Mat image_s;
  cv::GaussianBlur(image, image_s, cv::Size(5, 5), 0, 0);
  cv::Mat m = smoothedMask(mask);
  if (cv::countNonZero(m) < 2 * params) return false;
  MaskedTemplate mt(t, m, params);
  const Eigen::Matrix3d N = fromNormalised(t), N_inv = N.inverse();
  const int max_iterations = (criteria.type & cv::TermCriteria::COUNT) ? criteria.maxCount : 200;
  const double eps = (criteria.type & cv::TermCriteria::EPS) ? criteria.epsilon : -1;
  Eigen::Matrix3d W = *warp;
  double rho = -1, last_rho = -eps;
  cv::Mat warped, warped_valid, centred, outside;
  for (int i = 1; i <= max_iterations && std::abs(rho - last_rho) >= eps; ++i) {
    const cv::Matx33d Wm = toMatx(W);
    const double moved = displacementBound(Wm, t.smoothed.size());
    if (moved == 0) {
      warped = image_s;
    } else {
      if (warped.data == image_s.data) warped = cv::Mat();  // not in place
      const int flags = cv::INTER_LINEAR | cv::WARP_INVERSE_MAP;
      if (affine) {
        cv::warpAffine(image_s, warped, Wm.get_minor<2, 3>(0, 0), t.smoothed.size(), flags);
      } else {
        cv::warpPerspective(image_s, warped, Wm, t.smoothed.size(), flags);
      }
    }
    // Pixels the warp took off what the frame shows leave the mask. The
    // mask keeps pixels whose 3x3 neighbourhood is in `mask` (and so in the
    // frame): a warp moving no pixel by a whole one takes none off.
    if (moved >= 0.99) {
      cv::warpPerspective(image_valid, warped_valid, Wm, t.smoothed.size(),
                          cv::INTER_NEAREST | cv::WARP_INVERSE_MAP);
      cv::bitwise_and(m, ~warped_valid, outside);
      if (cv::countNonZero(outside) > 0) {
        cv::bitwise_and(m, warped_valid, m);
        if (cv::countNonZero(m) < 2 * params) return false;
        mt = MaskedTemplate(t, m, params);
      }
    }
    cv::Scalar mean_i, std_i;
    cv::meanStdDev(warped, mean_i, std_i, m);
    cv::subtract(warped, mean_i, centred);
    Eigen::VectorXd a(params);
    for (int k = 0; k < params; ++k) a(k) = mt.sd[k].dot(centred);
    const double c = mt.tpl.dot(centred);
    const double ii = mt.n * std_i[0] * std_i[0];
    last_rho = rho;
    rho = c / std::sqrt(ii * mt.tt);
    if (!std::isfinite(rho)) return false;
    if (mt.H_ldlt.info() != Eigen::Success) return false;
    const double lambda_d = c - a.dot(mt.Hb);
    if (!(lambda_d > 0)) return false;  // uncorrelated: the correlation would be minimised
    const Eigen::VectorXd dp = mt.H_ldlt.solve((mt.lambda_n / lambda_d) * a - mt.b);
    if (!dp.allFinite()) return false;
    // The template moved by dp matches the frame where W puts it: the frame's
    // pixel for template pixel y is W (N paramWarp(dp) N^-1)^-1 y.
    W = W * (N * paramWarp(dp) * N_inv).inverse();
    if (affine) W.row(2) << 0, 0, 1;
  }
  *warp = W / W(2, 2);
  *rho_out = rho;
  return true;
}

}  // namespace planar_detail
}  // namespace imt
