// A camera that is not level: its tilt relative to the level camera of the planar-motion model,
// T = Rx(pitch) Rz(roll) (pitch about the camera's x axis, roll about its optical axis;
// docs/math.md §1.10), and T's derivatives with respect to both angles. Shared by the pose
// refinement's tilt nuisance and the teach run's plane-and-tilt estimate (§2.5).
#pragma once

#include <Eigen/Core>

namespace homography_teach_repeat {

struct CameraTilt {
  Eigen::Matrix3d T;          // Rx(pitch) Rz(roll)
  Eigen::Matrix3d dT_dpitch;  // Rx'(pitch) Rz(roll)
  Eigen::Matrix3d dT_droll;   // Rx(pitch) Rz'(roll)
};

CameraTilt cameraTilt(double pitch, double roll);

}  // namespace homography_teach_repeat
