// A differential-drive base for the simulator: the true pose integrated exactly along arcs from
// (v, w) commands within the base's limits, and wheel odometry with the errors that make
// odometry-only repeat fail (paper 002: > 4 m after 5 laps): a scale error of the travelled
// distance, a heading bias per metre (unequal wheel radii), and random walk noise.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cstdint>
#include <utility>

#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

struct OdometryErrorModel {
  double scale_error = 0.0;             // measured distance = (1 + scale_error) * true distance
  double heading_bias_per_metre = 0.0;  // [rad/m] yaw error added per metre travelled (CCW +)
  double distance_noise = 0.0;          // [m/sqrt(m)] random walk of the distance
  double heading_noise = 0.0;           // [rad/sqrt(m)] random walk of the yaw

  void validate() const;  // throws std::invalid_argument naming the bad field
};

// What the odometry measures of a motion that covered `distance` [m] (>= 0) and turned `turn`
// [rad]: (measured distance, measured turn) under `model`, its noise drawn from `rng`. The one
// error model of the simulator's base and of the odometry evaluate_sequence synthesizes for data
// sets without wheel odometry.
std::pair<double, double> measuredMotion(double distance, double turn,
                                         const OdometryErrorModel& model, cv::RNG& rng);

// Odometry synthesized from ground-truth poses (data sets without wheel odometry, e.g. KITTI):
// each increment between consecutive truths, in the body frame of the previous one, is measured
// through measuredMotion (its direction kept, its length and turn corrupted) and integrated.
class SynthesizedOdometry {
 public:
  // Throws std::invalid_argument on an invalid model.
  SynthesizedOdometry(const OdometryErrorModel& model, std::uint64_t seed);
  // The odometry pose for the next ground-truth pose (the first is returned unchanged).
  Pose2D add(const Pose2D& truth);

 private:
  OdometryErrorModel model_;
  cv::RNG rng_;
  bool started_ = false;
  Pose2D last_truth_;
  Pose2D odometry_;
};

struct DriveLimits {
  double max_linear_velocity = 1.0;   // [m/s] > 0
  double max_angular_velocity = 2.0;  // [rad/s] > 0

  void validate() const;
};

// The base's velocity over an interval as its odometry reports it: the increment from `previous`
// to `current` (odometry poses) in the body frame over `dt` [s] (forward speed signed by the
// direction of travel, yaw rate), and its covariance over (v, w) from the model's random walk
// (distance_noise² |Δs| / dt², heading_noise² |Δs| / dt²). dt must be > 0.
struct MeasuredVelocity {
  double v = 0.0;
  double w = 0.0;
  Eigen::Matrix2d covariance = Eigen::Matrix2d::Zero();
};
MeasuredVelocity velocityFromOdometry(const Pose2D& previous, const Pose2D& current, double dt,
                                      const OdometryErrorModel& model);

// Exact pose after driving (v, w) for dt from `pose` (a straight line when w is ~0).
Pose2D integrateArc(const Pose2D& pose, double v, double w, double dt);

class DifferentialDriveSim {
 public:
  // Throws std::invalid_argument on invalid models or a non-finite start.
  DifferentialDriveSim(const Pose2D& start, const OdometryErrorModel& odometry_errors,
                       const DriveLimits& limits, std::uint64_t seed = 1);

  // One step with the commanded velocities (clamped to the limits; non-finite commands are
  // treated as zero). Returns the velocities actually applied.
  std::pair<double, double> step(double v, double w, double dt);

  const Pose2D& truth() const { return truth_; }
  const Pose2D& odometry() const { return odometry_; }
  double distanceTravelled() const { return distance_; }
  // The odometry pose's covariance over (x, y, yaw) in the odometry frame, propagated step by step
  // from the model's random walk (distance_noise² and heading_noise² per metre travelled; first
  // order along the arc). The scale error and heading bias are a calibration the base does not
  // know about and are not in it, as on a real base (docs/simulator.md).
  const Eigen::Matrix3d& odometryCovariance() const { return covariance_; }
  // Teleport (tests, resets): truth and odometry to the given poses.
  void reset(const Pose2D& truth, const Pose2D& odometry);
  // Carried elsewhere (a kidnapping): the truth moves, the odometry does not notice.
  void teleport(const Pose2D& truth) { truth_ = truth; }

 private:
  OdometryErrorModel errors_;
  DriveLimits limits_;
  cv::RNG rng_;
  Pose2D truth_;
  Pose2D odometry_;
  double distance_ = 0.0;
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Zero();
};

}  // namespace homography_teach_repeat
