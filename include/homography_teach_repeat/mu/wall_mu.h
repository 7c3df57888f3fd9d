// The μ of a reference keyframe's wall (docs/math.md §4.4-4.5): what the localization filter
// (localization/localization_filter.h) measures a μ fix against. μ = h12/h22 of the 1D homography
// the wall induces between the reference camera and the current one; it depends on the heading and
// on the lateral offset (μ ≈ f (θ + tx/d)).
#pragma once

#include <Eigen/Core>

#include <optional>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/geometry/scene_plane.h"

namespace homography_teach_repeat {

// A μ measured against a reference keyframe with a known wall.
struct MuObservation {
  double mu = 0.0;               // [px], centred (HeadingCorrection::mu)
  double variance = 4.0;         // [px²]; raised to min_mu_variance
  Pose2D reference_pose;         // route-frame base pose of the reference keyframe
  Eigen::Vector2d wall_normal = Eigen::Vector2d::UnitY();  // (nx, nz) in the reference camera frame, unit
  double wall_distance = 1.0;    // [m] > 0
  Pose2D camera_mount;           // camera forward frame in base_link (x, y, yaw)
  double focal_px = 500.0;       // the μ focal length [px]
  int reference_id = -1;         // the keyframe (confirmation compares fixes of the same one)
  // false: the measurement passed its own consensus check (ShiftHeading's unambiguous vote,
  // mu/shift_heading.h) and is taken without the previous frame's confirmation
  // (LocalizationFilterOptions::max_mu_step_px); the innovation gate still applies.
  bool needs_confirmation = true;
  // How uncertain the wall itself is (KeyframeReference's plane_normal_sigma_rad and
  // plane_distance_sigma, measured from the neighbouring keyframes' planes, docs/math.md §3.6):
  // the std of its normal's direction [rad, >= 0] and of its distance [fraction, >= 0]. The μ
  // the wall predicts is then uncertain too (wallModelVariance, §4.11).
  double wall_normal_sigma_rad = 0.0;
  double wall_distance_sigma = 0.0;
  // The point (x, z) [m] of the reference camera frame on the wall that its normal's error turns it
  // about (KeyframeReference::plane_pivot); absent: the wall's point nearest the camera.
  std::optional<Eigen::Vector2d> wall_pivot;
};

// The wall model of a reference with pose `reference_pose` (route frame) and scene `plane` (its
// camera frame) for a μ observation (mu left 0); nullopt without a plane or for a plane that is
// not a wall (|(nx, nz)| <= 0.5: floor or ceiling, where μ says nothing about it).
std::optional<MuObservation> muWallOf(const Pose2D& reference_pose, const std::optional<ScenePlane>& plane,
                                      const Pose2D& camera_mount, double focal_px, int reference_id);
// The centred 1D homography the observation's wall induces between the reference camera and the
// camera of a robot at `base` (route frame), docs/math.md §4.4 (planeHomography1d); its h12/h22 is the
// μ the filter predicts, and it tells the line matcher where the reference lines should be.
Expected<Eigen::Matrix2d> wallHomography1dAt(const MuObservation& wall, const Pose2D& base);
// The variance [px²] the wall's own uncertainty adds to the μ it predicts for a robot at `base`:
// (∂μ/∂φ · σφ)² + (∂μ/∂d · d σd)², φ the direction of the wall's normal in the reference camera's
// (x, z) plane, the derivatives by central differences (docs/math.md §4.11). 0 when both sigmas
// are 0; kInvalidInput for a negative or non-finite sigma; kDegenerate where a perturbed wall is
// not in front of both cameras.
Expected<double> wallModelVariance(const MuObservation& wall, const Pose2D& base);

}  // namespace homography_teach_repeat
