// First-order covariance of the Fast-HD pose from the pixel noise of the matches (MATH.md §3.4):
//   Σ_s = J_g J_h Σ_x J_hᵀ J_gᵀ,
// J_h (9 x 4n): Jacobian of the Hartley-normalised DLT, J_h = (T2⁻¹ ⊗ T1ᵀ)(−Â⁺ B̂) diag(s1,s1,s2,s2…);
// J_g (3 x 9): Jacobian of Fast-HD (κ normalisation, b of corrected eq. 4, Π⁻¹, atan2, pose map).
// The paper's printed recipe under-predicts the std by 350-1200x (MATH.md §3.5); this one was
// checked by Monte Carlo (eval_fast_hd "covariance").
//
// Pose order everywhere: (Cx, Cz, θ12) of the current camera in the reference camera frame
// (MATH.md §1.6), metres and radians. Match coordinates order: (u, v, u', v') per match.
#pragma once

#include <Eigen/Core>

#include "homography_teach_repeat/fast_hd.h"
#include "homography_teach_repeat/homography.h"
#include "homography_teach_repeat/pinhole_camera.h"
#include "homography_teach_repeat/status.h"

namespace homography_teach_repeat {

using Matrix39d = Eigen::Matrix<double, 3, 9>;

// J_g of MATH.md §3.4 step 2, evaluated at H (any scale; the result scales as 1/scale, so use the
// H that the DLT Jacobian refers to). Fails like solveFastHd.
Expected<Matrix39d> fastHdJacobian(const Eigen::Matrix3d& H, const PinholeCamera& camera,
                                   const ScenePlane& plane);

// J_h of MATH.md §3.4 step 1 (9 x 4n), the derivative of vec(dlt.H_unscaled) (row-major) with
// respect to the match coordinates. The matches must be those the DLT was solved from.
Eigen::MatrixXd normalizedDltJacobian(const NormalizedDlt& dlt, const PointMatches& matches);

// Covariance of (Cx, Cz, θ12) for iid Gaussian noise of standard deviation sigma_px on every
// coordinate of every match (both images). O(n) with fixed-size products: J_h is never formed.
// Status: kInvalidInput (sigma not finite or < 0, match count differs from the DLT's), or the
// failures of solveFastHd.
Expected<Eigen::Matrix3d> fastHdCovariance(const NormalizedDlt& dlt, const PointMatches& matches,
                                           const PinholeCamera& camera, const ScenePlane& plane,
                                           double sigma_px);

}  // namespace homography_teach_repeat
