#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"

#include <algorithm>
#include <array>
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
  if (!std::isfinite(plane_normal_sigma_rad) || plane_normal_sigma_rad < 0.0 || plane_normal_sigma_rad > 0.5) {
    throw std::invalid_argument("plane_normal_sigma must be in [0, 0.5] rad, got " +
                                std::to_string(plane_normal_sigma_rad));
  }
  if (!std::isfinite(plane_distance_sigma) || plane_distance_sigma < 0.0 || plane_distance_sigma > 0.5) {
    throw std::invalid_argument("plane_distance_sigma must be in [0, 0.5] (a fraction of the distance), got " +
                                std::to_string(plane_distance_sigma));
  }
  if (!std::isfinite(tilt_sigma_rad) || tilt_sigma_rad < 0.0 || tilt_sigma_rad > 0.2) {
    throw std::invalid_argument("tilt_sigma must be in [0, 0.2] rad, got " + std::to_string(tilt_sigma_rad));
  }
  if (!std::isfinite(heading_sigma_rad) || heading_sigma_rad < 0.0 || heading_sigma_rad > 0.05) {
    throw std::invalid_argument("heading_sigma must be in [0, 0.05] rad, got " + std::to_string(heading_sigma_rad));
  }
  if (!std::isfinite(common_shift_sigma_px) || common_shift_sigma_px < 0.0 || common_shift_sigma_px > 5.0) {
    throw std::invalid_argument("common_shift_sigma must be in [0, 5] px, got " + std::to_string(common_shift_sigma_px));
  }
  if (!(residual_sigma_gain >= 0.0 && residual_sigma_gain <= 10.0)) {
    throw std::invalid_argument("residual_sigma_gain must be in [0, 10], got " + std::to_string(residual_sigma_gain));
  }
  if (refinement_max_iterations < 1) {
    throw std::invalid_argument("refinement_max_iterations must be >= 1");
  }
}

namespace {
// The plane's error model of docs/math.md §3.6: σ_N on each direction across the normal, σ_d.
Eigen::Vector3d planeVariances(double normal_sigma_rad, double distance_sigma) {
  return Eigen::Vector3d(normal_sigma_rad * normal_sigma_rad, normal_sigma_rad * normal_sigma_rad,
                         distance_sigma * distance_sigma);
}

// The model's part of a pose covariance (PlanarPoseEstimate::model_covariance): the plane's term
// and the heading's own error floor (docs/math.md §3.8: a common rotation of the current camera
// about its vertical axis moves θ12 and leaves the centre where it is); a common image shift of σ
// px is such a rotation by σ / fx.
Eigen::Matrix3d withHeadingFloor(Eigen::Matrix3d plane_term, const PlanarPoseEstimatorOptions& options,
                                 const PinholeCamera& camera) {
  const double shift_rad = options.common_shift_sigma_px / camera.fx();
  plane_term(2, 2) += options.heading_sigma_rad * options.heading_sigma_rad + shift_rad * shift_rad;
  return plane_term;
}
}  // namespace

