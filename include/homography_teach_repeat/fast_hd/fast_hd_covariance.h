// First-order covariance of the Fast-HD pose from the pixel noise of the matches (docs/math.md §3.4):
//   Σ_s = J_g J_h Σ_x J_hᵀ J_gᵀ,
// J_h (9 x 4n): Jacobian of the Hartley-normalised DLT, J_h = (T2⁻¹ ⊗ T1ᵀ)(−Â⁺ B̂) diag(s1,s1,s2,s2…);
// J_g (3 x 9): Jacobian of Fast-HD (κ normalisation, b of corrected eq. 4, Π⁻¹, atan2, pose map).
// The paper's printed recipe under-predicts the std by 350-1200x (docs/math.md §3.5); this one was
// checked by Monte Carlo (eval_fast_hd "covariance").
//
// Pose order everywhere: (Cx, Cz, θ12) of the current camera in the reference camera frame
// (docs/math.md §1.6), metres and radians. Match coordinates order: (u, v, u', v') per match.
#pragma once

#include <Eigen/Core>

#include <array>

#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

using Matrix39d = Eigen::Matrix<double, 3, 9>;

// J_g of docs/math.md §3.4 step 2, evaluated at H (any scale; the result scales as 1/scale, so use the
// H that the DLT Jacobian refers to). Fails like solveFastHd.
Expected<Matrix39d> fastHdJacobian(const Eigen::Matrix3d& H, const PinholeCamera& camera,
                                   const ScenePlane& plane);

// The last step of Fast-HD, the pose map g: s* = (x21, z21, S, C) -> (Cx, Cz, θ12) with
// θ21 = atan2(S, C) (docs/math.md §1.4, §1.6): its Jacobian (3x4) and the Hessians of its three
// components (4x4 each), at a solution.
Eigen::Matrix<double, 3, 4> fastHdPoseMapJacobian(const FastHdSolution& solution);
std::array<Eigen::Matrix4d, 3> fastHdPoseMapHessians(const FastHdSolution& solution);

// J_h of docs/math.md §3.4 step 1 (9 x 4n), the derivative of vec(dlt.H_unscaled) (row-major) with
// respect to the match coordinates. The matches must be those the DLT was solved from.
Eigen::MatrixXd normalizedDltJacobian(const NormalizedDlt& dlt, const PointMatches& matches);

// Covariance of (Cx, Cz, θ12) for iid Gaussian noise of standard deviation sigma_px on every
// coordinate of every match (both images). O(n) with fixed-size products: J_h is never formed.
// The first-order part is docs/math.md §3.4 exactly. With `second_order` (default) the curvature of
// the last step, the map s* = (x21, z21, S, C) -> (Cx, Cz, θ12) (atan2 and the rotation of t21),
// adds ½ tr(G_i Σ_s G_j Σ_s) (G_i its Hessians, Σ_s the first-order covariance of s*, which is
// linear in the data to first order): when the position std is a sizeable fraction of the
// baseline the first-order covariance is over-confident along its weakest directions (measured
// in eval_fast_hd: scene B at 1 px, NEES 3.57 first-order, 3.1 with the term; scene A unchanged).
// With `reference_noise_covariance`: the first-order part of it that the reference image's
// coordinates (u, v) alone make, shared by every pose measured against the same reference image.
// Status: kInvalidInput (sigma not finite or < 0, match count differs from the DLT's), or the
// failures of solveFastHd.
Expected<Eigen::Matrix3d> fastHdCovariance(const NormalizedDlt& dlt, const PointMatches& matches,
                                           const PinholeCamera& camera, const ScenePlane& plane,
                                           double sigma_px, bool second_order = true,
                                           Eigen::Matrix3d* reference_noise_covariance = nullptr);

}  // namespace homography_teach_repeat
