// The numerical Jacobian the localization filter linearizes its measurement models with
// (docs/math.md §7): ∂f/∂(x, y, yaw) of a scalar function f(pose) -> Expected<double> of the
// robot's route-frame pose, by central differences. The first failing evaluation's status is
// returned.
#pragma once

#include <Eigen/Core>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

// ∂f/∂(x, y, yaw) of a scalar function of the robot pose by central differences (1e-5 m, 1e-6 rad):
// the measurement models are smooth and six evaluations cost microseconds.
template <typename Measurement>
Expected<Eigen::RowVector3d> poseJacobian(const Pose2D& at, const Measurement& measure) {
  Eigen::RowVector3d jacobian;
  const double steps[3] = {1e-5, 1e-5, 1e-6};
  for (int i = 0; i < 3; ++i) {
    Pose2D plus = at, minus = at;
    (i == 0 ? plus.x : i == 1 ? plus.y : plus.yaw) += steps[i];
    (i == 0 ? minus.x : i == 1 ? minus.y : minus.yaw) -= steps[i];
    const Expected<double> value_plus = measure(plus), value_minus = measure(minus);
    if (!value_plus) return value_plus.status();
    if (!value_minus) return value_minus.status();
    jacobian(i) = (*value_plus - *value_minus) / (2.0 * steps[i]);
  }
  return jacobian;
}

}  // namespace homography_teach_repeat
