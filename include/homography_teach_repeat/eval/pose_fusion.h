// Fusion of independent planar pose estimates (e.g. Fast-HD on each visible plane: the planes'
// matches are disjoint, so their errors are independent to first order) by covariance
// weighting: Σ = (Σ_i Σ_i⁻¹)⁻¹, x = Σ Σ_i Σ_i⁻¹ x_i. Angles are unwrapped around the first
// estimate before averaging and the result is wrapped to (−π, π].
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// A planar pose (Cx, Cz, θ12 or x, y, yaw: any consistent order) with its 3x3 covariance.
struct PoseWithCovariance {
  PlanarPose pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Identity();
};

// Status: kInvalidInput (no estimate, a non-finite pose or covariance, or a covariance that is
// not symmetric positive definite).
Expected<PoseWithCovariance> fusePoseEstimates(const std::vector<PoseWithCovariance>& estimates);

}  // namespace homography_teach_repeat
