#include "instant_motion_tracking/core/camera_model.h"

#include <opencv2/calib3d.hpp>

#include <algorithm>
#include <cmath>
#include <sstream>

namespace imt {
namespace {

cv::Matx33d cameraMatrix(const CameraModel& k) {
  return cv::Matx33d(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
}

// OpenCV's default undistortPoints stops after 5 fixed-point iterations,
// which leaves pixels off near the corners of a strongly distorted image;
// this converges to well below 1e-6 px inside the image.
const cv::TermCriteria kUndistortCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100,
                                          1e-9);

bool finite(const cv::Point2d& p) { return std::isfinite(p.x) && std::isfinite(p.y); }

// Undistorts the finite points of `pts` in place (non-finite ones are left alone).
void undistortFinite(const CameraModel& k, std::vector<cv::Point2d>* pts) {
  std::vector<cv::Point2d> in;
  std::vector<size_t> where;
  in.reserve(pts->size());
  for (size_t i = 0; i < pts->size(); ++i) {
    if (!finite((*pts)[i])) continue;
    in.push_back((*pts)[i]);
    where.push_back(i);
  }
  if (in.empty()) return;
  std::vector<cv::Point2d> out;
  const cv::Matx33d K = cameraMatrix(k);
  const cv::Mat D(k.D, true);
  try {
    if (k.distortion == CameraModel::Distortion::kEquidistant) {
      cv::fisheye::undistortPoints(in, out, K, D, cv::noArray(), K, kUndistortCriteria);
    } else {
      cv::undistortPoints(in, out, K, D, cv::noArray(), K, kUndistortCriteria);
    }
  } catch (const cv::Exception&) {
    return;  // validate()d models do not throw; leave the pixels as they are
  }
  for (size_t j = 0; j < where.size() && j < out.size(); ++j) (*pts)[where[j]] = out[j];
}

}  // namespace

CameraModel CameraModel::fromFieldOfView(int w, int h, double hfov_deg) {
  CameraModel k;
  k.width = w;
  k.height = h;
  k.fx = k.fy = 0.5 * w / std::tan(0.5 * hfov_deg * M_PI / 180.0);
  k.cx = 0.5 * w;
  k.cy = 0.5 * h;
  k.valid = w > 0 && h > 0 && hfov_deg > 0 && hfov_deg < 180;
  return k;
}

CameraModel CameraModel::forFrame(const CameraModel& from_info, int width, int height,
                                  double default_hfov_deg) {
  if (from_info.valid && from_info.width == width && from_info.height == height &&
      from_info.validate().empty())
    return from_info;
  return fromFieldOfView(width, height, default_hfov_deg);
}

const char* CameraModel::distortionName(Distortion d) {
  switch (d) {
    case Distortion::kPlumbBob: return "plumb_bob";
    case Distortion::kRationalPolynomial: return "rational_polynomial";
    case Distortion::kEquidistant: return "equidistant";
    case Distortion::kNone: break;
  }
  return "none";
}

bool CameraModel::parseDistortion(const std::string& name, Distortion* d) {
  for (Distortion c : {Distortion::kNone, Distortion::kPlumbBob, Distortion::kRationalPolynomial,
                       Distortion::kEquidistant}) {
    if (name == distortionName(c)) {
      *d = c;
      return true;
    }
  }
  if (name.empty()) {
    *d = Distortion::kNone;
    return true;
  }
  return false;
}

size_t CameraModel::coefficientCount(Distortion d) {
  switch (d) {
    case Distortion::kPlumbBob: return 5;
    case Distortion::kRationalPolynomial: return 8;
    case Distortion::kEquidistant: return 4;
    case Distortion::kNone: break;
  }
  return 0;
}

bool CameraModel::setDistortion(Distortion d, const std::vector<double>& coefficients,
                                std::string* why) {
  const size_t n = coefficientCount(d);
  for (double c : coefficients) {
    if (!std::isfinite(c)) {
      if (why) *why = std::string(distortionName(d)) + " distortion has a NaN or infinite coefficient";
      return false;
    }
  }
  if (d == Distortion::kNone) {
    if (std::any_of(coefficients.begin(), coefficients.end(), [](double c) { return c != 0; })) {
      if (why) *why = "distortion model none with non-zero coefficients";
      return false;
    }
    distortion = d;
    D.clear();
    return true;
  }
  if (coefficients.size() > n) {
    if (why) {
      std::ostringstream os;
      os << distortionName(d) << " distortion takes " << n << " coefficients, got "
         << coefficients.size();
      *why = os.str();
    }
    return false;
  }
  distortion = d;
  D = coefficients;
  D.resize(n, 0.0);
  return true;
}

std::string CameraModel::validate() const {
  std::ostringstream os;
  if (!valid) return "camera model not set (valid = false)";
  if (!(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0))
    os << "focal length must be positive and finite (fx " << fx << ", fy " << fy << ")";
  else if (!(std::isfinite(cx) && std::isfinite(cy)))
    os << "principal point must be finite (cx " << cx << ", cy " << cy << ")";
  else if (width <= 0 || height <= 0)
    os << "image size must be positive (" << width << " x " << height << ")";
  else if (D.size() != coefficientCount(distortion))
    os << distortionName(distortion) << " distortion takes " << coefficientCount(distortion)
       << " coefficients, got " << D.size();
  else if (!std::all_of(D.begin(), D.end(), [](double c) { return std::isfinite(c); }))
    os << "distortion coefficient is NaN or infinite";
  return os.str();
}

bool CameraModel::hasDistortion() const {
  if (distortion == Distortion::kNone || D.size() != coefficientCount(distortion)) return false;
  if (!std::any_of(D.begin(), D.end(), [](double c) { return c != 0; })) return false;
  return validate().empty();
}

cv::Point2d CameraModel::undistort(const cv::Point2d& px) const {
  if (!hasDistortion() || !finite(px)) return px;
  std::vector<cv::Point2d> p{px};
  undistortFinite(*this, &p);
  return p[0];
}

void CameraModel::undistort(std::vector<cv::Point2d>* px) const {
  if (hasDistortion()) undistortFinite(*this, px);
}

void CameraModel::undistort(std::vector<cv::Point2f>* px) const {
  if (!hasDistortion()) return;
  std::vector<cv::Point2d> p(px->begin(), px->end());
  undistortFinite(*this, &p);
  for (size_t i = 0; i < p.size(); ++i) (*px)[i] = cv::Point2f(p[i]);
}

cv::Point2d CameraModel::distort(const cv::Point2d& ideal_px) const {
  if (!hasDistortion() || !finite(ideal_px)) return ideal_px;
  std::vector<cv::Point2d> p{ideal_px};
  distort(&p);
  return p[0];
}

void CameraModel::distort(std::vector<cv::Point2d>* ideal_px) const {
  if (!hasDistortion()) return;
  std::vector<cv::Point2d> normalised;
  std::vector<cv::Point3d> rays;
  std::vector<size_t> where;
  for (size_t i = 0; i < ideal_px->size(); ++i) {
    const cv::Point2d& p = (*ideal_px)[i];
    if (!finite(p)) continue;
    const cv::Point2d n((p.x - cx) / fx, (p.y - cy) / fy);
    normalised.push_back(n);
    rays.emplace_back(n.x, n.y, 1.0);
    where.push_back(i);
  }
  if (where.empty()) return;
  const cv::Matx33d K = cameraMatrix(*this);
  const cv::Mat D_mat(D, true);
  std::vector<cv::Point2d> out;
  try {
    if (distortion == Distortion::kEquidistant) {
      cv::fisheye::distortPoints(normalised, out, K, D_mat);
    } else {
      cv::projectPoints(rays, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D_mat, out);
    }
  } catch (const cv::Exception&) {
    return;
  }
  for (size_t j = 0; j < where.size() && j < out.size(); ++j) (*ideal_px)[where[j]] = out[j];
}

Eigen::Matrix3d CameraModel::imageHomography(const Eigen::Matrix3d& H_ideal) const {
  if (!hasDistortion() || !H_ideal.allFinite()) return H_ideal;
  constexpr int kGrid = 9;
  std::vector<cv::Point2d> src, ideal;
  for (int i = 0; i < kGrid; ++i)
    for (int j = 0; j < kGrid; ++j)
      src.emplace_back(width * i / (kGrid - 1.0), height * j / (kGrid - 1.0));
  ideal = src;
  undistort(&ideal);
  std::vector<cv::Point2d> from, to;
  for (size_t i = 0; i < src.size(); ++i) {
    const Eigen::Vector3d q = H_ideal * Eigen::Vector3d(ideal[i].x, ideal[i].y, 1.0);
    if (!(q.z() > 1e-9)) continue;  // maps behind the camera
    from.push_back(src[i]);
    to.emplace_back(q.x() / q.z(), q.y() / q.z());
  }
  if (from.size() < 8) return H_ideal;
  distort(&to);
  cv::Mat H;
  try {
    H = cv::findHomography(from, to, 0);
  } catch (const cv::Exception&) {
    return H_ideal;
  }
  if (H.empty()) return H_ideal;
  Eigen::Matrix3d out;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) out(r, c) = H.at<double>(r, c);
  if (!out.allFinite() || std::abs(out(2, 2)) < 1e-12) return H_ideal;
  return out / out(2, 2);
}

double CameraModel::localScale(const cv::Point2d& ideal_px) const {
  if (!hasDistortion() || !finite(ideal_px)) return 1.0;
  constexpr double h = 0.5;  // px, central differences
  std::vector<cv::Point2d> p = {ideal_px + cv::Point2d(h, 0), ideal_px - cv::Point2d(h, 0),
                                ideal_px + cv::Point2d(0, h), ideal_px - cv::Point2d(0, h)};
  distort(&p);
  const cv::Point2d ju = (p[0] - p[1]) / (2 * h), jv = (p[2] - p[3]) / (2 * h);
  const double det = std::abs(ju.x * jv.y - ju.y * jv.x);
  return std::isfinite(det) && det > 0 ? std::sqrt(det) : 1.0;
}

}  // namespace imt
