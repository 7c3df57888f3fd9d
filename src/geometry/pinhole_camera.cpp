#include "homography_teach_repeat/geometry/pinhole_camera.h"

#include <Eigen/Geometry>
#include <opencv2/calib3d.hpp>

#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string describe(const CameraCalibration& c) {
  std::ostringstream s;
  s << "(width=" << c.width << ", height=" << c.height << ", fx=" << c.fx << ", fy=" << c.fy
    << ", cx=" << c.cx << ", cy=" << c.cy << ", model='" << c.distortion_model << "')";
  return s.str();
}

void require(bool condition, const std::string& what, const CameraCalibration& calibration) {
  if (!condition) {
    throw std::invalid_argument("PinholeCamera: " + what + " " + describe(calibration));
  }
}

// Undistorted radius of the single-parameter model: solves r + k r³ = r_d by Newton's method.
// The iteration is monotone from r_d (convex for k > 0, concave for k < 0), so it converges to the
// root nearest the centre. For k < 0 the model folds back beyond r_peak = 1/sqrt(−3k): distorted
// radii above the fold have no preimage and give NaN.
double undistortRadiusSingleParameter(double distorted_radius, double k) {
  if (k == 0.0 || distorted_radius == 0.0) return distorted_radius;
  if (k < 0.0) {
    const double r_peak = 1.0 / std::sqrt(-3.0 * k);
    if (distorted_radius >= r_peak + k * r_peak * r_peak * r_peak) return kNaN;
  }
  double r = distorted_radius;
  for (int iteration = 0; iteration < 100; ++iteration) {
    const double residual = r + k * r * r * r - distorted_radius;
    const double step = residual / (1.0 + 3.0 * k * r * r);
    r -= step;
    if (std::abs(step) <= 1e-15 * (1.0 + r)) break;
  }
  return r;
}

}  // namespace

DistortionModel distortionModelFromString(const std::string& name) {
  if (name == "none" || name.empty()) return DistortionModel::kNone;
  if (name == "plumb_bob") return DistortionModel::kPlumbBob;
  if (name == "rational_polynomial") return DistortionModel::kRationalPolynomial;
  if (name == "single_parameter_radial") return DistortionModel::kSingleParameterRadial;
  throw std::invalid_argument("unknown distortion model '" + name +
                              "' (accepted: none, plumb_bob, rational_polynomial, "
                              "single_parameter_radial)");
}

std::string toString(DistortionModel model) {
  switch (model) {
    case DistortionModel::kNone:
      return "none";
    case DistortionModel::kPlumbBob:
      return "plumb_bob";
    case DistortionModel::kRationalPolynomial:
      return "rational_polynomial";
    case DistortionModel::kSingleParameterRadial:
      return "single_parameter_radial";
  }
  return "none";
}

PinholeCamera::PinholeCamera(const CameraCalibration& c)
    : width_(c.width),
      height_(c.height),
      fx_(c.fx),
      fy_(c.fy),
      cx_(c.cx),
      cy_(c.cy),
      model_(DistortionModel::kNone),
      coefficients_(c.distortion),
      camera_to_level_(c.camera_to_level),
      levelled_(false) {
  require(c.width > 0 && c.height > 0, "image size must be positive", c);
  require(std::isfinite(c.fx) && c.fx > 0.0, "fx must be finite and > 0", c);
  require(std::isfinite(c.fy) && c.fy > 0.0, "fy must be finite and > 0", c);
  require(std::isfinite(c.cx) && std::isfinite(c.cy), "principal point must be finite", c);
  try {
    model_ = distortionModelFromString(c.distortion_model);
  } catch (const std::invalid_argument& e) {
    throw std::invalid_argument(std::string("PinholeCamera: ") + e.what());
  }
  for (std::size_t i = 0; i < coefficients_.size(); ++i) {
    if (!std::isfinite(coefficients_[i])) {
      throw std::invalid_argument("PinholeCamera: distortion coefficient D[" + std::to_string(i) +
                                  "] is not finite " + describe(c));
    }
  }
  require(camera_to_level_.allFinite(), "camera_to_level is not finite", c);
  require((camera_to_level_.transpose() * camera_to_level_ - Eigen::Matrix3d::Identity()).norm() < 1e-6 &&
              camera_to_level_.determinant() > 0.0,
          "camera_to_level is not a rotation", c);
  // The levelled optical axis: beyond 60° from the measured one the level camera's field of view
  // holds little of the measured image.
  require(camera_to_level_(2, 2) > 0.5, "camera_to_level turns the optical axis by more than 60 deg", c);
  levelled_ = !camera_to_level_.isIdentity(1e-12);
  const std::size_t n = coefficients_.size();
  switch (model_) {
    case DistortionModel::kNone:
      for (double d : coefficients_) {
        require(d == 0.0, "model 'none' with non-zero distortion coefficients", c);
      }
      coefficients_.clear();
      break;
    case DistortionModel::kPlumbBob:
      require(n == 4 || n == 5, "plumb_bob needs 4 or 5 coefficients, got " + std::to_string(n),
              c);
      coefficients_.resize(5, 0.0);
      break;
    case DistortionModel::kRationalPolynomial:
      require(n == 8, "rational_polynomial needs 8 coefficients, got " + std::to_string(n), c);
      break;
    case DistortionModel::kSingleParameterRadial:
      require(n == 1, "single_parameter_radial needs 1 coefficient (k1), got " + std::to_string(n),
              c);
      break;
  }
}

