#include "homography_teach_repeat/geometry/planar_pose.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

Eigen::Matrix2d rotation2d(double angle) {
  const double c = std::cos(angle);
  const double s = std::sin(angle);
  return (Eigen::Matrix2d() << c, -s, s, c).finished();
}

// d rotation2d / d angle
Eigen::Matrix2d rotation2dDerivative(double angle) {
  const double c = std::cos(angle);
  const double s = std::sin(angle);
  return (Eigen::Matrix2d() << -s, -c, c, -s).finished();
}

}  // namespace

double wrapToPi(double angle) {
  if (!std::isfinite(angle)) return angle;
  double wrapped = std::remainder(angle, 2.0 * M_PI);  // in [−π, π]
  if (wrapped <= -M_PI) wrapped += 2.0 * M_PI;
  return wrapped;
}

// ---------------------------------------------------------------------------------------------
// Pose2D and PlanarPose are both elements of SE(2); they differ only in the names of the axes
// ((x, y) vs (x, z)), so both use the same 2D rotation R(angle) = [[c, −s], [s, c]].

Pose2D Pose2D::compose(const Pose2D& other) const {
  const Eigen::Vector2d t = transformPoint(Eigen::Vector2d(other.x, other.y));
  return Pose2D(t.x(), t.y(), wrapToPi(yaw + other.yaw));
}

Pose2D Pose2D::inverse() const {
  const Eigen::Vector2d t = -(rotation2d(-yaw) * Eigen::Vector2d(x, y));
  return Pose2D(t.x(), t.y(), wrapToPi(-yaw));
}

Eigen::Vector2d Pose2D::transformPoint(const Eigen::Vector2d& point) const {
  return Eigen::Vector2d(x, y) + rotation2d(yaw) * point;
}

bool Pose2D::isFinite() const { return std::isfinite(x) && std::isfinite(y) && std::isfinite(yaw); }

PlanarPose PlanarPose::compose(const PlanarPose& other) const {
  return rep103ToCameraAxes(cameraAxesToRep103(*this).compose(cameraAxesToRep103(other)));
}

PlanarPose PlanarPose::inverse() const {
  return rep103ToCameraAxes(cameraAxesToRep103(*this).inverse());
}

Eigen::Vector2d PlanarPose::transformPoint(const Eigen::Vector2d& point_xz) const {
  return Eigen::Vector2d(x, z) + rotation2d(theta) * point_xz;
}

Eigen::Matrix3d PlanarPose::rotation21() const {
  // Ry(θ21) = [[cos, 0, −sin], [0, 1, 0], [sin, 0, cos]] with θ21 = −theta (docs/math.md §1.1).
  const double c = std::cos(-theta);
  const double s = std::sin(-theta);
  Eigen::Matrix3d r;
  r << c, 0.0, -s, 0.0, 1.0, 0.0, s, 0.0, c;
  return r;
}

Eigen::Isometry3d PlanarPose::toIsometry() const {
  // X1 = C + R21ᵀ X2.
  Eigen::Isometry3d transform = Eigen::Isometry3d::Identity();
  transform.linear() = rotation21().transpose();
  transform.translation() = centre();
  return transform;
}

bool PlanarPose::isFinite() const {
  return std::isfinite(x) && std::isfinite(z) && std::isfinite(theta);
}

// Camera axes x right, z forward; REP-103 axes x forward, y left. The yaw of both conventions is
// counter-clockwise seen from above (docs/math.md §1.1: θ12 turns the optical axis towards −x = left).
Pose2D cameraAxesToRep103(const PlanarPose& pose) { return Pose2D(pose.z, -pose.x, pose.theta); }

PlanarPose rep103ToCameraAxes(const Pose2D& pose) { return PlanarPose(-pose.y, pose.x, pose.yaw); }

// ---------------------------------------------------------------------------------------------
CameraMount::CameraMount(double x, double y, double yaw) : forward_frame_(x, y, yaw) {
  if (!forward_frame_.isFinite()) {
    std::ostringstream msg;
    msg << "CameraMount: non-finite mounting (x=" << x << ", y=" << y << ", yaw=" << yaw << ")";
    throw std::invalid_argument(msg.str());
  }
}

