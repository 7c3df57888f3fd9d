// A scene plane in a camera frame and the homography it induces between two cameras under planar
// motion (docs/math.md §1.1-§1.2). The type every module shares: route storage, Fast-HD, the
// classic decomposition, plane estimation and the μ wall model.
#pragma once

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

// A plane in the reference camera frame (docs/math.md §1.1): nᵀ X = d with n a unit vector pointing
// from the camera towards the plane (visible points have nᵀ K⁻¹ p > 0) and d > 0 [m].
struct ScenePlane {
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  double distance = 1.0;

  // kInvalidInput for a non-unit or non-finite normal or a distance that is not > 0;
  // kDegenerate for a floor/ceiling plane (nx = nz = 0: Π is singular, det Π = d²(nx² + nz²)).
  Status validate() const;
};

// Where the plane's uncertainty turns it (docs/math.md §3.6): the centroid of the points where
// `rays` (directions in the plane's camera frame, any length) meet it; rays that meet it behind the
// camera or run parallel to it are left out. nullopt when none meets it.
std::optional<Eigen::Vector3d> centroidOnPlane(const ScenePlane& plane, const std::vector<Eigen::Vector3d>& rays);
// The same for the reference pixels of `matches` (undistorted, the plane's camera): where a fix's
// matches hold the plane.
std::optional<Eigen::Vector3d> centroidOnPlane(const ScenePlane& plane, const PinholeCamera& camera,
                                               const PointMatches& matches);
// `plane` with its normal turned to `normal` (normalised here) about `pivot`, a point on the plane:
// the distance becomes n'ᵀ pivot (docs/math.md §3.6).
ScenePlane turnedAbout(const ScenePlane& plane, const Eigen::Vector3d& normal, const Eigen::Vector3d& pivot);

// The homography a plane induces between a reference camera and a camera at `pose`
// (docs/math.md §1.2): H21 ∝ K (R21 − t21 n1ᵀ / d1) K⁻¹, t21 = R21 C. Unit Frobenius norm.
// `height_offset`: the current camera's centre Cy [m] off the reference camera's height (a
// passenger, a slope; the refinement's nuisance), C = (x, Cy, z). Used to synthesise exact data,
// by the plane-parameter estimation and by the repeat's plane-residual check.
Eigen::Matrix3d planeInducedHomography(const PinholeCamera& camera, const PlanarPose& pose,
                                       const ScenePlane& plane, double height_offset = 0.0);

}  // namespace homography_teach_repeat
