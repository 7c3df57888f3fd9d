// Motion and structure from the 1D trifocal tensor (docs/math.md §5.6-5.7; paper 003 leaves this step
// to its references, docs/math.md gives a verified closed form).
//
// The closed form gives two candidates (the genuine two-fold ambiguity of three 1D views): both
// reproduce T and every bearing exactly. Each candidate has 8 sign variants (θ' + π, θ'' + π,
// global sign of the translations), of which the one that puts every triangulated landmark in
// front of all three views (cheirality) is kept; that usually rejects the wrong candidate too,
// otherwise an odometry prior (or a fourth view) decides.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/trifocal/trifocal_tensor_1d.h"

namespace homography_teach_repeat {

// Views 2 and 3 relative to view 1 (docs/math.md §5.1): X_k = R(θ_k) X_1 + t_k. The translations share
// one unknown scale (unit norm of (t', t'') from the tensor alone).
struct TrifocalMotion {
  double theta_second = 0.0;
  double theta_third = 0.0;
  Eigen::Vector2d t_second = Eigen::Vector2d::Zero();
  Eigen::Vector2d t_third = Eigen::Vector2d::Zero();

  // Camera centre of view 2 / 3 in the frame of view 1: −R(θ)ᵀ t.
  Eigen::Vector2d centreSecond() const;
  Eigen::Vector2d centreThird() const;
  // The same motion with the translations multiplied by `factor`.
  TrifocalMotion scaled(double factor) const;
};

// The tensor of a motion: T_ijk = minors of [M; M'; M''] (docs/math.md §5.2, sign of eq. 2).
TrifocalTensor1d tensorFromMotion(const TrifocalMotion& motion);
// The unit bearing of landmark (X, Z) (frame of view 1) in view 1, 2 or 3 of `motion`: the
// direction of M_k x, so a landmark behind the camera gets |α| > π/2.
Bearing projectBearing(const TrifocalMotion& motion, const Eigen::Vector2d& landmark, int view);

struct TrifocalMotionCandidate {
  TrifocalMotion motion;
  int in_front = 0;  // triplets whose landmark is in front of all three views (cheirality)
};

// The two candidates of the closed form, each with its best sign variant; sorted by `in_front`
// (most first). Status kDegenerate when |v| = 0, t' = 0 or t'' = 0 (no baseline between two of the
// views); kInvalidInput for a non-finite tensor.
Expected<std::vector<TrifocalMotionCandidate>> motionCandidates(const TrifocalTensor1d& T,
                                                                const std::vector<BearingTriplet>& triplets);

// Odometry prior for the disambiguation: the camera poses of views 2 and 3 in the frame of view 1
// (centres and headings); the centres also fix the metric scale.
struct TrifocalMotionPrior {
  Eigen::Vector2d centre_second = Eigen::Vector2d::Zero();
  Eigen::Vector2d centre_third = Eigen::Vector2d::Zero();
  double theta_second = 0.0;
  double theta_third = 0.0;
};

struct TrifocalMotionOptions {
  // A candidate needs this fraction of the triplets in front of all views [0, 1].
  double min_in_front_fraction = 0.8;
  // Refine the chosen candidate by bundle adjustment (refineTrifocalMotion); a refinement that
  // turns a view by more than 0.02 rad is not taken (where the two candidates lie 1-2° apart,
  // forward motion, it slid from a 0.4° to a 1.9° solution). Measured: fountain-P11 median
  // rotation error 0.29° -> 0.24° (eval_real_trifocal); 43 random triplets in the simulated room
  // (0.5 m baselines, image noise σ 2, exact prior): median 0.82° either way, p90 3.2° -> 2.4°.
  bool refine = true;
  void validate() const;
};

struct TrifocalMotionEstimate {
  TrifocalMotion motion;     // metric when a prior was given (scale from its baselines)
  bool ambiguous = false;    // both candidates passed cheirality and no prior decided
  bool metric = false;
  int in_front = 0;
};

// The motion of a tensor: the candidates passing cheirality; with two of them the prior (if any)
// picks the one closer in rotation and translation direction (not the one with more landmarks in
// front: in the simulator that picked the wrong one of two candidates 4.5° apart), and scales it
// so that its baselines match the prior's in the least-squares sense. Status kNoConsensus when no candidate
// passes cheirality; kDegenerate as motionCandidates, or when the prior's baselines are zero.
Expected<TrifocalMotionEstimate> estimateTrifocalMotion(const TrifocalTensor1d& T,
                                                       const std::vector<BearingTriplet>& triplets,
                                                       const std::optional<TrifocalMotionPrior>& prior = std::nullopt,
                                                       const TrifocalMotionOptions& options = {});

// Bundle adjustment of the motion and the landmarks (triangulated from `initial`, docs/math.md §5.7) on
// the angular bearing errors in the three views (Levenberg-Marquardt, landmarks eliminated by the
// Schur complement), the scale kept by |(t', t'')| fixed. Returns the motion with the same
// translation norm; kInvalidInput for non-finite input, kTooFewPoints for fewer than 5 triplets,
// kDegenerate for fewer than 5 landmarks with parallax.
Expected<TrifocalMotion> refineTrifocalMotion(const TrifocalMotion& initial, const std::vector<BearingTriplet>& triplets,
                                              int max_iterations = 20);

// Landmark from its three bearings (docs/math.md §5.7): rows u_2 M_k(1,:) − u_1 M_k(2,:), SVD null
// vector, in the scale of the motion's translations. kDegenerate for a landmark at infinity or
// on the line of the camera centres (no parallax); kInvalidInput for non-finite bearings.
Expected<Eigen::Vector2d> triangulateLandmark(const TrifocalMotion& motion, const BearingTriplet& triplet);

}  // namespace homography_teach_repeat
