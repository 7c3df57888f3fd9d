// Heading from a 1D homography of vertical lines (paper 002 §3, docs/math.md §4.4-4.7). Conventions
// (docs/math.md §4.1): top view (x, z), X2 = R X1 + t, R = [[cosθ, sinθ], [−sinθ, cosθ]]; θ > 0 turns
// the camera towards −x (left), the same sign as PlanarPose::theta (θ12). Image x = f X/Z + x0.
// H maps reference x to current x (pixels, any scale).
//
//  - μ = h12/h22 of the centred H (x ← x − x0) = f tanθ for a pure rotation; with translation
//    μ = f (d sinθ + tx cosφ)/(d cosθ + tz cosφ): lateral translation over-rotates, which is what
//    steers a robot back onto its path (paper 002 §3.2, Fig. 4).
//  - t = h21/h22 = −tanθ/f (pure rotation).
//  - eigenvalues: |θ| = acos(tr H / (2 √det H)) after h22 > 0, det H > 0 (§4.6): needs no
//    calibration, loses the sign.
//  - complete motion (§4.7, corrected Algorithm 2): two solutions (R, t/d, n); the scale of H is
//    fixed by det Hc = d2/d1 when that ratio is known, else det Hc = 1 (exact only for motion
//    parallel to the wall; 0.124 rad error when advancing 1.5 m towards a wall 5 m away).
#pragma once

#include <Eigen/Core>

#include <optional>
#include <utility>
#include <vector>

#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// The 1D camera: focal length and principal point along x [px].
struct LineCamera {
  double f = 500.0;
  double x0 = 0.0;
  Status validate() const;  // kInvalidInput for non-finite values or f <= 0
};

// H in centred coordinates: Hc = T H T⁻¹, T = [[1, −x0], [0, 1]], scaled so that h22 > 0.
Expected<Eigen::Matrix2d> centredHomography1d(const Eigen::Matrix2d& H, double x0);

// μ = h12/h22 of the centred H [px]. Status kNotFinite/kDegenerate (h22 = 0).
Expected<double> muOf(const Eigen::Matrix2d& H, double x0);
Expected<double> headingFromMu(const Eigen::Matrix2d& H, const LineCamera& camera);
Expected<double> headingFromT(const Eigen::Matrix2d& H, const LineCamera& camera);
// |θ| (the sign is not observable); kDegenerate when det H <= 0.
Expected<double> headingMagnitudeFromEigenvalues(const Eigen::Matrix2d& H);

struct CompleteMotion1d {
  double theta = 0.0;                                           // θ as above
  Eigen::Vector2d translation_over_distance = Eigen::Vector2d::Zero();  // t/d, (x, z)
  Eigen::Vector2d normal = Eigen::Vector2d::UnitY();            // n in frame 1, nᵀ m1 > 0
};

// Corrected Algorithm 2 (docs/math.md §4.7). `reference_xs`: the inlier x of the reference image (for
// the sign of Hc and of n). `depth_ratio` d2/d1 when known (true scale); otherwise det Hc = 1.
// Returns 1 or 2 solutions. Status: kInvalidInput (no reference x, bad camera or ratio),
// kDegenerate (det Hc <= 0), kNotFinite.
Expected<std::vector<CompleteMotion1d>> completeMotion1d(const Eigen::Matrix2d& H,
                                                         const LineCamera& camera,
                                                         const std::vector<double>& reference_xs,
                                                         std::optional<double> depth_ratio = {});

// The 1D homography that lines on the wall nᵀX1 = d (reference camera frame, n = (nx, nz) unit,
// d > 0) induce between the reference camera and a camera at `current` (its pose in the reference
// camera frame), in centred pixels: docs/math.md §4.4, H = K (R + t nᵀ/d) K⁻¹ with t = −R C,
// K = [[f, 0], [0, 1]], at the scale h22 = cosθ + tz nz/d (not normalised). μ = h12/h22 of it is
// what HeadingCorrector measures (docs/math.md §4.5). Status kInvalidInput for a non-unit or
// non-finite normal, d <= 0 or f <= 0; kDegenerate when h22 <= 0 (the wall is not in front of
// both cameras).
Expected<Eigen::Matrix2d> planeHomography1d(const PlanarPose& current, const Eigen::Vector2d& normal_xz,
                                            double distance, double f);
Expected<double> predictedMu(const PlanarPose& current, const Eigen::Vector2d& normal_xz, double distance,
                             double f);

// Calibration (paper 002 §4.1): f from μ against known rotations, μ_i = f tan θ_i, least squares
// through the origin. `samples`: (θ_i [rad], μ_i [px]).
struct FocalFit {
  double f = 0.0;
  double rms_residual_px = 0.0;  // of μ
  int samples = 0;
};
// Status: kTooFewPoints (no sample with θ ≠ 0), kInvalidInput (non-finite), kDegenerate (f <= 0).
Expected<FocalFit> fitFocalFromMu(const std::vector<std::pair<double, double>>& samples);

}  // namespace homography_teach_repeat
