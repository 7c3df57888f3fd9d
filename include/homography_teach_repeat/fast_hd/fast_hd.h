// Fast Homography Decomposition (Fast-HD, paper 000 §II) with the corrections of docs/math.md §1:
// the planar pose (x, z, θ) of the current camera in the frame of a reference camera from one
// homography of a plane whose normal and distance in the reference frame are known. Constant
// time, unique solution (the known normal removes the classic decomposition's ambiguity, §1.8).
//
// Implementation order (docs/math.md §1.9):
//   κ = H(2,2) − v0 H(3,2)                        (1-based; the exact normaliser, §1.3)
//   Hn = H/κ;  c11, c13, c31, c33 and b = d1 (c11, c13, c31, c33)           (§1.4, corrected eq. 4)
//   x21, z21, S, C from the closed-form inverse of Π; θ21 = atan2(S, C)     (§1.4)
//   Cx = cosθ21 x21 + sinθ21 z21,  Cz = −sinθ21 x21 + cosθ21 z21,  θ12 = −θ21   (§1.6)
// H maps reference pixels to current pixels (p2 ∝ H21 p1), undistorted, any scale and sign.
#pragma once

#include <Eigen/Core>

#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// The intermediate solution of Π s* = b (docs/math.md §1.4), kept for the covariance (§3.4).
struct FastHdSolution {
  PlanarPose pose;          // camera 2 in the reference frame: (Cx, Cz, θ12)
  double x21 = 0.0;         // t21 = R21 C
  double z21 = 0.0;
  double sin_theta21 = 0.0;  // S and C of atan2(S, C); S² + C² = 1 only for exact data
  double cos_theta21 = 0.0;
  double kappa = 0.0;       // H(2,2) − v0 H(3,2) of the input H
};

// Status: kNotFinite (H has NaN/Inf), kDegenerate (|κ| ≈ 0 relative to |H|, floor/ceiling
// plane), kInvalidInput (bad plane).
Expected<FastHdSolution> solveFastHd(const Eigen::Matrix3d& H, const PinholeCamera& camera,
                                     const ScenePlane& plane);

}  // namespace homography_teach_repeat
