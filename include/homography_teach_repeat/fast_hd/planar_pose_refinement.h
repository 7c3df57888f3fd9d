// Beyond paper 000: a 3-DoF Gauss-Newton (Levenberg-Marquardt damped) refinement of the planar
// pose (Cx, Cz, θ12) that minimises the symmetric transfer error of the inlier matches of one or
// several planes of known parameters. The DLT fits 8 parameters; the plane being known leaves 3,
// so the refined pose uses the data better (eval_fast_hd: "FastHD_refined").
//
// Model (docs/math.md §1.2): H21(pose) = K T R21 (I − C nᵀ/d) K⁻¹, R21 = Ry(−θ12), C = (Cx, Cy, Cz) with
// the height offset Cy either fixed at 0 or estimated as a nuisance parameter, and T the current
// camera's tilt (identity, or a nuisance pair with a prior, §1.10).
// Cost (RefinementCost):
//  - Sampson (default): per match r = W ε, ε = A_i h the algebraic DLT residual (docs/math.md §3.1),
//    W = (B Bᵀ)^(-1/2), B = ∂ε/∂(u, v, u', v') (§3.4): the first-order geometric distance of the
//    match to the model in the joint image space, i.e. the ML cost for iid pixel noise in both
//    images (on eval_fast_hd's Table I it is as accurate as the symmetric transfer error,
//    mean position error 0.0166 vs 0.0167 m, cheaper, and its covariance is the plain normal
//    equations);
//  - symmetric transfer: p' − π(H p) and p − π(H⁻¹ p'), pixels.
// Covariance: first-order sandwich of the normal equations,
//   Σ = (JᵀJ)⁻¹ (Σ_i J_iᵀ R_i Σ_x R_iᵀ J_i) (JᵀJ)⁻¹,  R_i = ∂r_i/∂(u, v, u', v').
// For Sampson R_i R_iᵀ = I, so this is σ²(JᵀJ)⁻¹; for the symmetric transfer each pixel enters
// both residuals and the plain σ²(JᵀJ)⁻¹ would be optimistic.
#pragma once

#include <Eigen/Core>

#include <utility>
#include <vector>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// Matches of one plane (pixels, undistorted) with the plane's parameters in the reference frame.
struct PlaneMatches {
  ScenePlane plane;
  PointMatches matches;
};

enum class RefinementCost { kSampson, kSymmetricTransfer };

struct PoseRefinementOptions {
  RefinementCost cost = RefinementCost::kSampson;
  int max_iterations = 20;
  double sigma_px = 1.0;  // pixel noise of every coordinate, for the covariance
  // Stop when the step changes the position by less than this [m] and the angle by less than
  // this [rad].
  double convergence_step = 1e-9;
  // Also estimate the camera's height offset Cy between the two images (a nuisance parameter;
  // the covariance returned is the marginal of (Cx, Cz, θ12)). A robot's camera height is
  // constant, but real sequences have small height changes and residual tilt that the 3-DoF
  // model would otherwise absorb into a biased pose (measured on fountain-P11:
  // eval_real_fast_hd, README "Fast-HD on real walls").
  bool estimate_height_offset = true;
  // Also estimate the current camera's tilt relative to the reference camera (pitch about its x
  // axis, roll about its optical axis: a nuisance pair with a zero-mean prior of this std [rad];
  // 0: no tilt). A robot without an IMU levels its images with one constant mount rotation, so
  // the body's pitch and roll on a road (about 1°, ~6 px at f = 360 px) remain in every image and
  // the 3-DoF model reads them as a wrong pose (docs/math.md §1.10).
  double tilt_sigma_rad = 0.0;
  // Also return how the refined pose moves with the plane (RefinedPlanarPose::plane_jacobian; one
  // plane only): what the plane's own uncertainty adds to the covariance (docs/math.md §3.6).
  bool plane_sensitivity = false;
};

struct RefinedPlanarPose {
  PlanarPose pose;
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (Cx, Cz, θ12)
  // The part of `covariance` that the reference image's pixel noise makes (its coordinates u, v
  // alone through the same sandwich): every pose measured against the same reference image shares
  // it, whatever the current image (docs/math.md §3.4). The rest, the current image's noise and the
  // tilt prior, differs from fix to fix.
  Eigen::Matrix3d reference_noise_covariance = Eigen::Matrix3d::Zero();
  double height_offset = 0.0;                             // Cy [m] (0 unless estimated)
  // The current camera's estimated tilt T = Rx(pitch) Rz(roll) (identity unless estimated): the
  // model homography is K T R21 (I − C nᵀ/d) K⁻¹.
  Eigen::Matrix3d tilt = Eigen::Matrix3d::Identity();
  double rms_transfer_error_px = 0.0;  // RMS residual: Sampson distance or transfer error [px]
  int iterations = 0;
  // With PoseRefinementOptions::plane_sensitivity: ∂(Cx, Cz, θ12)/∂(the normal turned towards
  // each of directionsAcrossNormal [rad], the distance [relative]) of the refined pose, the
  // derivative of the minimum with the matches held, −(JᵀJ)⁻¹ ∂(Jᵀr)/∂plane (docs/math.md §3.6).
  Eigen::Matrix3d plane_jacobian = Eigen::Matrix3d::Zero();
};

// The two unit directions across a plane's normal in which its error is modelled (docs/math.md
// §3.6): for a wall, the first horizontal (the wall turned about the vertical), the second the
// wall leaning.
std::pair<Eigen::Vector3d, Eigen::Vector3d> directionsAcrossNormal(const Eigen::Vector3d& normal);

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
