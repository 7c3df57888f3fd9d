// Beyond paper 000: a 3-DoF Gauss-Newton (Levenberg-Marquardt damped) refinement of the planar
// pose (Cx, Cz, θ12) that minimises the symmetric transfer error of the inlier matches of one or
// several planes of known parameters. The DLT fits 8 parameters; the plane being known leaves 3,
// so the refined pose uses the data better (eval_fast_hd: "FastHD_refined").
//
// Model (MATH.md §1.2): H21(pose) = K R21 (I − C nᵀ/d) K⁻¹, R21 = Ry(−θ12).
// Residuals per match: p' − π(H p) and p − π(H⁻¹ p'), pixels.
// Covariance: first-order sandwich of the normal equations,
//   Σ = (JᵀJ)⁻¹ (Σ_i J_iᵀ R_i Σ_x R_iᵀ J_i) (JᵀJ)⁻¹,
// with R_i = ∂r_i/∂(u, v, u', v') (each pixel enters both residuals, so the plain σ²(JᵀJ)⁻¹
// would be optimistic).
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/fast_hd.h"
#include "homography_teach_repeat/homography.h"
#include "homography_teach_repeat/pinhole_camera.h"
#include "homography_teach_repeat/planar_pose.h"
#include "homography_teach_repeat/status.h"

namespace homography_teach_repeat {

// Matches of one plane (pixels, undistorted) with the plane's parameters in the reference frame.
struct PlaneMatches {
  ScenePlane plane;
  PointMatches matches;
};

struct PoseRefinementOptions {
  int max_iterations = 20;
  double sigma_px = 1.0;  // pixel noise of every coordinate, for the covariance
  // Stop when the step changes the position by less than this [m] and the angle by less than
  // this [rad].
  double convergence_step = 1e-9;
};

struct RefinedPlanarPose {
  PlanarPose pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (Cx, Cz, θ12)
  double rms_transfer_error_px = 0.0;                     // over both directions
  int iterations = 0;
};

// Status: kTooFewPoints (< 2 matches in total: 3 parameters, 4 residuals per match),
// kInvalidInput (bad plane, non-finite initial pose or matches, bad options), kDegenerate
// (singular normal equations or a camera on a plane), kNotFinite.
Expected<RefinedPlanarPose> refinePlanarPose(const PlanarPose& initial,
                                             const std::vector<PlaneMatches>& planes,
                                             const PinholeCamera& camera,
                                             const PoseRefinementOptions& options = {});

// The unnormalised model homography of a pose (reference pixels -> current pixels).
Eigen::Matrix3d poseHomography(const PinholeCamera& camera, const PlanarPose& pose,
                               const ScenePlane& plane);

}  // namespace homography_teach_repeat
