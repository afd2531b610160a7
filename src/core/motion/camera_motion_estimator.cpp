#include "instant_motion_tracking/core/motion/camera_motion_estimator.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>

#include <algorithm>
#include <cmath>
#include <complex>
#include <cstdint>

namespace imt {

const char* modelCheckName(ModelCheck c) {
  switch (c) {
    case ModelCheck::kOk:
      return "ok";
    case ModelCheck::kNotFitted:
      return "not fitted";
    case ModelCheck::kDegenerate:
      return "degenerate";
    case ModelCheck::kTooFewInliers:
      return "too few inliers";
    case ModelCheck::kLowInlierFraction:
      return "low inlier fraction";
    case ModelCheck::kLowCoverage:
      return "low inlier coverage";
    case ModelCheck::kScale:
      return "scale out of bounds";
    case ModelCheck::kRotation:
      return "rotation out of bounds";
    case ModelCheck::kPerspective:
      return "perspective out of bounds";
    case ModelCheck::kTranslation:
      return "translation out of bounds";
  }
  return "?";
}

namespace {

using Eigen::Matrix3d;
using Eigen::Vector2d;

// Correspondences in normalised coordinates: origin at the frame centre, the
// half diagonal is 1. Keeps the homography's normal equations well conditioned.
struct Problem {
  std::vector<Vector2d> p, q;
  std::vector<double> prior;
  size_t size() const { return p.size(); }
};

Vector2d apply(const Matrix3d& H, const Vector2d& p) {
  const double w = H(2, 0) * p.x() + H(2, 1) * p.y() + H(2, 2);
  return Vector2d((H(0, 0) * p.x() + H(0, 1) * p.y() + H(0, 2)) / w,
                  (H(1, 0) * p.x() + H(1, 1) * p.y() + H(1, 2)) / w);
}

void computeResiduals(const Problem& pr, const Matrix3d& H, std::vector<double>* r) {
  r->resize(pr.size());
  for (size_t i = 0; i < pr.size(); ++i) {
    const double v = (pr.q[i] - apply(H, pr.p[i])).norm();
    (*r)[i] = std::isfinite(v) ? v : 1e9;
  }
}

// Tukey's biweight: 1 at zero residual, 0 beyond c.
double tukey(double r, double c) {
  if (r >= c) return 0.0;
  const double u = 1.0 - (r * r) / (c * c);
  return u * u;
}

bool fitTranslation(const Problem& pr, const std::vector<double>& w, Matrix3d* H) {
  Vector2d sum = Vector2d::Zero();
  double sw = 0;
  for (size_t i = 0; i < pr.size(); ++i) {
    sum += w[i] * (pr.q[i] - pr.p[i]);
    sw += w[i];
  }
  if (!(sw > 1e-9)) return false;
  *H = Matrix3d::Identity();
  H->block<2, 1>(0, 2) = sum / sw;
  return true;
}

// u = a x - b y + tx, v = b x + a y + ty.
bool fitSimilarity(const Problem& pr, const std::vector<double>& w, Matrix3d* H) {
  Eigen::Matrix4d A = Eigen::Matrix4d::Zero();
  Eigen::Vector4d b = Eigen::Vector4d::Zero();
  int used = 0;
  for (size_t i = 0; i < pr.size(); ++i) {
    if (w[i] <= 0) continue;
    ++used;
    const double x = pr.p[i].x(), y = pr.p[i].y();
    const Eigen::Vector4d r1(x, -y, 1, 0), r2(y, x, 0, 1);
    A.noalias() += w[i] * (r1 * r1.transpose() + r2 * r2.transpose());
    b.noalias() += w[i] * (r1 * pr.q[i].x() + r2 * pr.q[i].y());
  }
  if (used < 2) return false;
  Eigen::LDLT<Eigen::Matrix4d> ldlt(A);
  if (ldlt.info() != Eigen::Success ||
      ldlt.vectorD().minCoeff() <= 1e-12 * std::max(1.0, A.trace()))
    return false;
  const Eigen::Vector4d s = ldlt.solve(b);
  if (!s.allFinite()) return false;
  *H << s(0), -s(1), s(2), s(1), s(0), s(3), 0, 0, 1;
  return true;
}

// h = [h00 h01 h02 h10 h11 h12 h20 h21], h22 = 1. The linear (algebraic)
// equations are divided by the current denominator so that the weighted
// residuals approximate geometric ones. Each point contributes the rows
//   r1 = [x y 1 0 0 0 -ux -uy] (rhs u),  r2 = [0 0 0 x y 1 -vx -vy] (rhs v);
// the normal equations are assembled from 23 weighted moments instead of two
// 8x8 outer products per point.
bool fitHomography(const Problem& pr, const std::vector<double>& w, const Matrix3d& H0,
                   Matrix3d* H) {
  double s1 = 0, sx = 0, sy = 0, sxx = 0, sxy = 0, syy = 0;  // of m m^T, m = (x, y, 1)
  double u1 = 0, ux = 0, uy = 0, uxx = 0, uxy = 0, uyy = 0;  // u m, u m [x y]
  double v1 = 0, vx = 0, vy = 0, vxx = 0, vxy = 0, vyy = 0;  // v m, v m [x y]
  double rx = 0, ry = 0, rxx = 0, rxy = 0, ryy = 0;          // (u^2 + v^2) [x y] ...
  int used = 0;
  for (size_t i = 0; i < pr.size(); ++i) {
    if (w[i] <= 0) continue;
    ++used;
    const double x = pr.p[i].x(), y = pr.p[i].y(), u = pr.q[i].x(), v = pr.q[i].y();
    const double d = H0(2, 0) * x + H0(2, 1) * y + 1.0;
    const double wi = w[i] / std::max(1e-6, d * d);
    const double wx = wi * x, wy = wi * y, wxx = wx * x, wxy = wx * y, wyy = wy * y;
    s1 += wi, sx += wx, sy += wy, sxx += wxx, sxy += wxy, syy += wyy;
    u1 += wi * u, ux += wx * u, uy += wy * u, uxx += wxx * u, uxy += wxy * u, uyy += wyy * u;
    v1 += wi * v, vx += wx * v, vy += wy * v, vxx += wxx * v, vxy += wxy * v, vyy += wyy * v;
    const double r2 = u * u + v * v;
    rx += wx * r2, ry += wy * r2, rxx += wxx * r2, rxy += wxy * r2, ryy += wyy * r2;
  }
  if (used < 4) return false;
  Eigen::Matrix<double, 8, 8> A = Eigen::Matrix<double, 8, 8>::Zero();
  Eigen::Matrix<double, 8, 1> b;
  Eigen::Matrix3d M;
  M << sxx, sxy, sx, sxy, syy, sy, sx, sy, s1;
  A.block<3, 3>(0, 0) = M;
  A.block<3, 3>(3, 3) = M;
  Eigen::Matrix<double, 3, 2> Pu, Pv;
  Pu << -uxx, -uxy, -uxy, -uyy, -ux, -uy;
  Pv << -vxx, -vxy, -vxy, -vyy, -vx, -vy;
  A.block<3, 2>(0, 6) = Pu;
  A.block<3, 2>(3, 6) = Pv;
  A.block<2, 3>(6, 0) = Pu.transpose();
  A.block<2, 3>(6, 3) = Pv.transpose();
  A(6, 6) = rxx, A(6, 7) = A(7, 6) = rxy, A(7, 7) = ryy;
  b << ux, uy, u1, vx, vy, v1, -rx, -ry;
  Eigen::LDLT<Eigen::Matrix<double, 8, 8>> ldlt(A);
  if (ldlt.info() != Eigen::Success ||
      ldlt.vectorD().minCoeff() <= 1e-12 * std::max(1.0, A.trace()))
    return false;
  const Eigen::Matrix<double, 8, 1> h = ldlt.solve(b);
  if (!h.allFinite()) return false;
  *H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1;
  return true;
}

// IRLS for one model class from initial residuals `r` (normalised units).
// Returns false when a solve failed; `r` holds the final residuals.
bool irls(MotionModel model, const Problem& pr, double thr, int iterations, const Matrix3d& seed,
          std::vector<double>* r, Matrix3d* H) {
  std::vector<double> w(pr.size());
  Matrix3d cur = seed;
  bool ok = false;
  std::vector<double> inl;
  double adaptive = thr;
  for (int k = 0; k < iterations; ++k) {
    // Annealed cut-off: wide at first so that a rough seed does not throw
    // away true inliers, then the inlier threshold, then (from the fourth
    // round) three times the median inlier residual, within [thr/4, thr]:
    // tracking noise is ~0.1 px while slowly moving objects sit at 0.5-2 px,
    // well inside the inlier threshold, and would otherwise bend the fit.
    double c = thr * std::max(1.0, 3.0 - k);
    if (k == 3 || k == 6) {  // (re-)estimate the noise scale from the inliers
      inl.clear();
      for (double v : *r)
        if (v < thr) inl.push_back(v);
      if (inl.size() >= 4) {
        std::nth_element(inl.begin(), inl.begin() + inl.size() / 2, inl.end());
        adaptive = std::clamp(3.0 * inl[inl.size() / 2], 0.25 * thr, thr);
      }
    }
    if (k >= 3) c = adaptive;
    for (size_t i = 0; i < pr.size(); ++i) w[i] = pr.prior[i] * tukey((*r)[i], c);
    Matrix3d next;
    bool solved = false;
    switch (model) {
      case MotionModel::kTranslation:
        solved = fitTranslation(pr, w, &next);
        break;
      case MotionModel::kSimilarity:
        solved = fitSimilarity(pr, w, &next);
        break;
      case MotionModel::kHomography:
        solved = fitHomography(pr, w, cur, &next);
        break;
      case MotionModel::kInvalid:
        break;
    }
    if (!solved) break;
    ok = true;
    const double change = (next - cur).cwiseAbs().maxCoeff();
    cur = next;
    computeResiduals(pr, cur, r);
    if (k >= 4 && change < 1e-7) break;  // converged (normalised units: ~1e-4 px)
  }
  *H = cur;
  return ok;
}

// Seed: the best (highest prior-weighted truncated-quadratic score) of last
// frame's model, the median translation and 2-point similarity hypotheses.
Matrix3d seedModel(const Problem& pr, double thr, int hypotheses, const Matrix3d* previous) {
  const size_t n = pr.size();
  std::vector<double> r;
  auto score = [&](const Matrix3d& H) {
    computeResiduals(pr, H, &r);
    double s = 0;
    for (size_t i = 0; i < n; ++i)
      if (r[i] < thr) s += pr.prior[i] * (1.0 - (r[i] * r[i]) / (thr * thr));
    return s;
  };
  Matrix3d best = Matrix3d::Identity();
  double best_score = score(best);
  auto consider = [&](const Matrix3d& H) {
    if (!H.allFinite()) return;
    const double s = score(H);
    if (s > best_score) best_score = s, best = H;
  };
  if (previous) consider(*previous);
  {
    std::vector<double> dx(n), dy(n);
    for (size_t i = 0; i < n; ++i)
      dx[i] = pr.q[i].x() - pr.p[i].x(), dy[i] = pr.q[i].y() - pr.p[i].y();
    std::nth_element(dx.begin(), dx.begin() + n / 2, dx.end());
    std::nth_element(dy.begin(), dy.begin() + n / 2, dy.end());
    Matrix3d T = Matrix3d::Identity();
    T(0, 2) = dx[n / 2];
    T(1, 2) = dy[n / 2];
    consider(T);
  }
  if (n < 2) return best;
  // Deterministic sampling (same input, same result); pairs are drawn with
  // probability proportional to their prior and must be well separated.
  uint64_t state = 0x9E3779B97F4A7C15ull ^ n;
  auto next = [&state]() {
    state ^= state << 13;
    state ^= state >> 7;
    state ^= state << 17;
    return state;
  };
  auto draw = [&]() {
    for (int tries = 0; tries < 8; ++tries) {
      const size_t i = next() % n;
      if ((next() % 1024) / 1024.0 < pr.prior[i]) return i;
    }
    return static_cast<size_t>(next() % n);
  };
  for (int h = 0, attempts = 0; h < hypotheses && attempts < 4 * hypotheses; ++attempts) {
    const size_t i = draw(), j = draw();
    const std::complex<double> p1(pr.p[i].x(), pr.p[i].y()), p2(pr.p[j].x(), pr.p[j].y());
    if (std::abs(p1 - p2) < 0.1)
      continue;  // 5% of the diagonal: too close to fix rotation and scale
    ++h;
    const std::complex<double> q1(pr.q[i].x(), pr.q[i].y()), q2(pr.q[j].x(), pr.q[j].y());
    const std::complex<double> a = (q1 - q2) / (p1 - p2);
    const std::complex<double> t = q1 - a * p1;
    Matrix3d S;
    S << a.real(), -a.imag(), t.real(), a.imag(), a.real(), t.imag(), 0, 0, 1;
    consider(S);
  }
  return best;
}

}  // namespace

CameraMotionEstimator::CameraMotionEstimator(const MotionAnalysisOptions& options)
    : options_(options) {}

CameraMotionEstimate CameraMotionEstimator::estimate(const std::vector<cv::Point2f>& prev,
                                                     const std::vector<cv::Point2f>& cur,
                                                     const std::vector<float>& prior,
                                                     const cv::Size& frame,
                                                     const Eigen::Matrix3d* previous_H) const {
  CameraMotionEstimate out;
  const size_t n = std::min(prev.size(), cur.size());
  out.motion.features = static_cast<int>(n);
  if (frame.width <= 0 || frame.height <= 0) return out;
  const double diag = std::hypot(frame.width, frame.height);
  const double cx = 0.5 * frame.width, cy = 0.5 * frame.height, s = 2.0 / diag;
  Matrix3d N;  // pixels -> normalised
  N << s, 0, -s * cx, 0, s, -s * cy, 0, 0, 1;
  Matrix3d N_inv;
  N_inv << 1 / s, 0, cx, 0, 1 / s, cy, 0, 0, 1;

  Problem pr;
  pr.p.reserve(n);
  pr.q.reserve(n);
  pr.prior.reserve(n);
  std::vector<int> cell;
  cell.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    if (!std::isfinite(prev[i].x) || !std::isfinite(prev[i].y) || !std::isfinite(cur[i].x) ||
        !std::isfinite(cur[i].y))
      continue;
    pr.p.emplace_back(s * (prev[i].x - cx), s * (prev[i].y - cy));
    pr.q.emplace_back(s * (cur[i].x - cx), s * (cur[i].y - cy));
    const double w = prior.size() == n ? static_cast<double>(prior[i]) : 1.0;
    pr.prior.push_back(std::isfinite(w) ? std::clamp(w, 1e-3, 1.0) : 1.0);
    const int gx = std::clamp(static_cast<int>(cur[i].x * options_.grid_cols / frame.width), 0,
                              options_.grid_cols - 1);
    const int gy = std::clamp(static_cast<int>(cur[i].y * options_.grid_rows / frame.height), 0,
                              options_.grid_rows - 1);
    cell.push_back(gy * options_.grid_cols + gx);
  }
  const size_t m = pr.size();
  if (static_cast<int>(m) < std::max(1, options_.min_inliers_translation)) return out;

