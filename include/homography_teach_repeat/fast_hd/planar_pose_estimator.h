// The whole per-frame estimate of the repeat phase: matches -> robust homography (inliers) ->
// normalised DLT on the inliers -> Fast-HD -> covariance (docs/math.md §3.4) -> optional 3-DoF
// refinement (planar_pose_refinement.h). Every failure is a status, never a pose.
#pragma once

#include <Eigen/Core>
#include <optional>

#include <vector>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/fast_hd/planar_pose_refinement.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct PlanarPoseEstimatorOptions {
  RobustHomographyOptions robust;
  double pixel_sigma_px = 0.5;  // std of every match coordinate, for both covariances
  // > 0: the pixel σ of this estimate measured from its own matches too (docs/math.md §3.9): this
  // gain [0-10] times the rms transfer error r of the inliers about their DLT homography (the
  // statistic the teach run measures between keyframes, so the same gain) where that is more than
  // pixel_sigma_px. A view matched less closely than the keyframe's neighbours (a second surface
  // near the plane, features followed by optical flow over frames) claims accordingly more; one
  // matched more closely does not claim less (its error is not all pixel noise). 0: pixel_sigma_px.
  double residual_sigma_gain = 0.0;
  bool refine = true;           // run the 3-DoF refinement after Fast-HD
  int refinement_max_iterations = 20;
  // The keyframe plane is itself an estimate (docs/math.md §3.6): the std of its normal's direction
  // [rad, each of the two directions across it] and of its distance [fraction of the distance].
  // Their effect on the pose, J Σ_plane Jᵀ with J the pose's derivative with respect to the plane,
  // is added to both covariances (Fast-HD's: central differences of the closed form; the refined
  // pose's: the refinement's own derivative, docs/math.md §3.6); 0 and 0: the covariance of the
  // pixel noise alone.
  double plane_normal_sigma_rad = 0.0;
  double plane_distance_sigma = 0.0;
  // The current camera's tilt relative to the keyframe's as a nuisance pair in the refinement
  // (PoseRefinementOptions::tilt_sigma_rad, docs/math.md §1.10): the std of its zero-mean prior
  // [rad, 0-0.2]; 0: the camera is level (an IMU or a level mount). Needs `refine`.
  double tilt_sigma_rad = 0.0;
  // An error of the heading that many matches do not average away (docs/math.md §3.8): the
  // camera's calibration, the image's common-mode shift, the reference's own heading. Its
  // variance [rad², this std 0-0.05 rad] is added to the heading's in both covariances; 0: pixel
  // noise alone sets the heading's std (hundreds of matches on a wall give a few 0.01°).
  double heading_sigma_rad = 0.0;
  // The same floor in the image's own unit: a shift of the current image against the keyframe's
  // that all matches share (the keypoints' common localization error, the image's resampling, the
  // calibration's principal point), its std [px, 0-5] turned into a heading by the camera's focal
  // length (σ_θ = σ_shift / fx, docs/math.md §3.8), so that it scales with the image. Its variance
  // is added to heading_sigma_rad's. 0.5 px: on a real street (KITTI 07) and a real facade
  // (fountain-P11) with this and plane_sigma_from_neighbours the NEES is 1.3-3.9 per segment where
  // without it 9-44 (docs/evaluation.md); the simulator's exact camera sets its own.
  double common_shift_sigma_px = 0.5;

  // Throws std::invalid_argument naming the field on an invalid value.
  void validate() const;
};

struct PlanarPoseEstimate {
  PlanarPose pose;                                       // refined if `refined`, else Fast-HD
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (Cx, Cz, θ12)
  // The part of `covariance` that is not this image's pixel noise: the plane's and the heading
  // floor's (options above). Every fix against the same keyframe plane shares it (docs/math.md §7.1).
  Eigen::Matrix3d model_covariance = Eigen::Matrix3d::Zero();
  // The part of `covariance` that the keyframe image's own pixel noise makes (docs/math.md §3.4):
  // also shared by every fix against that keyframe; the rest (covariance − model_covariance −
  // reference_noise_covariance) is the current image's noise, and differs from fix to fix.
  Eigen::Matrix3d reference_noise_covariance = Eigen::Matrix3d::Zero();
  PlanarPose fast_hd_pose;                               // the closed-form solution
  Eigen::Matrix3d fast_hd_covariance = Eigen::Matrix3d::Zero();
  bool refined = false;
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity();  // inlier DLT, unit Frobenius norm
  Eigen::Matrix3d tilt = Eigen::Matrix3d::Identity();  // the refinement's current-camera tilt
  double height_offset = 0.0;  // the refinement's camera height offset Cy [m] (0 unless refined)
  std::vector<int> inliers;                          // indices into the input matches
  double rms_transfer_error_px = 0.0;  // of the inliers about H [px]
  double pixel_sigma_px = 0.0;         // the σ both covariances used (options, residual_sigma_gain)
};

// The pose covariance that the plane's uncertainty adds (see the options above) for the pose Fast-HD
// gives from H and `plane`: its normal turned about `pivot` (the matched points' centroid on the
// plane, centroidOnPlane; nullopt: the plane's point nearest the camera), its distance scaled
// (docs/math.md §3.6). Fails like solveFastHd.
Expected<Eigen::Matrix3d> planeUncertaintyCovariance(const Eigen::Matrix3d& H, const PinholeCamera& camera,
                                                     const ScenePlane& plane, double normal_sigma_rad,
                                                     double distance_sigma,
                                                     const std::optional<Eigen::Vector3d>& pivot = std::nullopt);

// Outlier-free input (all matches used): DLT -> Fast-HD -> covariance -> refinement.
// Status: kTooFewPoints (< 4), kDegenerate (collinear points, floor/ceiling plane, κ = 0),
// kInvalidInput, kNotFinite.
Expected<PlanarPoseEstimate> estimatePlanarPoseFromInliers(const PointMatches& matches,
                                                           const PinholeCamera& camera,
                                                           const ScenePlane& plane,
                                                           const PlanarPoseEstimatorOptions& options);

// With outliers: the robust selector first; the same statuses plus kNoConsensus.
Expected<PlanarPoseEstimate> estimatePlanarPose(const PointMatches& matches,
                                                const PinholeCamera& camera,
                                                const ScenePlane& plane,
                                                const PlanarPoseEstimatorOptions& options);

}  // namespace homography_teach_repeat