Expected<Eigen::Matrix3d> planeUncertaintyCovariance(const Eigen::Matrix3d& H, const PinholeCamera& camera,
                                                     const ScenePlane& plane, double normal_sigma_rad,
                                                     double distance_sigma, const std::optional<Eigen::Vector3d>& pivot) {
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  if (!(normal_sigma_rad > 0.0) && !(distance_sigma > 0.0)) return covariance;
  // Two directions across the normal, and the distance: central differences of the closed form.
  const Eigen::Vector3d n = plane.normal.normalized();
  const auto [across1, across2] = directionsAcrossNormal(n);
  constexpr double kStep = 1e-4;
  const Eigen::Vector3d about = pivot.value_or(plane.distance * n);
  // The normal turned about `about` (its distance n'ᵀ about), then the distance scaled.
  auto poseWith = [&](const Eigen::Vector3d& normal, double scale) -> Expected<Eigen::Vector3d> {
    ScenePlane perturbed = turnedAbout(plane, normal, about);
    perturbed.distance *= scale;
    const auto solution = solveFastHd(H, camera, perturbed);
    if (!solution) return solution.status();
    return Eigen::Vector3d(solution->pose.x, solution->pose.z, solution->pose.theta);
  };
  Eigen::Matrix3d J;
  const std::array<std::pair<Eigen::Vector3d, double>, 3> steps{
      {{kStep * across1, 0.0}, {kStep * across2, 0.0}, {Eigen::Vector3d::Zero(), kStep}}};
  for (int k = 0; k < 3; ++k) {
    const auto plus = poseWith(n + steps[k].first, 1.0 + steps[k].second);
    const auto minus = poseWith(n - steps[k].first, 1.0 - steps[k].second);
    if (!plus) return plus.status();
    if (!minus) return minus.status();
    Eigen::Vector3d difference = *plus - *minus;
    difference.z() = wrapToPi(difference.z());
    J.col(k) = difference / (2.0 * kStep);  // per radian across the normal, per unit relative distance
  }
  covariance = J * planeVariances(normal_sigma_rad, distance_sigma).asDiagonal() * J.transpose();
  if (!covariance.allFinite()) return Status(StatusCode::kNotFinite, "plane uncertainty covariance is not finite");
  return covariance;
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
  const Eigen::Matrix3d H = dlt->H_unscaled / dlt->H_unscaled.norm();
  const double rms = rmsTransferError(H, matches);
  const double sigma = options.residual_sigma_gain > 0.0
                           ? std::max(options.residual_sigma_gain * rms, options.pixel_sigma_px)
                           : options.pixel_sigma_px;
  Eigen::Matrix3d reference_noise_covariance;
  const auto covariance = fastHdCovariance(*dlt, matches, camera, plane, sigma,
                                           /*second_order=*/true, &reference_noise_covariance);
  if (!covariance) return covariance.status();
  const auto plane_covariance = planeUncertaintyCovariance(dlt->H_unscaled, camera, plane, options.plane_normal_sigma_rad,
                                                           options.plane_distance_sigma,
                                                           centroidOnPlane(plane, camera, matches));
  if (!plane_covariance) return plane_covariance.status();

  const Eigen::Matrix3d model_covariance = withHeadingFloor(*plane_covariance, options, camera);

  PlanarPoseEstimate estimate;
  estimate.fast_hd_pose = solution->pose;
  estimate.fast_hd_covariance = *covariance + model_covariance;
  estimate.pose = solution->pose;
  estimate.covariance = estimate.fast_hd_covariance;
  estimate.model_covariance = model_covariance;
  estimate.reference_noise_covariance = reference_noise_covariance;
  estimate.H = H;
  estimate.inliers.resize(matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i) estimate.inliers[i] = static_cast<int>(i);
  estimate.rms_transfer_error_px = rms;
  estimate.pixel_sigma_px = sigma;
  if (options.refine) {
    PoseRefinementOptions refinement;
    refinement.sigma_px = sigma;
    refinement.max_iterations = options.refinement_max_iterations;
    refinement.tilt_sigma_rad = options.tilt_sigma_rad;
    refinement.plane_sensitivity = options.plane_normal_sigma_rad > 0.0 || options.plane_distance_sigma > 0.0;
    const auto refined =
        refinePlanarPose(solution->pose, {PlaneMatches{plane, matches}}, camera, refinement);
    if (!refined) return refined.status();
    estimate.pose = refined->pose;
    // The plane's error moves the refined pose as the refinement's own derivative says (zero
    // without plane uncertainty: not requested).
    const Eigen::Matrix3d& J = refined->plane_jacobian;
    estimate.model_covariance = withHeadingFloor(
        J * planeVariances(options.plane_normal_sigma_rad, options.plane_distance_sigma).asDiagonal() * J.transpose(),
        options, camera);
    estimate.covariance = refined->covariance + estimate.model_covariance;
    estimate.reference_noise_covariance = refined->reference_noise_covariance;
    estimate.tilt = refined->tilt;
    estimate.height_offset = refined->height_offset;
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
