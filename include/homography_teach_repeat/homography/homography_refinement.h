// Optional nonlinear refinement of a homography (8 DoF) on inlier matches: Levenberg-Marquardt on
// the Sampson distance, the first-order geometric (ML) error of a match for iid pixel noise in
// both images: r_i = W_i A_i h, W_i = (B_i B_iᵀ)^(-1/2), with the DLT rows A_i (docs/math.md §3.1) and
// B_i = ∂(A_i h)/∂(u, v, u', v') (docs/math.md §3.4). The DLT minimises the algebraic error instead
// (biased, docs/math.md §3.5). h stays on the unit sphere: steps are taken in its 8-dimensional
// tangent space and renormalised. Coordinates are conditioned by translating each image's
// centroid to the origin and scaling both images by one common factor (a common scale keeps the
// Sampson distance proportional to pixels).
//
// Used by RobustHomographyOptions::refine_nonlinear. Fast-HD's covariance (docs/math.md §3.4) is that
// of the DLT, so the pose pipeline keeps the DLT and refines the pose instead
// (planar_pose_refinement.h).
#pragma once

#include <Eigen/Core>

#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct HomographyRefinementOptions {
  int max_iterations = 20;
  double relative_cost_tolerance = 1e-12;  // stop when the cost decreases by less than this
};

struct RefinedHomography {
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity();  // unit Frobenius norm
  double rms_sampson_px = 0.0;                       // before: initial_rms_sampson_px
  double initial_rms_sampson_px = 0.0;
  int iterations = 0;
};

// RMS Sampson distance [px] of the matches under H; NaN if a match is degenerate under H.
double rmsSampsonDistance(const Eigen::Matrix3d& H, const PointMatches& matches);

// Status: kTooFewPoints (< 4 matches), kInvalidInput (non-finite input or options), kDegenerate
// (singular normal equations: fewer than 4 points in general position).
Expected<RefinedHomography> refineHomographySampson(const Eigen::Matrix3d& H,
                                                    const PointMatches& matches,
                                                    const HomographyRefinementOptions& options = {});

}  // namespace homography_teach_repeat
