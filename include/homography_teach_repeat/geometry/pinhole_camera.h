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
};

class PinholeCamera {
 public:
  // Throws std::invalid_argument with a message naming the bad value when: width/height <= 0,
  // fx/fy not finite or <= 0, cx/cy not finite, an unknown model, a coefficient count the model
  // does not accept, or a non-finite coefficient.
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

  Eigen::Matrix3d K() const;
  Eigen::Matrix3d Kinverse() const;
  CameraCalibration calibration() const;

  // Distorted (measured) pixel -> pixel of the ideal pinhole camera with the same K.
  cv::Point2d undistortPixel(const cv::Point2d& distorted) const;
  std::vector<cv::Point2d> undistortPixels(const std::vector<cv::Point2d>& distorted) const;
  // Ideal pinhole pixel -> distorted pixel (the forward lens model).
  cv::Point2d distortPixel(const cv::Point2d& undistorted) const;

  // Distorted pixel -> normalised, undistorted image coordinates (x/z, y/z).
  Eigen::Vector2d pixelToNormalized(const cv::Point2d& distorted) const;
  // Point in the optical frame (z > 0) -> distorted pixel.
  cv::Point2d project(const Eigen::Vector3d& point_optical) const;
  bool isInside(const cv::Point2d& pixel) const;

 private:
  Eigen::Vector2d distortNormalized(const Eigen::Vector2d& undistorted) const;
  Eigen::Vector2d undistortNormalized(const Eigen::Vector2d& distorted) const;

  int width_;
  int height_;
  double fx_, fy_, cx_, cy_;
  DistortionModel model_;
  std::vector<double> coefficients_;
};

}  // namespace homography_teach_repeat
