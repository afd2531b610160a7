// The camera model of the full-resolution image: pinhole intrinsics plus an
// optional lens distortion (ROS camera_info's plumb_bob, rational_polynomial
// or equidistant), and the one rule that picks the model for a frame.
//
// Every pose, ray and rotation homography of the trackers is computed between
// *ideal* pixels: where a point would appear through a distortion-free
// pinhole with the same K. Features, taps and reported positions are *image*
// pixels (where the point appears in the frame, through the lens).
// undistort() maps image -> ideal pixels, distort() ideal -> image pixels;
// without distortion both return their argument unchanged (bit-identical), so
// the pinhole path costs nothing.
//
// Pixels use our convention (docs/conventions.md: pixel (0,0) covers
// [0,1) x [0,1)); cx, cy are in it, and the distortion acts on the normalised
// coordinates ((u - cx) / fx, (v - cy) / fy), as in OpenCV and ROS.
//
// Usage:
//   imt::CameraModel k = imt::CameraModel::forFrame(from_camera_info, w, h, default_hfov_deg);
//   cv::Point2d ideal = k.undistort(feature_px);       // for a ray or a pose fit
//   cv::Point2d shown = k.distort(K * p / p.z());      // where a 3D point appears
// Threading: a plain value; const methods may be called from several threads.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace imt {

struct CameraModel {
  // The lens distortion model, as camera_info's distortion_model names it.
  enum class Distortion { kNone, kPlumbBob, kRationalPolynomial, kEquidistant };

  double fx = 0, fy = 0, cx = 0, cy = 0;  // px (our pixel convention)
  int width = 0, height = 0;              // px, the image these intrinsics belong to
  bool valid = false;  // false when unknown (no camera_info): callers use forFrame()
  Distortion distortion = Distortion::kNone;
  // Coefficients in OpenCV's (and ROS's) order: plumb_bob k1 k2 p1 p2 k3;
  // rational_polynomial k1 k2 p1 p2 k3 k4 k5 k6; equidistant k1 k2 k3 k4.
  // Set them with setDistortion(), which checks the length.
  std::vector<double> D;

  Eigen::Matrix3d K() const {
    Eigen::Matrix3d k;
    k << fx, 0, cx, 0, fy, cy, 0, 0, 1;
    return k;
  }
  // Distortion-free intrinsics of a w x h image with horizontal field of view
  // `hfov_deg`, principal point at the centre and square pixels.
  static CameraModel fromFieldOfView(int w, int h, double hfov_deg);
  // The model for a width x height frame: `from_info` (camera_info's) when it
  // is valid and both its width and height match the frame, else the
  // field-of-view default (distortion-free). The one place this rule lives.
  static CameraModel forFrame(const CameraModel& from_info, int width, int height,
                              double default_hfov_deg);

  // "none", "plumb_bob", "rational_polynomial", "equidistant".
  static const char* distortionName(Distortion d);
  // The model named `name` (camera_info spelling; "" means none); false when unknown.
  static bool parseDistortion(const std::string& name, Distortion* d);
  // Coefficients the model takes (0, 5, 8, 4).
  static size_t coefficientCount(Distortion d);
  // Sets the distortion. `coefficients` may be shorter than the model's count
  // (missing ones are 0: plumb_bob with 4) but not longer, and must be
  // finite; false with *why otherwise (the model is then left unchanged).
  bool setDistortion(Distortion d, const std::vector<double>& coefficients, std::string* why);

  // Empty when usable: valid, a positive finite focal length and principal
  // point, a positive size, coefficients of the right count; else why not.
  std::string validate() const;
  // A usable model whose distortion is not the identity (some coefficient non-zero).
  bool hasDistortion() const;

  // Image pixel -> ideal pinhole pixel (the same K). Returns `px` unchanged
  // without distortion or for a non-finite pixel. Accurate to ~1e-6 px inside
  // the image (OpenCV's iterative undistortPoints / fisheye::undistortPoints).
  cv::Point2d undistort(const cv::Point2d& px) const;
  // The same for many points at once (in place; one OpenCV call).
  void undistort(std::vector<cv::Point2d>* px) const;
  void undistort(std::vector<cv::Point2f>* px) const;
  // Ideal pinhole pixel -> image pixel: where the ray through `ideal_px`
  // appears in the frame (cv::projectPoints / fisheye::distortPoints).
  // Returns its argument unchanged without distortion. Far outside the image
  // a radial polynomial can fold back on itself: the result is then the
  // polynomial's value, not a physical pixel.
  cv::Point2d distort(const cv::Point2d& ideal_px) const;
  void distort(std::vector<cv::Point2d>* ideal_px) const;

  // The 3x3 homography between image pixels that best approximates
  // p -> distort(H_ideal * undistort(p)) over the image (least squares on a
  // 9 x 9 grid of image pixels): a rotation homography K R K^-1 holds only
  // between ideal pixels, and users that can take just a homography (the
  // region tracker's camera fallback) get this. H_ideal itself without
  // distortion (or when the fit fails). H(2,2) = 1.
  Eigen::Matrix3d imageHomography(const Eigen::Matrix3d& H_ideal) const;
  // How much the lens magnifies a small patch at ideal pixel `ideal_px`
  // (linear: sqrt |det J| of distort() there); 1 without distortion.
  double localScale(const cv::Point2d& ideal_px) const;
};

}  // namespace imt
