// Robust three-view matching with the 1D trifocal tensor (paper 003 §IV; docs/math.md §5.4, §5.8).
//
// RANSAC over minimal sets of bearing triplets (TT7: 7, TT5: 5), each hypothesis scored by the
// angular transfer error of every triplet (the largest of the three views' errors, modulo π),
// with the adaptive iteration count m = log(1 − P)/log(1 − w^n) from the best inlier fraction w so
// far (at 40 % outliers and P = 0.99: 163 for TT7, 57 for TT5). TT4 searches in two stages: the
// plane's 1D homographies from 3 triplets (19 iterations at 40 %), then the one off-plane triplet
// that completes the tensor (6 more). The winner is refitted on its inliers and re-scored while
// the inlier set grows (the "growth of the match set by the tensor constraint"), then refitted on
// the inliers within 2.5 σ̂ of the transfer-error noise they show (σ̂ = 1.4826 · median).
#pragma once

#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/trifocal/trifocal_tensor_1d.h"

namespace homography_teach_repeat {

enum class TrifocalMethod { kTT7, kTT5, kTT4 };

// "TT7", "TT5", "TT4"; throws std::invalid_argument naming the accepted values.
TrifocalMethod trifocalMethodFromString(const std::string& name);
std::string toString(TrifocalMethod method);
// Triplets of a minimal set: 7, 5, 4 (3 on the plane + 1).
int minimalTriplets(TrifocalMethod method);

struct TrifocalRansacOptions {
  TrifocalMethod method = TrifocalMethod::kTT5;
  double max_transfer_error = 0.003;  // [rad] inlier threshold (≈ 3 px at 1024 px / 53°)
  double confidence = 0.99;           // P, in (0, 1)
  int max_iterations = 5000;          // per stage, >= 1
  int max_growth_rounds = 5;          // refit + re-score rounds (growth, then tightening), >= 0
  unsigned seed = 1;                  // samples are drawn deterministically from this seed

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct TrifocalRansacResult {
  TrifocalTensor1d tensor = TrifocalTensor1d::Zero();  // unit norm, refitted on the inliers
  std::vector<int> inliers;        // the triplets the tensor was fitted to (within the tightened
                                   // threshold), indices into the input, ascending
  int consistent = 0;              // triplets within max_transfer_error of the final tensor
  int iterations = 0;              // hypotheses drawn (TT4: both stages)
  // TT4 only: the plane stage.
  int plane_iterations = 0;
  std::vector<int> plane_inliers;
  Eigen::Matrix2d H_second = Eigen::Matrix2d::Zero();  // plane homography view 1 -> 2
  Eigen::Matrix2d H_third = Eigen::Matrix2d::Zero();   // plane homography view 1 -> 3
};

// The plane (a wall: its landmarks are collinear in the top view) that explains most triplets: its
// 1D homographies view 1 -> 2 and 1 -> 3 (RANSAC over 3 triplets, both bearing errors below
// max_transfer_error, refitted on the inliers). Used by TT4, and to detect the degenerate case of
// every landmark on one wall, where a tensor from points alone is not determined (paper 003 §IV:
// "if the whole image matches can be explained with a sole homography ... the localization
// results from the trifocal tensor are not good"). kTooFewPoints (< 3), kNoConsensus.
struct DominantPlane {
  Eigen::Matrix2d H_second = Eigen::Matrix2d::Zero();
  Eigen::Matrix2d H_third = Eigen::Matrix2d::Zero();
  std::vector<int> inliers;  // ascending
  int iterations = 0;
};
Expected<DominantPlane> estimateDominantPlane(const std::vector<BearingTriplet>& triplets,
                                              const TrifocalRansacOptions& options = {});

// Adaptive RANSAC count ⌈log(1 − P)/log(1 − w^n)⌉ (docs/math.md §5.8), capped at `cap`.
int ransacIterations(double inlier_fraction, int sample_size, double confidence, int cap);

// Status: kTooFewPoints (fewer triplets than a minimal set), kInvalidInput (non-finite bearings,
// bad options), kNoConsensus (no hypothesis supported by 2 triplets beyond its sample), kDegenerate (TT4:
// every triplet on the plane, i.e. one homography explains the scene and the tensor is not
// determined — paper 003 §IV).
Expected<TrifocalRansacResult> estimateTrifocalRansac(const std::vector<BearingTriplet>& triplets,
                                                     const TrifocalRansacOptions& options = {});

}  // namespace homography_teach_repeat
