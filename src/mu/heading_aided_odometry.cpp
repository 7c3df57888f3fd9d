#include "homography_teach_repeat/mu/heading_aided_odometry.h"

#include <Eigen/Dense>

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/mu/heading_1d.h"

namespace homography_teach_repeat {
namespace {

void requireNonNegative(double value, const char* name) {
  if (!std::isfinite(value) || value < 0.0) {
    throw std::invalid_argument(std::string("heading-aided odometry: ") + name + " must be finite and >= 0");
  }
}

void requirePositive(double value, const char* name) {
  if (!std::isfinite(value) || !(value > 0.0)) {
    throw std::invalid_argument(std::string("heading-aided odometry: ") + name + " must be finite and > 0");
  }
}

// μ a camera at base pose `base` (route frame) measures against the observation's reference.
Expected<double> muAt(const MuObservation& observation, const Pose2D& base) {
  const auto H = wallHomography1dAt(observation, base);
  if (!H) return H.status();
  return (*H)(0, 1) / (*H)(1, 1);
}

}  // namespace

std::optional<MuObservation> muWallOf(const Pose2D& reference_pose, const std::optional<ScenePlane>& plane,
                                      const Pose2D& camera_mount, double focal_px, int reference_id) {
  if (!plane) return std::nullopt;
  const Eigen::Vector2d normal(plane->normal.x(), plane->normal.z());
  if (!(normal.norm() > 0.5) || !(plane->distance > 0.0)) return std::nullopt;
  MuObservation wall;
  wall.reference_pose = reference_pose;
  // The wall's line in the (x, z) plane: n·X = d with the unit horizontal part of n.
  wall.wall_normal = normal.normalized();
  wall.wall_distance = plane->distance / normal.norm();
  wall.camera_mount = camera_mount;
  wall.focal_px = focal_px;
  wall.reference_id = reference_id;
  return wall;
}

Expected<Eigen::Matrix2d> wallHomography1dAt(const MuObservation& wall, const Pose2D& base) {
  const CameraMount mount(wall.camera_mount.x, wall.camera_mount.y, wall.camera_mount.yaw);
  const PlanarPose camera = mount.baseToCamera(wall.reference_pose.inverse().compose(base));
  return planeHomography1d(camera, wall.wall_normal, wall.wall_distance, wall.focal_px);
}

void HeadingAidedOdometryOptions::validate() const {
  requireNonNegative(initial_position_variance, "initial_position_variance");
  requireNonNegative(position_variance_per_metre, "position_variance_per_metre");
  requirePositive(heading_fix_variance, "heading_fix_variance");
  requireNonNegative(heading_variance_per_metre, "heading_variance_per_metre");
  requireNonNegative(heading_variance_per_radian, "heading_variance_per_radian");
  requirePositive(min_mu_variance, "min_mu_variance");
  requirePositive(innovation_gate, "innovation_gate");
  if (refused_before_reset < 1) {
    throw std::invalid_argument("heading-aided odometry: refused_before_reset must be >= 1");
  }
  requirePositive(max_mu_step_px, "max_mu_step_px");
  requirePositive(max_confirmation_distance, "max_confirmation_distance");
  requireNonNegative(reset_position_variance, "reset_position_variance");
  requireNonNegative(reset_heading_variance, "reset_heading_variance");
}

HeadingAidedOdometry::HeadingAidedOdometry(const HeadingAidedOdometryOptions& options) : options_(options) {
  options_.validate();
}

Status HeadingAidedOdometry::align(const Pose2D& route_pose, const Pose2D& odom_pose) {
  if (!route_pose.isFinite() || !odom_pose.isFinite()) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite alignment pose");
  }
  estimate_ = Pose2D(route_pose.x, route_pose.y, wrapToPi(route_pose.yaw));
  covariance_ = Eigen::Vector3d(options_.initial_position_variance, options_.initial_position_variance,
                                options_.heading_fix_variance)
                    .asDiagonal();
  last_odom_ = odom_pose;
  previous_mu_.reset();
  aligned_ = true;
  distance_since_fix_ = 0.0;
  refused_in_a_row_ = 0;
  return Status::ok();
}

Pose2D HeadingAidedOdometry::alignment() const { return estimate_.compose(last_odom_.inverse()); }

Expected<Pose2D> HeadingAidedOdometry::odometryStepTo(const Pose2D& odom_pose) const {
  if (!odom_pose.isFinite()) return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite odometry");
  if (!aligned_) return Status(StatusCode::kNoConsensus, "heading-aided odometry: not aligned yet");
  return last_odom_.inverse().compose(odom_pose);
}

Status HeadingAidedOdometry::predict(const Pose2D& odom_pose) {
  const auto odometry_step = odometryStepTo(odom_pose);
  if (!odometry_step) return odometry_step.status();
  const Pose2D& step = *odometry_step;
  const double c = std::cos(estimate_.yaw), s = std::sin(estimate_.yaw);
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 2) = -s * step.x - c * step.y;
  F(1, 2) = c * step.x - s * step.y;
  const double distance = std::hypot(step.x, step.y);
  const double turned = std::abs(wrapToPi(step.yaw));
  // Position noise is isotropic in the body frame, so it needs no rotation into the route frame.
  const Eigen::Vector3d process(options_.position_variance_per_metre * distance,
                                options_.position_variance_per_metre * distance,
                                options_.heading_variance_per_metre * distance +
                                    options_.heading_variance_per_radian * turned);
  covariance_ = F * covariance_ * F.transpose() + Eigen::Matrix3d(process.asDiagonal());
  estimate_ = estimate_.compose(step);
  estimate_.yaw = wrapToPi(estimate_.yaw);
  last_odom_ = odom_pose;
  distance_since_fix_ += distance;
  return Status::ok();
}

