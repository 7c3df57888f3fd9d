// Is a published pose covariance honest? Scores pose estimates against ground truth by the
// normalised estimation error squared (NEES, Bar-Shalom, Li & Kirubarajan 2001, §5.4):
// e^T P^-1 e with e = (x, y, yaw) estimate minus truth and P the published 3x3 covariance of
// (x, y, yaw). For a consistent estimator the NEES is chi-square with 3 degrees of freedom: mean 3
// and 5 % of the samples above 7.81. A mean far above 3 is an overconfident covariance (a
// controller or a fusion filter would trust the pose more than it deserves); far below,
// an overcautious one. Used by evaluate_demo_run (scripts/demo) on the repeat_node's pose.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <vector>

#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// The 95 % quantile of chi-square with 3 degrees of freedom.
constexpr double kChiSquare3Dof95 = 7.814727903251178;

struct PoseConsistencySummary {
  std::size_t samples = 0;
  double position_error_rms = 0.0;  // [m]
  double heading_error_rms = 0.0;   // [rad]
  double position_sigma_rms = 0.0;  // [m] sqrt(mean(var_x + var_y)): the spread the pose claimed
  double heading_sigma_rms = 0.0;   // [rad] sqrt(mean(var_yaw))
  double nees_mean = 0.0;           // consistent: 3
  double nees_median = 0.0;         // consistent: 2.37
  double fraction_above_chi2_95 = 0.0;  // consistent: 0.05
};

// The NEES of one estimate (e = estimate − truth, yaw wrapped); kInvalidInput for a non-finite pose or
// covariance or one that is not symmetric positive definite.
Expected<double> normalizedEstimationErrorSquared(const Pose2D& estimate, const Eigen::Matrix3d& covariance,
                                                  const Pose2D& truth);

class PoseConsistency {
 public:
  // `covariance`: of (x, y, yaw) in the frame of the poses. kInvalidInput (the sample is not
  // counted) for a non-finite pose or covariance, or a covariance that is not symmetric positive
  // definite: such a pose cannot be scored, and its count is in rejected().
  Status add(const Pose2D& estimate, const Eigen::Matrix3d& covariance, const Pose2D& truth);

  // kTooFewPoints without a sample.
  Expected<PoseConsistencySummary> summary() const;
  std::size_t rejected() const { return rejected_; }

 private:
  struct Sample {
    double position_error_squared;
    double heading_error_squared;
    double position_variance;
    double heading_variance;
    double nees;
  };
  std::vector<Sample> samples_;
  std::size_t rejected_ = 0;
};

// Does the integrity flag say when a pose is wrong? Each published pose, flagged (DEGRADED or LOST)
// or not, against its error from the ground truth: a pose more than `wrong_position` [m] or
// `wrong_heading` [rad] off is wrong. A useful monitor flags nearly every wrong pose (detection)
// and few right ones (false alarms) (docs/reliability.md, "Integrity").
struct IntegritySummary {
  std::size_t poses = 0, wrong = 0, wrong_flagged = 0, right = 0, right_flagged = 0;
  double detection = 0.0;    // wrong_flagged / wrong (1 when no pose is wrong)
  double false_alarm = 0.0;  // right_flagged / right (0 when no pose is right)
};

class IntegrityScore {
 public:
  explicit IntegrityScore(double wrong_position = 0.3, double wrong_heading = 5.0 * 3.14159265358979323846 / 180.0)
      : wrong_position_(wrong_position), wrong_heading_(wrong_heading) {}
  // kInvalidInput (not counted) for a non-finite pose.
  Status add(const Pose2D& estimate, bool flagged, const Pose2D& truth);
  IntegritySummary summary() const;

 private:
  double wrong_position_, wrong_heading_;
  IntegritySummary counts_;
};

}  // namespace homography_teach_repeat
