// The 1D trifocal tensor of three planar views (paper 003; docs/math.md §5).
//
// Top view of a planar motion: a landmark x = (X, Z, 1)ᵀ (X right, Z forward in the first
// camera) is seen by view k as the bearing u ∝ M_k x, u = (sin α, cos α)ᵀ with α measured from
// the optical axis (+Z) towards +X. M = [I | 0], M' = [R(θ') | t'], M'' = [R(θ'') | t''],
// R(θ) = [[cos θ, sin θ], [−sin θ, cos θ]] (X_k = R X_1 + t; θ > 0 turns the camera towards −X,
// i.e. to the left) — docs/math.md §5.1, with the printed R'' typo corrected.
// The tensor T = (T111, T112, T121, T122, T211, T212, T221, T222) satisfies the trilinear
// constraint Σ T_ijk u_i u'_j u''_k = 0 (eq. 2) for every landmark seen in the three views.
//
// Estimators (bearings must be calibrated, i.e. in the metric frame of each camera):
//  - TT7 (eq. 3): ≥ 7 triplets, SVD null vector of the 8-column system;
//  - TT5 (eq. 7): ≥ 5 triplets, the two calibration constraints of eq. 6 eliminate T221, T222;
//  - TT4 (eqs. 9-12): 1D homographies H', H'' of a plane (a wall: ≥ 3 triplets on it) give the
//    four constraints of eq. 12; with eq. 6 and one triplet off the plane, a 7x8 system.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

using Bearing = Eigen::Vector2d;                 // (sin α, cos α), or any positive multiple
using TrifocalTensor1d = Eigen::Matrix<double, 8, 1>;

// Index of T_ijk (1-based i, j, k) in TrifocalTensor1d: 4(i−1) + 2(j−1) + (k−1).
constexpr int tensorIndex(int i, int j, int k) { return 4 * (i - 1) + 2 * (j - 1) + (k - 1); }

// One landmark seen in the three views.
struct BearingTriplet {
  Bearing first;   // u   (view 1, the reference frame)
  Bearing second;  // u'  (view 2)
  Bearing third;   // u'' (view 3)
};

// Bearing of an angle α [rad] from the optical axis towards +X (an omnidirectional image).
Bearing bearingFromAngle(double alpha);
// Bearing of the image column x [px] of a conventional camera with focal length f [px] and
// principal point u0 [px] (after undistortion): (x − u0, f), normalised. docs/math.md §5.2 eq. 4:
// u^p = K u^c, K = [[f, u0], [0, 1]].
Bearing bearingFromPixel(double x, double f, double u0);
// Angle of a bearing, atan2(u1, u2).
double bearingAngle(const Bearing& u);

// Eq. 4: the calibrated tensor of a tensor estimated from pixel "bearings" (x, 1):
// T^c_lmn = Σ_ijk T^p_ijk K(i,l) K(j,m) K(k,n). The calibration constraints (eq. 6) hold only for
// calibrated tensors.
TrifocalTensor1d calibrateTensor(const TrifocalTensor1d& pixel_tensor, double f, double u0);

// The two calibration constraints of eq. 6 (0 for a calibrated tensor):
// (−T111 + T122 + T212 + T221, T112 + T121 + T211 − T222).
Eigen::Vector2d calibrationResidual(const TrifocalTensor1d& T);

// Σ T_ijk u_i u'_j u''_k for unit bearings and a unit-norm tensor (0 for an exact triplet).
double trilinearResidual(const TrifocalTensor1d& T, const BearingTriplet& triplet);

// Transfer (docs/math.md §5.4, eq. 8 corrected): the bearing of view `view` (1, 2 or 3) predicted from
// the other two; the angular error between the predicted and the measured bearing [rad], modulo π
// (projective sign). transferError: the largest of the three views' errors.
Bearing transferBearing(const TrifocalTensor1d& T, const BearingTriplet& triplet, int view);
double transferAngleError(const TrifocalTensor1d& T, const BearingTriplet& triplet, int view);
double transferError(const TrifocalTensor1d& T, const BearingTriplet& triplet);
// transferError(T, triplet) < threshold for a threshold in (0, π/2), without trigonometry: the
// sine of each view's angle against sin(threshold) (RANSAC's inner loop; 3x faster).
bool transferErrorBelow(const TrifocalTensor1d& T, const BearingTriplet& triplet, double threshold);

// Status of every estimator: kTooFewPoints (fewer triplets than the method needs), kInvalidInput
// (a non-finite or zero bearing), kDegenerate (the system's null space has more than one
// dimension: e.g. identical views or coincident camera centres, all landmarks on one bearing).
// The tensor has unit norm.
Expected<TrifocalTensor1d> estimateTT7(const std::vector<BearingTriplet>& triplets);
Expected<TrifocalTensor1d> estimateTT5(const std::vector<BearingTriplet>& triplets);

// 1D homography between bearings of a plane (a wall's trace): u' ∝ H u, from ≥ 3 pairs, row
// (−u'2 u1, −u'2 u2, u'1 u1, u'1 u2)·(H11, H12, H21, H22) = 0 (docs/math.md §5.5). Unit norm.
// kTooFewPoints, kInvalidInput, kDegenerate (fewer than 3 distinct bearings).
Expected<Eigen::Matrix2d> estimateBearingHomography(const std::vector<Bearing>& from,
                                                    const std::vector<Bearing>& to);
// Angle between H u and u' modulo π [rad].
double bearingHomographyError(const Eigen::Matrix2d& H, const Bearing& from, const Bearing& to);

// TT4: the plane's 1D homographies from view 1 to view 2 (H') and to view 3 (H''), and ≥ 1
// triplets off the plane. One off-plane triplet: eqs. 12 + 6 + its trilinear row (7x8 system);
// more are used in least squares. Status as above, kTooFewPoints without an off-plane triplet.
Expected<TrifocalTensor1d> estimateTT4(const Eigen::Matrix2d& H_second, const Eigen::Matrix2d& H_third,
                                       const std::vector<BearingTriplet>& off_plane);
// TT4 from the bearings directly: ≥ 3 triplets on the plane (both homographies) + ≥ 1 off it; the
// plane's triplets also add their trilinear rows (least squares over every match), and the four
// plane rows are weighted by the bearing noise propagated through the homographies (first order,
// against the trilinear rows' mean; a second solve at the first solution) — unit weights let
// poorly conditioned plane rows outvote the matches in forward motion (eval_trifocal, MovB).
Expected<TrifocalTensor1d> estimateTT4(const std::vector<BearingTriplet>& on_plane,
                                       const std::vector<BearingTriplet>& off_plane);

}  // namespace homography_teach_repeat