bool PinholeCamera::hasDistortion() const {
  for (double d : coefficients_) {
    if (d != 0.0) return true;
  }
  return false;
}

Eigen::Matrix3d PinholeCamera::K() const {
  Eigen::Matrix3d k;
  k << fx_, 0.0, cx_, 0.0, fy_, cy_, 0.0, 0.0, 1.0;
  return k;
}

Eigen::Matrix3d PinholeCamera::Kinverse() const {
  Eigen::Matrix3d k_inv;
  k_inv << 1.0 / fx_, 0.0, -cx_ / fx_, 0.0, 1.0 / fy_, -cy_ / fy_, 0.0, 0.0, 1.0;
  return k_inv;
}

CameraCalibration PinholeCamera::calibration() const {
  CameraCalibration c;
  c.width = width_;
  c.height = height_;
  c.fx = fx_;
  c.fy = fy_;
  c.cx = cx_;
  c.cy = cy_;
  c.distortion_model = toString(model_);
  c.distortion = coefficients_;
  c.camera_to_level = camera_to_level_;
  return c;
}

Eigen::Vector2d PinholeCamera::distortNormalized(const Eigen::Vector2d& undistorted) const {
  if (!hasDistortion()) return undistorted;
  if (model_ == DistortionModel::kSingleParameterRadial) {
    return undistorted * (1.0 + coefficients_[0] * undistorted.squaredNorm());
  }
  // plumb_bob / rational_polynomial: OpenCV's own forward model.
  const std::vector<cv::Point3d> object{cv::Point3d(undistorted.x(), undistorted.y(), 1.0)};
  std::vector<cv::Point2d> image;
  const cv::Matx33d identity = cv::Matx33d::eye();
  cv::projectPoints(object, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), identity, coefficients_,
                    image);
  return Eigen::Vector2d(image[0].x, image[0].y);
}

Eigen::Vector2d PinholeCamera::undistortNormalized(const Eigen::Vector2d& distorted) const {
  if (!hasDistortion()) return distorted;
  if (model_ == DistortionModel::kSingleParameterRadial) {
    const double r_d = distorted.norm();
    if (r_d == 0.0) return distorted;
    const double r_u = undistortRadiusSingleParameter(r_d, coefficients_[0]);
    return distorted * (r_u / r_d);
  }
  // OpenCV's iterative inverse, run to convergence rather than its default 5 iterations.
  const std::vector<cv::Point2d> src{cv::Point2d(distorted.x(), distorted.y())};
  std::vector<cv::Point2d> dst;
  const cv::Matx33d identity = cv::Matx33d::eye();
  cv::undistortPoints(src, dst, identity, coefficients_, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100,
                                       1e-14));
  return Eigen::Vector2d(dst[0].x, dst[0].y);
}

cv::Point2d PinholeCamera::undistortPixel(const cv::Point2d& distorted) const {
  const Eigen::Vector2d n = pixelToNormalized(distorted);
  return cv::Point2d(fx_ * n.x() + cx_, fy_ * n.y() + cy_);
}

std::vector<cv::Point2d> PinholeCamera::undistortPixels(
    const std::vector<cv::Point2d>& distorted) const {
  std::vector<cv::Point2d> out;
  out.reserve(distorted.size());
  for (const auto& p : distorted) out.push_back(undistortPixel(p));
  return out;
}

cv::Point2d PinholeCamera::distortPixel(const cv::Point2d& undistorted) const {
  return project(Eigen::Vector3d((undistorted.x - cx_) / fx_, (undistorted.y - cy_) / fy_, 1.0));
}

Eigen::Vector2d PinholeCamera::pixelToNormalized(const cv::Point2d& distorted) const {
  Eigen::Vector2d n = undistortNormalized(Eigen::Vector2d((distorted.x - cx_) / fx_, (distorted.y - cy_) / fy_));
  if (!levelled_) return n;
  const Eigen::Vector3d ray = camera_to_level_ * n.homogeneous();
  if (!(ray.z() > 0.0)) return Eigen::Vector2d(kNaN, kNaN);
  return ray.head<2>() / ray.z();
}

cv::Point2d PinholeCamera::project(const Eigen::Vector3d& point_level) const {
  const Eigen::Vector3d point_optical = levelled_ ? Eigen::Vector3d(camera_to_level_.transpose() * point_level) : point_level;
  if (!(point_optical.z() > 0.0)) return cv::Point2d(kNaN, kNaN);
  const Eigen::Vector2d d = distortNormalized(point_optical.head<2>() / point_optical.z());
  return cv::Point2d(fx_ * d.x() + cx_, fy_ * d.y() + cy_);
}

bool PinholeCamera::isInside(const cv::Point2d& pixel) const {
  return pixel.x >= 0.0 && pixel.y >= 0.0 && pixel.x <= width_ - 1.0 && pixel.y <= height_ - 1.0;
}

}  // namespace homography_teach_repeat
