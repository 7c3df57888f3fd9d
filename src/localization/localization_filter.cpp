#include "homography_teach_repeat/localization/localization_filter.h"

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "homography_teach_repeat/localization/pose_jacobian.h"
#include "homography_teach_repeat/mu/heading_1d.h"

namespace homography_teach_repeat {
namespace {

void requireNonNegative(double value, const char* name) {
  if (!std::isfinite(value) || value < 0.0) {
    throw std::invalid_argument(std::string("localization filter: ") + name + " must be finite and >= 0");
  }
}

void requirePositive(double value, const char* name) {
  if (!std::isfinite(value) || !(value > 0.0)) {
    throw std::invalid_argument(std::string("localization filter: ") + name + " must be finite and > 0");
  }
}

// μ a camera at base pose `base` (route frame) measures against the observation's reference.
Expected<double> muAt(const MuObservation& observation, const Pose2D& base) {
  const auto H = wallHomography1dAt(observation, base);
  if (!H) return H.status();
  return (*H)(0, 1) / (*H)(1, 1);
}

}  // namespace

void LocalizationFilterOptions::validate() const {
  requireNonNegative(initial_position_variance, "initial_position_variance");
  requireNonNegative(position_variance_per_metre, "position_variance_per_metre");
  requirePositive(heading_fix_variance, "heading_fix_variance");
  requireNonNegative(heading_variance_per_metre, "heading_variance_per_metre");
  requireNonNegative(heading_variance_per_radian, "heading_variance_per_radian");
  requireNonNegative(position_variance_per_radian, "position_variance_per_radian");
  requirePositive(pose_innovation_gate, "pose_innovation_gate");
  if (!(pose_common_fraction >= 0.0 && pose_common_fraction <= 1.0)) {
    throw std::invalid_argument("localization filter: pose_common_fraction must be in [0, 1]");
  }
  requirePositive(min_mu_variance, "min_mu_variance");
  requirePositive(innovation_gate, "innovation_gate");
  if (refused_before_reset < 1) {
    throw std::invalid_argument("localization filter: refused_before_reset must be >= 1");
  }
  requirePositive(max_mu_step_px, "max_mu_step_px");
  requirePositive(max_confirmation_distance, "max_confirmation_distance");
  requireNonNegative(reset_position_variance, "reset_position_variance");
  requireNonNegative(reset_heading_variance, "reset_heading_variance");
  requirePositive(line_sigma_px, "line_sigma_px");
  if (min_landmark_lines < 2) throw std::invalid_argument("localization filter: min_landmark_lines must be >= 2");
  requirePositive(line_inlier_gate, "line_inlier_gate");
  requireNonNegative(line_heading_sigma_rad, "line_heading_sigma_rad");
  requireNonNegative(line_position_sigma_m, "line_position_sigma_m");
  requirePositive(line_max_brightness_difference, "line_max_brightness_difference");
}

LocalizationFilter::LocalizationFilter(const LocalizationFilterOptions& options) : options_(options) {
  options_.validate();
}

Status LocalizationFilter::align(const Pose2D& route_pose, const Pose2D& odom_pose) {
  if (!route_pose.isFinite() || !odom_pose.isFinite()) {
    return Status(StatusCode::kInvalidInput, "localization filter: non-finite alignment pose");
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

Status LocalizationFilter::align(const Pose2D& route_pose, const Pose2D& odom_pose,
                                   const Eigen::Matrix3d& covariance) {
  if (!covariance.allFinite() || !covariance.isApprox(covariance.transpose(), 1e-9) ||
      Eigen::LLT<Eigen::Matrix3d>(covariance).info() != Eigen::Success) {
    return Status(StatusCode::kInvalidInput, "localization filter: alignment covariance not symmetric positive definite");
  }
  Status aligned = align(route_pose, odom_pose);
  if (!aligned.isOk()) return aligned;
  covariance_ = covariance;
  return Status::ok();
}

Pose2D LocalizationFilter::alignment() const { return estimate_.compose(last_odom_.inverse()); }

Expected<Pose2D> LocalizationFilter::odometryStepTo(const Pose2D& odom_pose) const {
  if (!odom_pose.isFinite()) return Status(StatusCode::kInvalidInput, "localization filter: non-finite odometry");
  if (!aligned_) return Status(StatusCode::kNoConsensus, "localization filter: not aligned yet");
  return last_odom_.inverse().compose(odom_pose);
}

Status LocalizationFilter::predict(const Pose2D& odom_pose) {
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
  const double position_variance =
      options_.position_variance_per_metre * distance + options_.position_variance_per_radian * turned;
  const Eigen::Vector3d process(position_variance, position_variance,
                                options_.heading_variance_per_metre * distance +
                                    options_.heading_variance_per_radian * turned);
  covariance_ = F * covariance_ * F.transpose() + Eigen::Matrix3d(process.asDiagonal());
  estimate_ = estimate_.compose(step);
  estimate_.yaw = wrapToPi(estimate_.yaw);
  last_odom_ = odom_pose;
  distance_since_fix_ += distance;
  return Status::ok();
}

Status LocalizationFilter::update(double innovation, const Eigen::RowVector3d& jacobian, double variance,
                                    const char* what) {
  double innovation_variance = (jacobian * covariance_ * jacobian.transpose())(0, 0) + variance;
  const double nis = innovation * innovation / innovation_variance;
  last_innovation_ = FilterInnovation{nis, 1, false};
  if (nis > options_.innovation_gate * options_.innovation_gate) {
    if (!countRefusal()) {
      char message[200];
      std::snprintf(message, sizeof(message),
                    "localization filter: %s refused, %.3g from the prediction (%.1f sigma > %.1f)", what,
                    innovation, std::abs(innovation) / std::sqrt(innovation_variance), options_.innovation_gate);
      return Status(StatusCode::kNoConsensus, message);
    }
    innovation_variance = (jacobian * covariance_ * jacobian.transpose())(0, 0) + variance;
  }
  refused_in_a_row_ = 0;
  last_innovation_->accepted = true;
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

Expected<double> LocalizationFilter::correctWithPose(const Pose2D& measured, const Eigen::Matrix3d& measurement_covariance,
                                                       const Pose2D& odom_pose, const Eigen::Matrix3d& shared_covariance) {
  if (!shared_covariance.allFinite()) {
    return Status(StatusCode::kInvalidInput, "localization filter: the pose fix's shared covariance is not finite");
  }
  if (!measured.isFinite() || !measurement_covariance.allFinite() ||
      !measurement_covariance.isApprox(measurement_covariance.transpose(), 1e-9) ||
      Eigen::LLT<Eigen::Matrix3d>(measurement_covariance).info() != Eigen::Success) {
    return Status(StatusCode::kInvalidInput,
                  "localization filter: pose fix not finite or its covariance not symmetric positive definite");
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  // H = I: the innovation is the pose difference (yaw wrapped), S = P + R (docs/math.md §7.1).
  const Eigen::Vector3d innovation(measured.x - estimate_.x, measured.y - estimate_.y,
                                   wrapToPi(measured.yaw - estimate_.yaw));
  Eigen::Matrix3d S = covariance_ + measurement_covariance;
  Eigen::LDLT<Eigen::Matrix3d> S_ldlt(S);
  const double nis = innovation.dot(S_ldlt.solve(innovation));
  last_innovation_ = FilterInnovation{nis, 3, false};
  if (!(nis <= options_.pose_innovation_gate)) {
    if (!countRefusal()) {
      char message[200];
      std::snprintf(message, sizeof(message),
                    "localization filter: pose fix refused, %.2f m / %.2f deg from the prediction (NIS %.1f > "
                    "pose_innovation_gate %.1f)",
                    std::hypot(innovation(0), innovation(1)), innovation(2) * 180.0 / M_PI, nis,
                    options_.pose_innovation_gate);
      return Status(StatusCode::kNoConsensus, message);
    }
    S = covariance_ + measurement_covariance;  // widened: the fix is taken
    S_ldlt.compute(S);
  }
  const Eigen::Matrix3d gain = covariance_ * S_ldlt.solve(Eigen::Matrix3d::Identity());
  const Eigen::Vector3d correction = gain * innovation;
  if (!correction.allFinite() || !std::isfinite(nis)) {
    return Status(StatusCode::kNotFinite, "localization filter: the pose update is not finite");
  }
  estimate_ = Pose2D(estimate_.x + correction(0), estimate_.y + correction(1), wrapToPi(estimate_.yaw + correction(2)));
  const Eigen::Matrix3d keep = Eigen::Matrix3d::Identity() - gain;
  covariance_ = keep * covariance_ * keep.transpose() + gain * measurement_covariance * gain.transpose();
  // The error shared by repeated fixes: the covariance is kept at least the fix's shared part, its
  // model covariance and pose_common_fraction of the rest (the positive part of the difference is
  // added: P ⪰ R_shared + c (R − R_shared) afterwards).
  const Eigen::Matrix3d shared =
      shared_covariance + options_.pose_common_fraction * (measurement_covariance - shared_covariance);
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> lacking(shared - covariance_);
  covariance_ += lacking.eigenvectors() * lacking.eigenvalues().cwiseMax(0.0).asDiagonal() *
                 lacking.eigenvectors().transpose();
  covariance_ = 0.5 * (covariance_ + covariance_.transpose());
  refused_in_a_row_ = 0;
  distance_since_fix_ = 0.0;
  last_innovation_ = FilterInnovation{nis, 3, true};
  return nis;
}

bool LocalizationFilter::countRefusal() {
  if (++refused_in_a_row_ < options_.refused_before_reset) return false;
  // Lasting disagreement: the estimate is the wrong one (e.g. a long outage with more drift than
  // modelled). Widen it so the measurements take over.
  covariance_ += Eigen::Vector3d(options_.reset_position_variance, options_.reset_position_variance,
                                 options_.reset_heading_variance)
                     .asDiagonal();
  refused_in_a_row_ = 0;
  return true;
}

Status LocalizationFilter::correctWithMu(const MuObservation& observation, const Pose2D& odom_pose) {
  if (!std::isfinite(observation.mu) || !std::isfinite(observation.variance) || !observation.reference_pose.isFinite() ||
      !observation.camera_mount.isFinite()) {
    return Status(StatusCode::kInvalidInput, "localization filter: non-finite mu observation");
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
  if (observation.needs_confirmation) {
    if (!previous || previous->reference_id != observation.reference_id ||
        std::hypot(back.x, back.y) > options_.max_confirmation_distance) {
      return Status(StatusCode::kNoConsensus, "localization filter: mu fix waits for the next frame's confirmation");
    }
    const auto predicted_previous = muAt(observation, estimate_.compose(back));
    if (!predicted_previous) return predicted_previous.status();
    const double step_error = (observation.mu - previous->mu) - (*predicted - *predicted_previous);
    if (std::abs(step_error) > options_.max_mu_step_px) {
      char message[160];
      std::snprintf(message, sizeof(message),
                    "localization filter: mu changed %.1f px more than odometry predicts since the previous "
                    "frame (max_mu_step_px %.1f): a wrong line association in one of them",
                    step_error, options_.max_mu_step_px);
      return Status(StatusCode::kNoConsensus, message);
    }
  }
  // ∂μ/∂(x, y, yaw) (only for a confirmed fix).
  const auto jacobian = poseJacobian(estimate_, [&](const Pose2D& pose) { return muAt(observation, pose); });
  if (!jacobian) return jacobian.status();
  // The wall is an estimate too: its uncertainty moves the μ it predicts (docs/math.md §4.11).
  const auto wall_variance = wallModelVariance(observation, estimate_);
  if (!wall_variance) return wall_variance.status();
  return update(observation.mu - *predicted, *jacobian,
                std::max(observation.variance, options_.min_mu_variance) + *wall_variance, "mu fix");
}

Status LocalizationFilter::correctHeading(double route_yaw, const Pose2D& odom_pose, double variance) {
  if (!std::isfinite(route_yaw) || !std::isfinite(variance)) {
    return Status(StatusCode::kInvalidInput, "localization filter: non-finite heading fix");
  }
  Status predicted_to_fix = predict(odom_pose);
  if (!predicted_to_fix.isOk()) return predicted_to_fix;
  return update(wrapToPi(route_yaw - estimate_.yaw), Eigen::RowVector3d(0.0, 0.0, 1.0),
                std::max(variance, options_.heading_fix_variance), "heading fix");
}

Expected<Pose2D> LocalizationFilter::predictedPose(const Pose2D& odom_pose) const {
  const auto step = odometryStepTo(odom_pose);
  if (!step) return step.status();
  Pose2D pose = estimate_.compose(*step);
  pose.yaw = wrapToPi(pose.yaw);
  return pose;
}

Expected<Pose2D> LocalizationFilter::routePose(const Pose2D& odom_pose) {
  const Status predicted = predict(odom_pose);
  if (!predicted.isOk()) return predicted;
  return estimate_;
}

}  // namespace homography_teach_repeat
