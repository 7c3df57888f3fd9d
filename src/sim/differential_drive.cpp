#include "homography_teach_repeat/sim/differential_drive.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {
namespace {

void requireFinite(double value, const char* name) {
  if (!std::isfinite(value)) throw std::invalid_argument(std::string("odometry model: ") + name + " must be finite");
}

}  // namespace

void OdometryErrorModel::validate() const {
  requireFinite(scale_error, "scale_error");
  requireFinite(heading_bias_per_metre, "heading_bias_per_metre");
  requireFinite(distance_noise, "distance_noise");
  requireFinite(heading_noise, "heading_noise");
  if (scale_error <= -1.0) throw std::invalid_argument("odometry model: scale_error must be > -1");
  if (distance_noise < 0.0 || heading_noise < 0.0) throw std::invalid_argument("odometry model: noise must be >= 0");
}

void DriveLimits::validate() const {
  if (!std::isfinite(max_linear_velocity) || !(max_linear_velocity > 0.0)) {
    throw std::invalid_argument("drive limits: max_linear_velocity must be > 0");
  }
  if (!std::isfinite(max_angular_velocity) || !(max_angular_velocity > 0.0)) {
    throw std::invalid_argument("drive limits: max_angular_velocity must be > 0");
  }
}

std::pair<double, double> measuredMotion(double distance, double turn,
                                         const OdometryErrorModel& model, cv::RNG& rng) {
  double measured_distance = (1.0 + model.scale_error) * distance;
  double measured_turn = turn + model.heading_bias_per_metre * distance;
  if (distance > 0.0) {
    measured_distance += rng.gaussian(model.distance_noise * std::sqrt(distance));
    measured_turn += rng.gaussian(model.heading_noise * std::sqrt(distance));
  }
  return {measured_distance, measured_turn};
}

SynthesizedOdometry::SynthesizedOdometry(const OdometryErrorModel& model, std::uint64_t seed)
    : model_(model), rng_(seed) {
  model_.validate();
}

Pose2D SynthesizedOdometry::add(const Pose2D& truth) {
  if (!started_) {
    started_ = true;
    last_truth_ = truth;
    odometry_ = truth;
    return odometry_;
  }
  const Pose2D increment = last_truth_.inverse().compose(truth);
  last_truth_ = truth;
  const double distance = std::hypot(increment.x, increment.y);
  const auto [measured_distance, measured_turn] =
      measuredMotion(distance, increment.yaw, model_, rng_);
  // The direction of travel in the body frame is kept; its heading error grows with the turn.
  const double stretch = distance > 0.0 ? measured_distance / distance : 0.0;
  odometry_ = odometry_.compose(Pose2D(stretch * increment.x, stretch * increment.y, measured_turn));
  return odometry_;
}

MeasuredVelocity velocityFromOdometry(const Pose2D& previous, const Pose2D& current, double dt,
                                      const OdometryErrorModel& model) {
  MeasuredVelocity velocity;
  if (!(dt > 0.0) || !std::isfinite(dt)) return velocity;
  const Pose2D increment = previous.inverse().compose(current);
  const double distance = std::hypot(increment.x, increment.y);
  velocity.v = (increment.x < 0.0 ? -distance : distance) / dt;
  velocity.w = increment.yaw / dt;
  velocity.covariance(0, 0) = model.distance_noise * model.distance_noise * distance / (dt * dt);
  velocity.covariance(1, 1) = model.heading_noise * model.heading_noise * distance / (dt * dt);
  return velocity;
}

Pose2D integrateArc(const Pose2D& pose, double v, double w, double dt) {
  const double dtheta = w * dt;
  if (std::abs(dtheta) < 1e-9) {
    return Pose2D(pose.x + v * dt * std::cos(pose.yaw + dtheta / 2), pose.y + v * dt * std::sin(pose.yaw + dtheta / 2),
                  wrapToPi(pose.yaw + dtheta));
  }
  const double radius = v / w;
  return Pose2D(pose.x + radius * (std::sin(pose.yaw + dtheta) - std::sin(pose.yaw)),
                pose.y - radius * (std::cos(pose.yaw + dtheta) - std::cos(pose.yaw)), wrapToPi(pose.yaw + dtheta));
}

DifferentialDriveSim::DifferentialDriveSim(const Pose2D& start, const OdometryErrorModel& odometry_errors,
                                           const DriveLimits& limits, std::uint64_t seed)
    : errors_(odometry_errors), limits_(limits), rng_(seed), truth_(start), odometry_(start) {
  errors_.validate();
  limits_.validate();
  if (!std::isfinite(start.x) || !std::isfinite(start.y) || !std::isfinite(start.yaw)) {
    throw std::invalid_argument("differential drive: non-finite start pose");
  }
}

std::pair<double, double> DifferentialDriveSim::step(double v, double w, double dt) {
  if (!std::isfinite(v)) v = 0.0;
  if (!std::isfinite(w)) w = 0.0;
  if (!(dt > 0.0) || !std::isfinite(dt)) return {0.0, 0.0};
  v = std::clamp(v, -limits_.max_linear_velocity, limits_.max_linear_velocity);
  w = std::clamp(w, -limits_.max_angular_velocity, limits_.max_angular_velocity);
  truth_ = integrateArc(truth_, v, w, dt);
  const double distance = std::abs(v * dt);
  distance_ += distance;
  // Odometry: the measured arc (scaled distance, biased and noisy heading change).
  const auto [measured_length, measured_turn] = measuredMotion(distance, w * dt, errors_, rng_);
  const double measured_distance = v < 0.0 ? -measured_length : measured_length;
  // Covariance, first order about the chord at the mid heading: F = ∂pose'/∂pose,
  // G = ∂pose'/∂(distance, turn), Q = the random walk's variances for this step.
  const double mid = odometry_.yaw + 0.5 * measured_turn;
  Eigen::Matrix3d F = Eigen::Matrix3d::Identity();
  F(0, 2) = -measured_distance * std::sin(mid);
  F(1, 2) = measured_distance * std::cos(mid);
  Eigen::Matrix<double, 3, 2> G;
  G << std::cos(mid), -0.5 * measured_distance * std::sin(mid), std::sin(mid), 0.5 * measured_distance * std::cos(mid),
      0.0, 1.0;
  const Eigen::Vector2d q(errors_.distance_noise * errors_.distance_noise * distance,
                          errors_.heading_noise * errors_.heading_noise * distance);
  covariance_ = F * covariance_ * F.transpose() + G * q.asDiagonal() * G.transpose();
  odometry_ = integrateArc(odometry_, measured_distance / dt, measured_turn / dt, dt);
  return {v, w};
}

void DifferentialDriveSim::reset(const Pose2D& truth, const Pose2D& odometry) {
  truth_ = truth;
  odometry_ = odometry;
  distance_ = 0.0;
  covariance_.setZero();
}

}  // namespace homography_teach_repeat
