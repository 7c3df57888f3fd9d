#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "support/geometry_fixtures.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

using namespace homography_teach_repeat;
using test_support::expectPoseNear;
using test_support::mathCamera;
using test_support::planeFromAngles;

namespace {
const PlanarPose kTruth(0.6, -1.4, -0.25);
const ScenePlane kPlane = planeFromAngles(0.35, 0.2, 5.0);

PointMatches exactMatches(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  return sampleVisiblePlaneMatches(mathCamera(), kPlane, kTruth, count, &rng);
}
}  // namespace

TEST(PlanarPoseEstimator, ExactFromInliers) {
  PlanarPoseEstimatorOptions options;
  const auto estimate = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane,
                                                      options);
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_TRUE(estimate->refined);
  expectPoseNear(estimate->pose, kTruth, 1e-9);
  expectPoseNear(estimate->fast_hd_pose, kTruth, 1e-9);
  EXPECT_EQ(estimate->inliers.size(), 30u);
}

TEST(PlanarPoseEstimator, RobustToOutliers) {
  PointMatches matches = exactMatches(80, 2);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 639.0), v(0.0, 479.0);
  for (int i = 0; i < 30; ++i) matches.push_back({{u(rng), v(rng)}, {u(rng), v(rng)}});
  PlanarPoseEstimatorOptions options;
  const auto estimate = estimatePlanarPose(matches, mathCamera(), kPlane, options);
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  expectPoseNear(estimate->pose, kTruth, 1e-8);
  EXPECT_GE(estimate->inliers.size(), 80u);
  EXPECT_LE(estimate->inliers.size(), 82u);
}

// Every failure is a status, never a pose (issue: fewer than 4 matches, collinear points,
// floor/ceiling plane, non-finite input).
TEST(PlanarPoseEstimator, FailureStatuses) {
  PlanarPoseEstimatorOptions options;
  const PointMatches three = exactMatches(3, 4);
  EXPECT_EQ(estimatePlanarPoseFromInliers(three, mathCamera(), kPlane, options).status().code(),
            StatusCode::kTooFewPoints);
  EXPECT_EQ(estimatePlanarPose(three, mathCamera(), kPlane, options).status().code(),
            StatusCode::kTooFewPoints);

  PointMatches collinear;
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector2d p(50.0 + 40.0 * i, 100.0 + 20.0 * i);
    collinear.push_back({p, p + Eigen::Vector2d(3.0, 1.0)});
  }
  EXPECT_EQ(estimatePlanarPoseFromInliers(collinear, mathCamera(), kPlane, options).status().code(),
            StatusCode::kDegenerate);

  ScenePlane floor;
  floor.normal = Eigen::Vector3d::UnitY();
  floor.distance = 0.8;
  EXPECT_EQ(estimatePlanarPoseFromInliers(exactMatches(20, 5), mathCamera(), floor, options)
                .status()
                .code(),
            StatusCode::kDegenerate);

  PointMatches with_nan = exactMatches(20, 6);
  with_nan[4].reference.y() = std::nan("");
  EXPECT_EQ(estimatePlanarPoseFromInliers(with_nan, mathCamera(), kPlane, options).status().code(),
            StatusCode::kInvalidInput);
}

TEST(PlanarPoseEstimator, OptionsValidation) {
  PlanarPoseEstimatorOptions options;
  EXPECT_NO_THROW(options.validate());
  options.pixel_sigma_px = 0.0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options.pixel_sigma_px = 1.0;
  options.refinement_max_iterations = 0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
}
