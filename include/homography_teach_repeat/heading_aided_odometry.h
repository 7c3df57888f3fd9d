// The robot pose of the μ mode (paper 002 §5): odometry for the position, vision for the heading.
// Odometry drifts mostly through its heading (wheel slip, unequal wheel radii), and a heading error
// turns into a growing lateral error; the μ mode measures the heading against the reference
// keyframe, so the odometry is re-aligned to it at every visual fix and only the odometry's
// short-range error remains. The pose lives in the route frame (the teach run's odometry frame):
//   route_pose = alignment ∘ odom_pose,
// where `alignment` (the map -> odom transform) starts from the keyframe the robot is placed at and
// is re-solved at each heading fix as a rotation about the robot's position at the fix stamp (so
// the position is continuous and only the heading jumps to the measured one).
//
// The covariance is a model, not a measurement (documented in the README): the position is a
// random walk of the odometry, `position_variance_per_metre` per metre travelled since the start;
// the heading has `heading_fix_variance` at a fix and grows by `heading_variance_per_metre` per
// metre since the last fix. x and y are uncorrelated with each other and with the heading.
#pragma once

#include <Eigen/Core>

#include <optional>

#include "homography_teach_repeat/planar_pose.h"
#include "homography_teach_repeat/status.h"

namespace homography_teach_repeat {

struct HeadingAidedOdometryOptions {
  double position_variance_per_metre = 0.0025;        // [m²/m] (5 cm after 1 m)
  double heading_fix_variance = 7.6e-5;                // [rad²] ((0.5°)²)
  double heading_variance_per_metre = 3.0e-4;          // [rad²/m] (1° after 1 m)
  // Fraction of the measured heading error applied at a fix, (0, 1]: 1 trusts each fix fully,
  // smaller values low-pass noisy fixes.
  double correction_gain = 1.0;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

class HeadingAidedOdometry {
 public:
  // Throws std::invalid_argument on invalid options.
  explicit HeadingAidedOdometry(const HeadingAidedOdometryOptions& options = {});

  // The robot is at `route_pose` while its odometry reads `odom_pose`. kInvalidInput on
  // non-finite input.
  Status align(const Pose2D& route_pose, const Pose2D& odom_pose);
  bool aligned() const { return aligned_; }

  // A visual heading fix: the robot's yaw in the route frame was `route_yaw` when its odometry
  // read `odom_pose`. kInvalidInput on non-finite input, kNoConsensus when not aligned yet.
  Status correctHeading(double route_yaw, const Pose2D& odom_pose);

  // The robot pose in the route frame for the odometry reading `odom_pose`, and its (x, y, yaw)
  // covariance. kNoConsensus when not aligned, kInvalidInput on non-finite input.
  Expected<Pose2D> routePose(const Pose2D& odom_pose);
  Eigen::Matrix3d covariance() const;
  // Odometry distance [m] travelled since the last heading fix (or the alignment).
  double distanceSinceFix() const { return distance_since_fix_; }

  // The map -> odom transform (route frame -> odometry frame).
  const Pose2D& alignment() const { return alignment_; }

 private:
  void accumulateDistance(const Pose2D& odom_pose);

  HeadingAidedOdometryOptions options_;
  bool aligned_ = false;
  Pose2D alignment_;
  std::optional<Pose2D> last_odom_;
  double distance_since_start_ = 0.0;  // [m]
  double distance_since_fix_ = 0.0;    // [m]
  bool has_fix_ = false;
};

}  // namespace homography_teach_repeat
