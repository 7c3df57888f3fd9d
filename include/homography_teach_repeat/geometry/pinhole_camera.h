// Pinhole camera with lens distortion: the calibration every estimator of the package uses.
//
// Models (names as in sensor_msgs/CameraInfo::distortion_model where one exists):
//  - "none": no distortion (D empty or all zero);
//  - "plumb_bob": OpenCV/ROS radial-tangential (k1, k2, p1, p2[, k3]);
//  - "rational_polynomial": OpenCV 8-coefficient model (k1, k2, p1, p2, k3, k4, k5, k6);
//  - "single_parameter_radial": the classical one-parameter radial model used by paper 002 §6:
//    normalised distorted point = undistorted point · (1 + k1 r²), r² = x² + y², distortion centre
//    at the principal point. It is plumb_bob with only k1, but its undistortion has a closed form
//    (the real root of a cubic), so it is exact rather than iterative.
//
// Pixels follow the camera convention of docs/math.md §1.1 (u right, v down); K = [[fx, 0, cx],
// [0, fy, cy], [0, 0, 1]]. Undistorted pixel coordinates use the same K (like image_proc's
// rectified image for a monocular camera with P = K).
//
// Levelling (docs/math.md §1.1, "A camera that is not level"): a camera whose mount is pitched or
// rolled carries the rotation `camera_to_level` of its optical frame into the level camera frame
// (the frame with y along gravity's down and z the optical axis turned horizontal). Undistorted
// pixels are then pixels of that level camera with the same K: every ray is turned before any
// estimator sees it, as CameraInfo's rectification R turns a stereo camera's rays (OpenCV's
// initUndistortRectifyMap with R). The planar-motion model of Fast-HD and μ holds for them.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <string>
#include <vector>

namespace homography_teach_repeat {

enum class DistortionModel { kNone, kPlumbBob, kRationalPolynomial, kSingleParameterRadial };

// Parses a distortion model name (see above); throws std::invalid_argument naming the accepted
// names for anything else.
DistortionModel distortionModelFromString(const std::string& name);
std::string toString(DistortionModel model);

// Plain calibration record (what a sensor_msgs/CameraInfo carries), free of ROS types.
struct CameraCalibration {
  int width = 0;
  int height = 0;
  double fx = 0.0;
  double fy = 0.0;
  double cx = 0.0;
  double cy = 0.0;
  std::string distortion_model = "none";
  std::vector<double> distortion;
  // Rotation of the optical frame into the level camera frame (see above); identity for a level
  // camera. Set from the camera's tf by CameraMount::cameraToLevel.
  Eigen::Matrix3d camera_to_level = Eigen::Matrix3d::Identity();
};

class PinholeCamera {
 public:
  // Throws std::invalid_argument with a message naming the bad value when: width/height <= 0,
  // fx/fy not finite or <= 0, cx/cy not finite, an unknown model, a coefficient count the model
  // does not accept, a non-finite coefficient, or a camera_to_level that is not a rotation or
  // turns the optical axis by more than 60° (no level camera sees what that camera sees).
  explicit PinholeCamera(const CameraCalibration& calibration);

  int width() const { return width_; }
  int height() const { return height_; }
  double fx() const { return fx_; }
  double fy() const { return fy_; }
  double cx() const { return cx_; }
  double cy() const { return cy_; }
  DistortionModel distortionModel() const { return model_; }
  const std::vector<double>& distortionCoefficients() const { return coefficients_; }
  bool hasDistortion() const;
  // Whether measured pixels are already the pixels every estimator works with: no lens
  // distortion and no levelling rotation.
  bool isIdealPinhole() const { return !hasDistortion() && !isLevelled(); }
  bool isLevelled() const { return levelled_; }

  Eigen::Matrix3d K() const;
  Eigen::Matrix3d Kinverse() const;
  CameraCalibration calibration() const;

  // Distorted (measured) pixel -> pixel of the ideal (levelled) pinhole camera with the same K;
  // NaN for a ray the levelling turns behind the level camera.
  cv::Point2d undistortPixel(const cv::Point2d& distorted) const;
  std::vector<cv::Point2d> undistortPixels(const std::vector<cv::Point2d>& distorted) const;
  // Ideal (levelled) pinhole pixel -> distorted pixel (the forward lens model).
  cv::Point2d distortPixel(const cv::Point2d& undistorted) const;

  // Distorted pixel -> normalised, undistorted, levelled image coordinates (x/z, y/z).
  Eigen::Vector2d pixelToNormalized(const cv::Point2d& distorted) const;
  // Point in the level camera frame (the optical frame for a level camera; in front of the
  // camera) -> distorted pixel.
  cv::Point2d project(const Eigen::Vector3d& point_level) const;
  bool isInside(const cv::Point2d& pixel) const;

 private:
  Eigen::Vector2d distortNormalized(const Eigen::Vector2d& undistorted) const;
  Eigen::Vector2d undistortNormalized(const Eigen::Vector2d& distorted) const;

  int width_;
  int height_;
  double fx_, fy_, cx_, cy_;
  DistortionModel model_;
  std::vector<double> coefficients_;
  Eigen::Matrix3d camera_to_level_;
  bool levelled_;
};

}  // namespace homography_teach_repeat
