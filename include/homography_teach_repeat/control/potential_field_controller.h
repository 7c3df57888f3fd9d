// The potential-field controller of paper 002 §5.1 (from its reference [15]) for a differential
// base. Velocity state x = (v, w) [m/s, rad/s] with the dynamics of eq. (3):
//   ẋ = −2b [[1, 0], [0, k_i]] x + F [[1, 0], [0, k_i h]] (cosψ, sinψ)ᵀ
// b viscous friction [1/s], k_i = m/I_zz [1/m²], h lever of the force [m], F the magnitude and ψ
// the direction (robot frame, CCW from forward) of the total force: the attraction towards the
// current goal plus the repulsion of the nearest obstacle point. The visual heading correction enters through ψ
// (the paper corrects the force direction, not the robot's orientation estimate).
// Integration is exact for piecewise-constant force over a step (a linear ODE), then the
// acceleration and velocity limits of the base are applied.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct PotentialFieldParameters {
  double viscous_friction = 1.0;      // b [1/s]
  double inertia_ratio = 2.0;         // k_i = m / I_zz [1/m²]
  double lever = 0.4;                 // h [m]
  double attractive_gain = 1.0;       // F = gain · min(distance, saturation) [m/s² per m]
  double attraction_saturation = 1.0;  // [m]
  double repulsive_gain = 0.2;        // [m³/s²] of the nearest obstacle point's repulsion
  double repulsive_range = 0.8;       // obstacles farther than this are ignored [m]
  double max_linear_velocity = 0.5;   // [m/s]
  double max_angular_velocity = 1.0;  // [rad/s]
  double max_linear_acceleration = 0.6;   // [m/s²]
  double max_angular_acceleration = 2.0;  // [rad/s²]
  bool allow_reverse = false;         // a differential base may back up; the paper's does not
  double goal_tolerance = 0.7;        // ε [m] (paper 002: 0.7 m)
  double goal_heading_tolerance = 0.349;  // δ [rad] (paper 002: 20°)

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct VelocityCommand {
  double linear = 0.0;   // [m/s]
  double angular = 0.0;  // [rad/s]
};

// Direction ψ of the goal in the robot frame: the bearing computed from the pose estimate, minus
// `heading_offset` (how far the robot's true heading is CCW of the estimate, e.g. from vision).
double goalBearing(const Pose2D& robot, const Pose2D& goal, double heading_offset = 0.0);

// The goal test of paper 002 Fig. 8: distance < ε and |heading difference| < δ.
bool goalReached(const Pose2D& robot, const Pose2D& goal, const PotentialFieldParameters& p);

class PotentialFieldController {
 public:
  explicit PotentialFieldController(const PotentialFieldParameters& parameters);

  // One control step of `dt` seconds towards a goal at `goal_distance` [m] in direction
  // `goal_bearing` [rad, robot frame], with obstacle points in the robot frame [m].
  // Status kInvalidInput (and the state reset to rest) on a non-finite input or dt <= 0.
  Expected<VelocityCommand> step(double goal_distance, double goal_bearing,
                                 const std::vector<Eigen::Vector2d>& obstacles, double dt);

  // Drives towards the target velocities (v, w) within the base's acceleration and velocity
  // limits over `dt` (the final approach and heading alignment of route_follower.h); the state
  // stays continuous with step(). kInvalidInput (state reset to rest) on a non-finite input.
  Expected<VelocityCommand> track(double linear, double angular, double dt);

  // Caps the forward velocity at `max_linear` [m/s, >= 0] at once (something in the way: a
  // safety limit, not bound by the deceleration limit), keeping the state continuous.
  VelocityCommand capLinearVelocity(double max_linear);

  // Back to rest (v = w = 0), e.g. when localization is lost.
  void reset() { state_ = VelocityCommand(); }
  const VelocityCommand& state() const { return state_; }
  const PotentialFieldParameters& parameters() const { return parameters_; }
  void setParameters(const PotentialFieldParameters& parameters);  // validates

 private:
  VelocityCommand limit(double linear, double angular, double dt);

  PotentialFieldParameters parameters_;
  VelocityCommand state_;
};

}  // namespace homography_teach_repeat
