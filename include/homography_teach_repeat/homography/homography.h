// Plane-induced homography between a reference image and a current image: p_cur ∝ H p_ref.
//
// The DLT is written here (not taken from OpenCV) because the covariance of Fast-HD needs the
// Jacobian of exactly this estimator (docs/math.md §3.4). Rows per match follow docs/math.md §3.1:
//   A_i = [[0ᵀ, −pᵀ, v' pᵀ], [pᵀ, 0ᵀ, −u' pᵀ]],  A h = 0,
// with Hartley normalisation (centroid at the origin, mean distance √2) of both point sets;
// docs/math.md §3.5 shows the unnormalised DLT has a bias comparable to its standard deviation.
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/point_match.h"

namespace homography_teach_repeat {

// Similarity T with T p = s (p − centroid), mean distance of the normalised points = √2.
struct HartleyNormalization {
  Eigen::Matrix3d transform = Eigen::Matrix3d::Identity();
  double scale = 1.0;
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
};

// Fails (kDegenerate) when all points coincide.
Expected<HartleyNormalization> computeHartleyNormalization(const std::vector<Eigen::Vector2d>& points);

// The normalised DLT with the quantities its Jacobian needs (docs/math.md §3.4): Ĥ (unit Frobenius
// norm, the right singular vector of Â), the two Hartley similarities, and the right singular
// vectors / singular values of Â (descending; the last is the null direction, value ~0).
// `H_unscaled` = T_cur⁻¹ Ĥ T_ref is the pixel homography at the scale the Jacobian refers to.
struct NormalizedDlt {
  Eigen::Matrix3d H_normalized;
  Eigen::Matrix3d H_unscaled;
  HartleyNormalization reference_normalization;
  HartleyNormalization current_normalization;
  Eigen::Matrix<double, 9, 9> right_singular_vectors;
  Eigen::Matrix<double, 9, 1> singular_values;  // zero-padded when only 4 matches (Â is 8x9)
  std::size_t match_count = 0;
};

// Same statuses as estimateHomographyDlt.
Expected<NormalizedDlt> solveNormalizedDlt(const PointMatches& matches);

// Normalised DLT from >= 4 matches. The result has unit Frobenius norm; its sign is arbitrary
// (use Fast-HD's κ normalisation, docs/math.md §1.3, where the sign matters).
// Status: kTooFewPoints (< 4), kInvalidInput (non-finite coordinates), kDegenerate (collinear
// points in either image, coincident points, or a null space of dimension > 1).
Expected<Eigen::Matrix3d> estimateHomographyDlt(const PointMatches& matches);

// Maps a pixel of the reference image into the current image. Returns NaN when the point maps to
// infinity (H₃·p = 0).
Eigen::Vector2d applyHomography(const Eigen::Matrix3d& H, const Eigen::Vector2d& point);

// |p_cur − π(H p_ref)| in pixels of the current image.
double transferError(const Eigen::Matrix3d& H, const PointMatch& match);
// √(mean transferError²) over `matches` [px]; 0 for none.
double rmsTransferError(const Eigen::Matrix3d& H, const PointMatches& matches);
// Symmetric transfer error: |p_cur − π(H p_ref)|² + |p_ref − π(H⁻¹ p_cur)|² (squared pixels).
double symmetricTransferErrorSquared(const Eigen::Matrix3d& H, const Eigen::Matrix3d& H_inverse,
                                     const PointMatch& match);

// Reads a 3x3 homography from a file: OpenCV XML/YAML (.xml, .yml, .yaml; the first node, as in
// opencv-doc's H1to3p.xml) or 9 whitespace-separated numbers in row-major order (Oxford and
// HPatches ground truth). Status kInvalidInput naming the file when it cannot be opened, is not
// 3x3, has fewer than 9 numbers, or has a non-finite entry.
Expected<Eigen::Matrix3d> readHomographyFile(const std::string& path);

// Mean of |π(H_a p) − π(H_b p)| over a regular grid of `step` pixels on a width x height image,
// restricted to the points whose image under H_b lies inside a `width_b` x `height_b` image.
// Used to compare an estimated homography with a ground truth independently of any features.
// Fails (kInvalidInput) if no grid point maps inside.
Expected<double> meanGridTransferDifference(const Eigen::Matrix3d& H_a, const Eigen::Matrix3d& H_b,
                                            int width, int height, int width_b, int height_b,
                                            int step);

}  // namespace homography_teach_repeat
