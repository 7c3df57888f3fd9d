// Robust homography from matches with outliers: an inlier selector, then the normalised DLT of
// homography.h refitted on the inliers (so the estimate, and its covariance later, is that of the
// estimator the error propagation of docs/math.md §3.4 describes).
//
// Inlier selection uses OpenCV's findHomography (RANSAC, LMedS, USAC MAGSAC++, or USAC's
// LO-RANSAC with MSAC scoring, "lo_ransac", cv::USAC_DEFAULT); each adapts its
// number of iterations to the inlier ratio found so far. The refit is iterated: inliers are
// re-selected with the refitted H by transfer error until the set stops changing.
//
// Scale-adaptive re-selection (on by default): with a fixed threshold of a few pixels, a nearly
// coplanar second structure can be absorbed by a compromise homography that then wins the
// consensus (measured on graf1 -> graf3: 130 matches of a structure 4-9 px off the wall plane gave
// a compromise 2.2 px off the ground truth). So after each refit the noise scale is estimated from
// the inliers, σ̂ = median(transfer error) / 1.1774 (the median of a 2D Gaussian error norm is
// 1.1774σ), and inliers are re-selected at the 95% radius 2.4477σ̂ (√χ²₂(0.95)), never above
// inlier_threshold_px and never below min_adaptive_threshold_px.
//
// Several hypotheses (on by default): even so, which of the two structures a single run returns
// flips with tiny input changes (graf1 -> graf3 with LO-RANSAC at 1.5 px: 42 of 54 runs on the wall
// over feature budgets 800-4000 and two grey conversions). The MSAC cost at the inlier threshold,
// Σ min(e², τ²) over all matches, separated the modes in every one of those runs (wall: at most
// 0.748 τ² per match at τ = 1 px; compromise: at least 0.772). So the selector runs on
// `hypotheses` permutations of the matches (deterministic: permutation k is seeded with k), each
// result is refitted, and the refit with the lowest MSAC cost is returned.
//
// The selector at the measured scale (on by default): the re-selection above starts from the
// selector's homography, and a compromise that wins at the selector's threshold can be stable at
// the measured one too. Two walls meeting ahead of a camera moving towards their corner (the
// simulator's gallery): at 1.5 px the selector took 188 points of one wall and 40 of the other,
// the refit kept them at 0.5 px (rms 0.25 px), and the plane the teach run read from it leaned by
// 4.2°. So where the measured threshold is below 0.8 of `inlier_threshold_px`, the hypotheses run
// again with the selector at the measured threshold, and the result whose MSAC cost at that
// threshold is lower is returned (there: 324 points of the one wall, 2 of the other, rms 0.20 px,
// the plane 0.2° off; docs/design.md, "The robust homography").
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

enum class RobustMethod { kRansac, kLmeds, kMagsac, kLoRansac };

// "ransac", "lmeds", "magsac", "lo_ransac"; throws std::invalid_argument on anything else.
RobustMethod robustMethodFromString(const std::string& name);
std::string toString(RobustMethod method);

struct RobustHomographyOptions {
  RobustMethod method = RobustMethod::kLoRansac;
  double inlier_threshold_px = 1.5;  // transfer error in the current image (≈3σ of SIFT)
  double confidence = 0.999;
  int max_iterations = 5000;
  int min_inliers = 8;  // fewer inliers than this is reported as kNoConsensus
  int max_refit_rounds = 10;
  bool adaptive_threshold = true;
  int hypotheses = 4;  // selector runs on permuted matches; the lowest MSAC cost wins
  // After the hypotheses, where the measured threshold (adaptive re-selection) is below 0.8 of
  // inlier_threshold_px: the hypotheses again with the selector at the measured threshold, and
  // the result that costs less at it (MSAC) is returned (header comment above).
  bool reselect_at_measured_scale = true;
  double min_adaptive_threshold_px = 0.5;
  // After the inliers are final, refine H on them by Levenberg-Marquardt on the Sampson distance
  // (homography_refinement.h). Off by default: the Fast-HD covariance is that of the DLT.
  bool refine_nonlinear = false;

  // Throws std::invalid_argument naming the field on an invalid value.
  void validate() const;
};

struct RobustHomographyResult {
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity();  // unit Frobenius norm
  std::vector<int> inliers;                           // indices into the input matches
  double rms_transfer_error_px = 0.0;                 // over the inliers
  double final_threshold_px = 0.0;                    // threshold of the last re-selection
  double msac_cost = 0.0;  // Σ min(e², τ²) / (n τ²) over all matches, τ = inlier_threshold_px
};

// Status: the DLT statuses (kTooFewPoints, kInvalidInput, kDegenerate) and kNoConsensus.
Expected<RobustHomographyResult> estimateHomographyRobust(const PointMatches& matches,
                                                          const RobustHomographyOptions& options);

}  // namespace homography_teach_repeat
