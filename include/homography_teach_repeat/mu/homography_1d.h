// 1D homography of vertical lines (paper 002 §2; docs/math.md §4.2-4.3): λ (x2, 1)ᵀ = H21 (x1, 1)ᵀ,
// H21 2x2 up to scale, one equation per matched line:
//   (x1, 1, −x1 x2, −x2) · (h11, h12, h21, h22)ᵀ = 0,
// so 3 matches determine it. Least median of squares exactly as the paper's Algorithm 1:
//   m = ⌈log Pf / log(1 − Pns³)⌉ random subsets of 3 (Pf = 0.001, Pns = 0.7 → 17),
//   the subset solution with the least median M_S of the squared transfer residuals
//   r = x2 − (h11 x1 + h12)/(h21 x1 + h22) [px] wins,
//   σ̂ = 1.4826 [1 + 5/(n − 3)] √M_S, inliers r² < 3.84 σ̂² (χ²₁ 95%),
// then the DLT refit on the inliers.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// One matched vertical line: x in the reference and in the current image [px].
struct LineCorrespondence {
  double reference_x = 0.0;
  double current_x = 0.0;
};

// DLT from >= 3 correspondences with the coordinates centred and scaled (conditioning; the
// result is returned in pixels, unit Frobenius norm, h22 >= 0). Status: kTooFewPoints (< 3),
// kInvalidInput (non-finite), kDegenerate (fewer than 3 distinct reference or current x, or a
// null space of dimension > 1).
Expected<Eigen::Matrix2d> estimateHomography1dDlt(const std::vector<LineCorrespondence>& lines);

// x2 − (h11 x1 + h12)/(h21 x1 + h22); infinite when the denominator vanishes.
double transferResidual1d(const Eigen::Matrix2d& H, const LineCorrespondence& line);

struct Homography1dOptions {
  double failure_probability = 0.001;  // Pf
  double inlier_probability = 0.7;     // Pns (expected fraction of good matches)
  unsigned seed = 1;                   // subsets are drawn deterministically from this seed

  void validate() const;  // throws std::invalid_argument naming the bad field
  int subsetCount() const;  // m = ⌈log Pf / log(1 − Pns³)⌉
};

struct Homography1dResult {
  Eigen::Matrix2d H = Eigen::Matrix2d::Identity();  // refit on the inliers, unit norm, h22 >= 0
  std::vector<int> inliers;
  double sigma_px = 0.0;              // σ̂ of Algorithm 1
  double median_squared_residual = 0.0;  // M_S of the winning subset [px²]
  double rms_residual_px = 0.0;       // of the refit over the inliers
  int subsets = 0;
};

// Status: kTooFewPoints (< 3 correspondences), kInvalidInput, kDegenerate (no subset gives a
// homography), kNoConsensus (fewer than 3 inliers after the threshold).
Expected<Homography1dResult> estimateHomography1dLmeds(const std::vector<LineCorrespondence>& lines,
                                                       const Homography1dOptions& options = {});

}  // namespace homography_teach_repeat