  const double thr = options_.inlier_threshold * diag * s;  // normalised units
  Matrix3d prev_n;
  if (previous_H) prev_n = N * (*previous_H) * N_inv;
  const Matrix3d seed =
      seedModel(pr, thr, options_.ransac_hypotheses, previous_H ? &prev_n : nullptr);
  std::vector<double> r_seed;
  computeResiduals(pr, seed, &r_seed);

  // Fit similarity from the seed, the homography from the similarity's
  // weights, the translation from the similarity's weights too.
  std::array<Matrix3d, 4> Hn;
  std::array<bool, 4> solved{};
  std::array<std::vector<double>, 4> res;
  const int it = options_.irls_iterations;
  res[2] = r_seed;
  solved[2] = irls(MotionModel::kSimilarity, pr, thr, it, seed, &res[2], &Hn[2]);
  const std::vector<double>& base = solved[2] ? res[2] : r_seed;
  const Matrix3d& base_H = solved[2] ? Hn[2] : seed;
  res[3] = base;
  solved[3] = irls(MotionModel::kHomography, pr, thr, it, base_H, &res[3], &Hn[3]);
  res[1] = base;
  solved[1] = irls(MotionModel::kTranslation, pr, thr, it, base_H, &res[1], &Hn[1]);

  const int cells = options_.grid_cols * options_.grid_rows;
  std::vector<char> covered(cells);
  const double frac_needed = options_.min_inlier_fraction;
  for (int k = 1; k <= 3; ++k) {
    CameraMotionEstimate::Fit& fit = out.fits[k];
    if (!solved[k]) {
      fit.check = ModelCheck::kDegenerate;
      continue;
    }
    Matrix3d Hp = N_inv * Hn[k] * N;
    Hp /= Hp(2, 2);
    fit.H = Hp;
    std::fill(covered.begin(), covered.end(), 0);
    for (size_t i = 0; i < m; ++i) {
      if (res[k][i] < thr) {
        ++fit.inliers;
        covered[cell[i]] = 1;
      }
    }
    fit.coverage = static_cast<double>(std::count(covered.begin(), covered.end(), 1)) / cells;
    // Stability bounds on the normalised model.
    const Matrix3d& H = Hn[k];
    const Vector2d centre_motion = apply(H, Vector2d::Zero()) / s;  // px
    const Eigen::Matrix2d A = H.block<2, 2>(0, 0) / H(2, 2);
    const double rotation = std::atan2(A(1, 0) - A(0, 1), A(0, 0) + A(1, 1));
    const Eigen::Vector2d sv = Eigen::JacobiSVD<Eigen::Matrix2d>(A).singularValues();
    const double perspective =
        2.0 * std::max(std::abs(H(2, 0)), std::abs(H(2, 1))) / std::abs(H(2, 2));
    const int min_inliers =
        k == 1 ? options_.min_inliers_translation
               : (k == 2 ? options_.min_inliers_similarity : options_.min_inliers_homography);
    fit.check = ModelCheck::kOk;
    if (fit.inliers < min_inliers) {
      fit.check = ModelCheck::kTooFewInliers;
    } else if (k > 1 && fit.inliers < frac_needed * m) {
      fit.check = ModelCheck::kLowInlierFraction;
    } else if (k == 3 && fit.coverage < options_.min_inlier_coverage) {
      fit.check = ModelCheck::kLowCoverage;
    } else if (centre_motion.norm() > options_.max_translation * diag) {
      fit.check = ModelCheck::kTranslation;
    } else if (k > 1 && (A.determinant() <= 0 || std::abs(sv(0) - 1) > options_.max_scale_change ||
                         std::abs(sv(1) - 1) > options_.max_scale_change)) {
      fit.check = ModelCheck::kScale;
    } else if (k > 1 && std::abs(rotation) > options_.max_rotation) {
      fit.check = ModelCheck::kRotation;
    } else if (k == 3 && perspective > options_.max_perspective) {
      fit.check = ModelCheck::kPerspective;
    }
  }
  for (int k = 3; k >= 1; --k) {
    if (out.fits[k].check == ModelCheck::kOk) {
      out.motion.model = static_cast<MotionModel>(k);
      out.motion.H = out.fits[k].H;
      out.motion.inliers = out.fits[k].inliers;
      break;
    }
  }
  return out;
}

}  // namespace imt
