// Decompositions of a plane-induced homography into motion and plane: the classic one (OpenCV's
// cv::decomposeHomographyMat, up to 4 solutions) with the filters of docs/math.md §2.1, and the
// decomposition for planar motion (Planar-HD, written here). Plane estimation (§2.1) uses the
// classic one; Planar-HD is a baseline for eval_fast_hd.
//
// Conventions (docs/math.md §1.1-1.2): H21 ∝ K (R21 + T Nᵀ) K⁻¹ with X2 = R21 X1 + T·d1 (OpenCV's
// form; T = −t21/d1), N the unit plane normal in the reference frame, positive depth Nᵀ K⁻¹ p > 0.
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct HomographyDecomposition {
  Eigen::Matrix3d rotation21 = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_over_distance = Eigen::Vector3d::Zero();  // T = −t21/d1
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();                    // N, reference frame

  // Planar motion about the camera's y axis: |R(1,1) − 1| < eps and |T_y| < eps (docs/math.md §2.1).
  bool isPlanarMotion(double eps) const;
  // The planar pose (Cx, Cz, θ12) this solution implies for a plane at distance d1: t21 = −T d1,
  // C = R21ᵀ t21, θ21 the yaw of R21 (any out-of-plane rotation is dropped).
  PlanarPose planarPose(double plane_distance) const;
  ScenePlane plane(double plane_distance) const { return ScenePlane{normal, plane_distance}; }
};

// All algebraic solutions of cv::decomposeHomographyMat (usually 4). Status: kNotFinite,
// kDegenerate (OpenCV found none).
Expected<std::vector<HomographyDecomposition>> decomposeHomographyClassic(
    const Eigen::Matrix3d& H, const PinholeCamera& camera);

// Keeps the solutions for which every reference pixel has positive depth (Nᵀ K⁻¹ p > 0), or, with
// `min_fraction` < 1, at least that fraction of them. In forward motion some inliers sit near the
// vanishing point, where the plane is seen at a grazing angle and a pixel's depth sign is decided
// by noise; on a real street (KITTI 07) 1-9 % of the inliers did, and requiring all of them
// dropped the true solution (docs/evaluation.md, "Recorded sequences"). Above 0.5 at most one of
// each (N, −N) pair is kept.
std::vector<HomographyDecomposition> filterByPositiveDepth(
    const std::vector<HomographyDecomposition>& solutions, const PinholeCamera& camera,
    const std::vector<Eigen::Vector2d>& reference_pixels, double min_fraction = 1.0);

// Planar-HD: the decomposition for planar motion (X2 = Ry(θ21) X1 + T d1, T_y = 0). With
// M = K⁻¹HK/κ − Ry(θ21), rows 1 and 3 of M are −(T_x, T_z) Nᵀ (rank one), so their 2x2 minor
// on columns (1, 3) vanishes: (M11)(M33) − (M13)(M31) = 0, which is linear in (cosθ, sinθ):
//   −(m11 + m33) cosθ + (m13 − m31) sinθ = −(1 + m11 m33 − m13 m31)
// (m = K⁻¹HK/κ). Its two roots on the unit circle give two solutions (one when tangent); N is the
// dominant right singular vector of those rows, signed for positive depth of `reference_pixels`
// (or +z when none are given), T = M N. Status: kNotFinite, kDegenerate (κ = 0).
Expected<std::vector<HomographyDecomposition>> decomposeHomographyPlanar(
    const Eigen::Matrix3d& H, const PinholeCamera& camera,
    const std::vector<Eigen::Vector2d>& reference_pixels = {});

}  // namespace homography_teach_repeat
