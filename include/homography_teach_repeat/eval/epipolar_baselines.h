// Epipolar baselines for the comparison of eval_fast_hd (paper 000 Table I): the 8-point
// fundamental matrix and the 5-point essential matrix, both from OpenCV, with cv::recoverPose
// choosing the motion by cheirality. They give the translation direction only; the caller
// supplies the metric baseline. A planar scene is a degenerate configuration for F (paper 000:
// "homography algorithms have better performance ... because the features are in planes").
#pragma once

#include <Eigen/Core>

#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

// X2 = R21 X1 + t·scale, |t| = 1.
struct EpipolarMotion {
  Eigen::Matrix3d rotation21 = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation_direction = Eigen::Vector3d::UnitZ();
  int cheirality_inliers = 0;  // points in front of both cameras (recoverPose)

  // (Cx, Cz, θ12) with |C| = baseline: C = −R21ᵀ t·baseline, θ21 the yaw of R21.
  PlanarPose planarPose(double baseline) const;
};

// Status: kTooFewPoints (< 8), kDegenerate (OpenCV returned no F), kNotFinite.
Expected<EpipolarMotion> motionFromEightPointF(const PointMatches& matches,
                                               const PinholeCamera& camera);

// 5-point (Nistér) inside OpenCV's RANSAC with a `threshold_px` inlier threshold; of the returned
// essential matrices the one with most cheirality inliers wins. Status: kTooFewPoints (< 5),
// kDegenerate (no E), kNotFinite.
Expected<EpipolarMotion> motionFromFivePointE(const PointMatches& matches,
                                              const PinholeCamera& camera,
                                              double threshold_px = 1.0);

}  // namespace homography_teach_repeat