Status HeadingAidedOdometry::update(double innovation, const Eigen::RowVector3d& jacobian, double variance,
                                    const char* what) {
  double innovation_variance = (jacobian * covariance_ * jacobian.transpose())(0, 0) + variance;
  if (innovation * innovation > options_.innovation_gate * options_.innovation_gate * innovation_variance) {
    if (++refused_in_a_row_ < options_.refused_before_reset) {
      char message[200];
      std::snprintf(message, sizeof(message),
                    "heading-aided odometry: %s refused, %.3g from the prediction (%.1f sigma > %.1f)", what,
                    innovation, std::abs(innovation) / std::sqrt(innovation_variance), options_.innovation_gate);
      return Status(StatusCode::kNoConsensus, message);
    }
    // Lasting disagreement: the estimate is the wrong one (e.g. a long outage with more drift
    // than modelled). Widen it so the measurements take over.
    covariance_ += Eigen::Vector3d(options_.reset_position_variance, options_.reset_position_variance,
                                   options_.reset_heading_variance)
                       .asDiagonal();
    innovation_variance = (jacobian * covariance_ * jacobian.transpose())(0, 0) + variance;
  }
  refused_in_a_row_ = 0;
  const Eigen::Vector3d gain = covariance_ * jacobian.transpose() / innovation_variance;
  estimate_.x += gain(0) * innovation;
  estimate_.y += gain(1) * innovation;
  estimate_.yaw = wrapToPi(estimate_.yaw + gain(2) * innovation);
  // Joseph form: stays symmetric positive semi-definite.
  const Eigen::Matrix3d keep = Eigen::Matrix3d::Identity() - gain * jacobian;
  covariance_ = keep * covariance_ * keep.transpose() + gain * variance * gain.transpose();
  distance_since_fix_ = 0.0;
  return Status::ok();
}

Status HeadingAidedOdometry::correctWithMu(const MuObservation& observation, const Pose2D& odom_pose) {
  if (!std::isfinite(observation.mu) || !std::isfinite(observation.variance) || !observation.reference_pose.isFinite() ||
      !observation.camera_mount.isFinite()) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite mu observation");
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  const auto predicted = muAt(observation, estimate_);
  if (!predicted) return predicted.status();
  // Confirmation by the previous frame: the measured change of μ against the change the
  // prediction gives between the two robot poses (the previous one: the current prediction moved
  // back by the odometry between them).
  const std::optional<PreviousMu> previous = previous_mu_;
  previous_mu_ = PreviousMu{observation.reference_id, observation.mu, odom_pose};
  const Pose2D back = odom_pose.inverse().compose(previous ? previous->odom : odom_pose);
  if (!previous || previous->reference_id != observation.reference_id ||
      std::hypot(back.x, back.y) > options_.max_confirmation_distance) {
    return Status(StatusCode::kNoConsensus, "heading-aided odometry: mu fix waits for the next frame's confirmation");
  }
  const auto predicted_previous = muAt(observation, estimate_.compose(back));
  if (!predicted_previous) return predicted_previous.status();
  const double step_error = (observation.mu - previous->mu) - (*predicted - *predicted_previous);
  if (std::abs(step_error) > options_.max_mu_step_px) {
    char message[160];
    std::snprintf(message, sizeof(message),
                  "heading-aided odometry: mu changed %.1f px more than odometry predicts since the previous "
                  "frame (max_mu_step_px %.1f): a wrong line association in one of them",
                  step_error, options_.max_mu_step_px);
    return Status(StatusCode::kNoConsensus, message);
  }
  // ∂μ/∂(x, y, yaw) by central differences (only for a confirmed fix): μ is smooth and six
  // evaluations cost microseconds.
  Eigen::RowVector3d jacobian;
  const double steps[3] = {1e-5, 1e-5, 1e-6};
  for (int i = 0; i < 3; ++i) {
    Pose2D plus = estimate_, minus = estimate_;
    (i == 0 ? plus.x : i == 1 ? plus.y : plus.yaw) += steps[i];
    (i == 0 ? minus.x : i == 1 ? minus.y : minus.yaw) -= steps[i];
    const auto mu_plus = muAt(observation, plus), mu_minus = muAt(observation, minus);
    if (!mu_plus || !mu_minus) return mu_plus ? mu_minus.status() : mu_plus.status();
    jacobian(i) = (*mu_plus - *mu_minus) / (2.0 * steps[i]);
  }
  return update(observation.mu - *predicted, jacobian, std::max(observation.variance, options_.min_mu_variance),
                "mu fix");
}

Status HeadingAidedOdometry::correctHeading(double route_yaw, const Pose2D& odom_pose) {
  if (!std::isfinite(route_yaw)) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite heading fix");
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  return update(wrapToPi(route_yaw - estimate_.yaw), Eigen::RowVector3d(0.0, 0.0, 1.0),
                options_.heading_fix_variance, "heading fix");
}

Expected<Pose2D> HeadingAidedOdometry::predictedPose(const Pose2D& odom_pose) const {
  const auto step = odometryStepTo(odom_pose);
  if (!step) return step.status();
  Pose2D pose = estimate_.compose(*step);
  pose.yaw = wrapToPi(pose.yaw);
  return pose;
}

Expected<Pose2D> HeadingAidedOdometry::routePose(const Pose2D& odom_pose) {
  const Status predicted = predict(odom_pose);
  if (!predicted.isOk()) return predicted;
  return estimate_;
}

}  // namespace homography_teach_repeat
