#include "homography_teach_repeat/control/potential_field_controller.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {
namespace {

void requirePositive(double value, const char* name) {
  if (!std::isfinite(value) || !(value > 0.0)) {
    throw std::invalid_argument(std::string("controller: ") + name + " must be finite and > 0, got " +
                                std::to_string(value));
  }
}

// x(t+dt) for ẋ = −a x + u with u constant: x e^{−a dt} + u (1 − e^{−a dt}) / a.
double exactStep(double x, double a, double u, double dt) {
  const double decay = std::exp(-a * dt);
  return x * decay + u * (1.0 - decay) / a;
}

double clampChange(double target, double current, double max_rate, double dt) {
  return current + std::clamp(target - current, -max_rate * dt, max_rate * dt);
}

}  // namespace

void PotentialFieldParameters::validate() const {
  requirePositive(viscous_friction, "viscous_friction");
  requirePositive(inertia_ratio, "inertia_ratio");
  requirePositive(lever, "lever");
  requirePositive(attractive_gain, "attractive_gain");
  requirePositive(attraction_saturation, "attraction_saturation");
  if (!std::isfinite(repulsive_gain) || repulsive_gain < 0.0) {
    throw std::invalid_argument("controller: repulsive_gain must be finite and >= 0");
  }
  requirePositive(repulsive_range, "repulsive_range");
  requirePositive(max_linear_velocity, "max_linear_velocity");
  requirePositive(max_angular_velocity, "max_angular_velocity");
  requirePositive(max_linear_acceleration, "max_linear_acceleration");
  requirePositive(max_angular_acceleration, "max_angular_acceleration");
  requirePositive(goal_tolerance, "goal_tolerance");
  if (!(goal_heading_tolerance > 0.0 && goal_heading_tolerance <= M_PI)) {
    throw std::invalid_argument("controller: goal_heading_tolerance must be in (0, pi]");
  }
}

double goalBearing(const Pose2D& robot, const Pose2D& goal, double heading_offset) {
  return wrapToPi(std::atan2(goal.y - robot.y, goal.x - robot.x) - robot.yaw - heading_offset);
}

bool goalReached(const Pose2D& robot, const Pose2D& goal, const PotentialFieldParameters& p) {
  return std::hypot(goal.x - robot.x, goal.y - robot.y) < p.goal_tolerance &&
         std::abs(wrapToPi(goal.yaw - robot.yaw)) < p.goal_heading_tolerance;
}

PotentialFieldController::PotentialFieldController(const PotentialFieldParameters& parameters)
    : parameters_(parameters) {
  parameters_.validate();
}

void PotentialFieldController::setParameters(const PotentialFieldParameters& parameters) {
  parameters.validate();
  parameters_ = parameters;
}

Expected<VelocityCommand> PotentialFieldController::step(
    double goal_distance, double goal_bearing, const std::vector<Eigen::Vector2d>& obstacles,
    double dt) {
  bool finite = std::isfinite(goal_distance) && goal_distance >= 0.0 &&
                std::isfinite(goal_bearing) && std::isfinite(dt) && dt > 0.0;
  for (const auto& o : obstacles) finite = finite && o.allFinite();
  if (!finite) {
    reset();
    return Status(StatusCode::kInvalidInput,
                  "controller input is not finite (or dt <= 0): commanding zero velocity");
  }
  const PotentialFieldParameters& p = parameters_;
  // Attraction towards the goal, saturated so that far goals do not demand unbounded force.
  Eigen::Vector2d force = p.attractive_gain * std::min(goal_distance, p.attraction_saturation) *
                          Eigen::Vector2d(std::cos(goal_bearing), std::sin(goal_bearing));
  // Repulsion (1/r − 1/r0)/r² away from the nearest obstacle point within range (Khatib's
  // repulsion from the closest point). Summed over every scan point it grew with the scanner's
  // resolution: a person 0.45 m beside the path, ~60 beams of a 1° scanner, pushed 60 times as
  // hard as a post and held the robot still for good (the people_in_the_way rostest).
  const Eigen::Vector2d* nearest = nullptr;
  for (const auto& o : obstacles) {
    const double r = o.norm();
    if (r >= p.repulsive_range || r < 1e-3) continue;
    if (nearest == nullptr || r < nearest->norm()) nearest = &o;
  }
  if (nearest != nullptr) {
    const double r = nearest->norm();
    force -= p.repulsive_gain * (1.0 / r - 1.0 / p.repulsive_range) / (r * r) * (*nearest / r);
  }
  const double magnitude = force.norm();
  const double psi = magnitude > 0.0 ? std::atan2(force.y(), force.x()) : 0.0;
  // Eq. (3), exact over dt: v' = −2b v + F cosψ, w' = −2b k_i w + F k_i h sinψ.
  const double two_b = 2.0 * p.viscous_friction;
  double v = exactStep(state_.linear, two_b, magnitude * std::cos(psi), dt);
  double w = exactStep(state_.angular, two_b * p.inertia_ratio,
                       magnitude * p.inertia_ratio * p.lever * std::sin(psi), dt);
  return limit(v, w, dt);
}

Expected<VelocityCommand> PotentialFieldController::track(double linear, double angular, double dt) {
  if (!std::isfinite(linear) || !std::isfinite(angular) || !std::isfinite(dt) || !(dt > 0.0)) {
    reset();
    return Status(StatusCode::kInvalidInput,
                  "velocity target is not finite (or dt <= 0): commanding zero velocity");
  }
  return limit(linear, angular, dt);
}

VelocityCommand PotentialFieldController::capLinearVelocity(double max_linear) {
  state_.linear = std::min(state_.linear, std::max(0.0, max_linear));
  return state_;
}

VelocityCommand PotentialFieldController::limit(double linear, double angular, double dt) {
  const PotentialFieldParameters& p = parameters_;
  // Limits of the base: acceleration, then velocity.
  double v = clampChange(linear, state_.linear, p.max_linear_acceleration, dt);
  double w = clampChange(angular, state_.angular, p.max_angular_acceleration, dt);
  v = std::clamp(v, p.allow_reverse ? -p.max_linear_velocity : 0.0, p.max_linear_velocity);
  w = std::clamp(w, -p.max_angular_velocity, p.max_angular_velocity);
  state_.linear = v;
  state_.angular = w;
  return state_;
}

}  // namespace homography_teach_repeat