namespace {
// A finite extrinsic with an orthonormal rotation.
bool isRigid(const Eigen::Isometry3d& base_T_optical) {
  const Eigen::Matrix3d rotation = base_T_optical.linear();
  return base_T_optical.matrix().allFinite() &&
         (rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() <= 1e-6;
}
}  // namespace

CameraMount CameraMount::fromExtrinsic(const Eigen::Isometry3d& base_T_optical,
                                       double max_tilt_rad) {
  if (!base_T_optical.matrix().allFinite()) {
    throw std::invalid_argument("CameraMount: the camera extrinsic contains NaN/Inf");
  }
  const Eigen::Matrix3d rotation = base_T_optical.linear();
  if ((rotation.transpose() * rotation - Eigen::Matrix3d::Identity()).norm() > 1e-6) {
    throw std::invalid_argument("CameraMount: the camera extrinsic rotation is not orthonormal");
  }
  // Optical axes expressed in base_link: columns of the rotation.
  const Eigen::Vector3d optical_z = rotation.col(2);
  const double tilt = tiltOf(base_T_optical);
  if (!(tilt <= max_tilt_rad)) {
    std::ostringstream msg;
    msg << "CameraMount: the camera is not level: its optical y axis is " << tilt
        << " rad from the downward vertical of base_link (allowed " << max_tilt_rad
        << " rad): the images of a tilted camera are levelled (CameraMount::cameraToLevel), but not by more "
           "than that; check the mount and its tf.";
    throw std::invalid_argument(msg.str());
  }
  const double yaw = std::atan2(optical_z.y(), optical_z.x());
  return CameraMount(base_T_optical.translation().x(), base_T_optical.translation().y(), yaw);
}

double CameraMount::tiltOf(const Eigen::Isometry3d& base_T_optical) {
  if (!isRigid(base_T_optical)) return std::numeric_limits<double>::quiet_NaN();
  return std::acos(std::clamp(-base_T_optical.linear().col(1).z(), -1.0, 1.0));
}

double CameraMount::elevationOf(const Eigen::Isometry3d& base_T_optical) {
  if (!base_T_optical.matrix().allFinite()) return std::numeric_limits<double>::quiet_NaN();
  return std::asin(std::clamp(base_T_optical.linear().col(2).z(), -1.0, 1.0));
}

Eigen::Matrix3d CameraMount::cameraToLevel(const Eigen::Isometry3d& base_T_optical) {
  const Eigen::Matrix3d rotation = base_T_optical.linear();
  if (!isRigid(base_T_optical)) {
    throw std::invalid_argument("CameraMount: the camera extrinsic is not a finite rigid transform");
  }
  const Eigen::Vector3d optical_z = rotation.col(2);
  const Eigen::Vector2d forward = optical_z.head<2>();
  if (!(forward.norm() > std::sin(M_PI / 180.0))) {
    throw std::invalid_argument("CameraMount: the optical axis is vertical: no level camera looks where it looks");
  }
  const double yaw = std::atan2(forward.y(), forward.x());
  // Level camera axes in base_link: x = −y_base, y = −z_base, z = x_base, turned by the yaw.
  Eigen::Matrix3d level_in_base;
  level_in_base << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  level_in_base = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * level_in_base;
  return level_in_base.transpose() * rotation;
}

Pose2D CameraMount::cameraToBase(const PlanarPose& camera_relative) const {
  return forward_frame_.compose(cameraAxesToRep103(camera_relative))
      .compose(forward_frame_.inverse());
}

PlanarPose CameraMount::baseToCamera(const Pose2D& base_relative) const {
  return rep103ToCameraAxes(forward_frame_.inverse().compose(base_relative).compose(forward_frame_));
}

Eigen::Matrix3d CameraMount::cameraToBaseJacobian(const PlanarPose& camera_relative) const {
  // Translation of M ∘ P ∘ M⁻¹ is m + R(ψ) p − R(ψ) R(θ) R(−ψ) m with p = (z, −x); yaw is θ.
  const double psi = forward_frame_.yaw;
  const Eigen::Vector2d m(forward_frame_.x, forward_frame_.y);
  Eigen::Matrix2d dp_dxz;
  dp_dxz << 0.0, 1.0, -1.0, 0.0;
  Eigen::Matrix3d jacobian = Eigen::Matrix3d::Zero();
  jacobian.topLeftCorner<2, 2>() = rotation2d(psi) * dp_dxz;
  jacobian.block<2, 1>(0, 2) =
      -rotation2d(psi) * rotation2dDerivative(camera_relative.theta) * rotation2d(-psi) * m;
  jacobian(2, 2) = 1.0;
  return jacobian;
}

bool isClosedLoop(const std::vector<Pose2D>& poses, double max_gap) {
  if (!(max_gap > 0.0) || poses.size() < 3) return false;
  return std::hypot(poses.front().x - poses.back().x, poses.front().y - poses.back().y) <= max_gap;
}

}  // namespace homography_teach_repeat
