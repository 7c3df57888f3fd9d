#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/fast_hd/fast_hd_covariance.h"
#include "homography_teach_repeat/homography/homography.h"

namespace homography_teach_repeat {

void PlanarPoseEstimatorOptions::validate() const {
  robust.validate();
  if (!std::isfinite(pixel_sigma_px) || !(pixel_sigma_px > 0.0)) {
    throw std::invalid_argument("pixel_sigma_px must be > 0, got " +
                                std::to_string(pixel_sigma_px));
  }
  if (refinement_max_iterations < 1) {
    throw std::invalid_argument("refinement_max_iterations must be >= 1");
  }
}

Expected<PlanarPoseEstimate> estimatePlanarPoseFromInliers(
    const PointMatches& matches, const PinholeCamera& camera, const ScenePlane& plane,
    const PlanarPoseEstimatorOptions& options) {
  const Status plane_status = plane.validate();
  if (!plane_status.isOk()) return plane_status;
  const auto dlt = solveNormalizedDlt(matches);
  if (!dlt) return dlt.status();
  const auto solution = solveFastHd(dlt->H_unscaled, camera, plane);
  if (!solution) return solution.status();
  const auto covariance = fastHdCovariance(*dlt, matches, camera, plane, options.pixel_sigma_px);
  if (!covariance) return covariance.status();

  PlanarPoseEstimate estimate;
  estimate.fast_hd_pose = solution->pose;
  estimate.fast_hd_covariance = *covariance;
  estimate.pose = solution->pose;
  estimate.covariance = *covariance;
  estimate.H = dlt->H_unscaled / dlt->H_unscaled.norm();
  estimate.inliers.resize(matches.size());
  double sum = 0.0;
  for (std::size_t i = 0; i < matches.size(); ++i) {
    estimate.inliers[i] = static_cast<int>(i);
    sum += std::pow(transferError(estimate.H, matches[i]), 2);
  }
  estimate.rms_transfer_error_px = std::sqrt(sum / static_cast<double>(matches.size()));
  if (options.refine) {
    PoseRefinementOptions refinement;
    refinement.sigma_px = options.pixel_sigma_px;
    refinement.max_iterations = options.refinement_max_iterations;
    const auto refined =
        refinePlanarPose(solution->pose, {PlaneMatches{plane, matches}}, camera, refinement);
    if (!refined) return refined.status();
    estimate.pose = refined->pose;
    estimate.covariance = refined->covariance;
    estimate.refined = true;
  }
  return estimate;
}

Expected<PlanarPoseEstimate> estimatePlanarPose(const PointMatches& matches,
                                                const PinholeCamera& camera,
                                                const ScenePlane& plane,
                                                const PlanarPoseEstimatorOptions& options) {
  const Status plane_status = plane.validate();
  if (!plane_status.isOk()) return plane_status;
  const auto robust = estimateHomographyRobust(matches, options.robust);
  if (!robust) return robust.status();
  PointMatches inliers;
  inliers.reserve(robust->inliers.size());
  for (const int i : robust->inliers) inliers.push_back(matches[static_cast<std::size_t>(i)]);
  auto estimate = estimatePlanarPoseFromInliers(inliers, camera, plane, options);
  if (!estimate) return estimate.status();
  estimate->inliers = robust->inliers;
  return estimate;
}

}  // namespace homography_teach_repeat
