// Planar robot poses in the two conventions the package meets, and the conversion between them.
//
// PlanarPose (docs/math.md §1.1, §1.6): the pose of a camera 2 in the frame of a reference camera 1,
// both moving on a horizontal plane, in the camera convention of Fast-HD: camera axes x right,
// y down, z forward; motion on the XZ plane. (x, z) is the centre of camera 2 in frame 1 and
// theta (= θ12 = −θ21) is the counter-clockwise yaw of camera 2 in a top view with x right and
// z up, so a point X2 of frame 2 is X1 = (x, z) + R2(theta) X2 with R2 = [[c, −s], [s, c]].
//
// Pose2D: a REP-103 planar pose (x forward, y left, yaw counter-clockwise about z up), e.g. the
// pose of base_link in the map/route frame.
//
// CameraMount: where the camera sits on the robot (from the tf base_link -> *_optical_frame).
// It converts a relative camera pose into the relative base_link pose (REP-103):
//   T_b1_b2 = M ∘ F(T_c1_c2) ∘ M⁻¹,  F(x, z, θ) = (z, −x, θ),
// where M is the camera's "forward frame" (x along the optical axis, y to its left) in base_link
// and F re-labels camera axes as REP-103 axes (optical z -> forward, optical x -> −left).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <string>
#include <vector>

namespace homography_teach_repeat {

// Wraps an angle to (−π, π].
double wrapToPi(double angle);

// REP-103 planar pose: x forward [m], y left [m], yaw counter-clockwise about z up [rad].
struct Pose2D {
  double x = 0.0;
  double y = 0.0;
  double yaw = 0.0;

  Pose2D() = default;
  Pose2D(double x_in, double y_in, double yaw_in) : x(x_in), y(y_in), yaw(yaw_in) {}

  // this ∘ other: `other` is expressed in the frame of `this`.
  Pose2D compose(const Pose2D& other) const;
  Pose2D inverse() const;
  // Maps a point expressed in this pose's frame into the parent frame.
  Eigen::Vector2d transformPoint(const Eigen::Vector2d& point) const;
  bool isFinite() const;
};

// Whether a sequence of poses is a loop: at least 3 poses and the last within `max_gap` [m] of the
// first (max_gap <= 0: never).
bool isClosedLoop(const std::vector<Pose2D>& poses, double max_gap);

// Camera-convention planar pose of docs/math.md §1.1 (x right [m], z forward [m], theta = θ12 [rad]).
struct PlanarPose {
  double x = 0.0;
  double z = 0.0;
  double theta = 0.0;

  PlanarPose() = default;
  PlanarPose(double x_in, double z_in, double theta_in) : x(x_in), z(z_in), theta(theta_in) {}

  // T_13 = T_12 ∘ T_23 (`other` is the pose of camera 3 in the frame of camera 2).
  PlanarPose compose(const PlanarPose& other) const;
  // Pose of camera 1 in the frame of camera 2.
  PlanarPose inverse() const;
  // X1 = (x, z) + R2(theta) X2 for a point (x2, z2) of frame 2.
  Eigen::Vector2d transformPoint(const Eigen::Vector2d& point_xz) const;

  // 3D rigid transform mapping frame-2 coordinates to frame-1 coordinates (camera axes).
  Eigen::Isometry3d toIsometry() const;
  // R21 = Ry(θ21) of docs/math.md §1.1 and C = (x, 0, z): X2 = R21 (X1 − C).
  Eigen::Matrix3d rotation21() const;
  Eigen::Vector3d centre() const { return Eigen::Vector3d(x, 0.0, z); }

  bool isFinite() const;
};

// Planar mounting of a level camera on the robot base.
class CameraMount {
 public:
  // Camera forward frame in base_link: position (x, y) [m] of the optical centre and yaw [rad] of
  // the optical axis. Throws std::invalid_argument on non-finite values.
  CameraMount(double x, double y, double yaw);

  // From the full extrinsic base_link -> optical frame (tf's base_T_optical). The camera must be
  // level: the optical y axis (down) within `max_tilt_rad` of −z of base_link, because Fast-HD
  // assumes the camera moves in its own XZ plane. Throws std::invalid_argument otherwise, naming
  // the measured tilt.
  static CameraMount fromExtrinsic(const Eigen::Isometry3d& base_T_optical, double max_tilt_rad);
  // The angle [rad] between the optical y axis (down) and the downward vertical of base_link: 0
  // for a level camera; NaN for a non-finite or non-orthonormal extrinsic.
  static double tiltOf(const Eigen::Isometry3d& base_T_optical);
  // The optical axis' elevation [rad] above base_link's horizontal plane (> 0: looking up).
  static double elevationOf(const Eigen::Isometry3d& base_T_optical);
  // The rotation of the optical frame into the level camera frame (CameraCalibration::
  // camera_to_level, docs/math.md §1.1): the level frame has y along base_link's −z and z along
  // the optical axis turned into base_link's horizontal plane (the forward frame's yaw). Identity
  // for a level camera. Throws std::invalid_argument for a non-finite or non-orthonormal extrinsic
  // or an optical axis within 1° of the vertical (no forward direction).
  static Eigen::Matrix3d cameraToLevel(const Eigen::Isometry3d& base_T_optical);

  const Pose2D& forwardFrame() const { return forward_frame_; }

  // Relative camera pose (camera 2 in camera 1) -> relative base pose (base 2 in base 1).
  Pose2D cameraToBase(const PlanarPose& camera_relative) const;
  // Inverse of cameraToBase.
  PlanarPose baseToCamera(const Pose2D& base_relative) const;

  // 3x3 Jacobian d(x, y, yaw)_base / d(x, z, theta)_camera of cameraToBase at `camera_relative`,
  // for propagating a covariance: Σ_base = J Σ_camera Jᵀ.
  Eigen::Matrix3d cameraToBaseJacobian(const PlanarPose& camera_relative) const;

 private:
  Pose2D forward_frame_;
};

// F of the header comment: camera-convention pose re-labelled as a REP-103 pose (no mount).
Pose2D cameraAxesToRep103(const PlanarPose& pose);
PlanarPose rep103ToCameraAxes(const Pose2D& pose);

}  // namespace homography_teach_repeat
