#include <gtest/gtest.h>

#include <cmath>
#include <iostream>
#include <random>

#include "support/geometry_fixtures.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/homography_refinement.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

using namespace homography_teach_repeat;
using test_support::mathCamera;
using test_support::planeFromAngles;

namespace {
const PlanarPose kPose(0.6, -1.4, -0.25);
const ScenePlane kPlane = planeFromAngles(0.35, 0.2, 5.0);

Eigen::Matrix3d trueH() { return planeInducedHomography(mathCamera(), kPose, kPlane); }

PointMatches exactMatches(int n, unsigned seed) {
  std::mt19937_64 rng(seed);
  return sampleVisiblePlaneMatches(mathCamera(), kPlane, kPose, n, &rng);
}

// Same ray up to sign and scale.
double homographyDistance(Eigen::Matrix3d a, Eigen::Matrix3d b) {
  a /= a.norm();
  b /= b.norm();
  return std::min((a - b).norm(), (a + b).norm());
}
}  // namespace

TEST(HomographyRefinement, ExactDataConvergesToTheTruth) {
  const PointMatches matches = exactMatches(30, 1);
  Eigen::Matrix3d start = trueH();
  start(0, 2) += 0.01 * start.norm();
  start(2, 0) += 1e-5 * start.norm();
  const auto refined = refineHomographySampson(start, matches);
  ASSERT_TRUE(refined.isOk()) << refined.status().toString();
  EXPECT_LT(homographyDistance(refined->H, trueH()), 1e-9);
  EXPECT_LT(refined->rms_sampson_px, 1e-7);
  EXPECT_GT(refined->initial_rms_sampson_px, 0.1);
}

// On noisy data the refinement never increases the Sampson distance of the DLT and, averaged
// over trials, brings H closer to the truth (the DLT minimises an algebraic error).
TEST(HomographyRefinement, ImprovesOnTheDlt) {
  const PointMatches exact = exactMatches(40, 2);
  std::mt19937_64 rng(3);
  double dlt_error = 0.0, refined_error = 0.0;
  const int trials = 60;
  for (int t = 0; t < trials; ++t) {
    const PointMatches noisy = test_support::addPixelNoise(exact, 1.0, &rng);
    const auto dlt = estimateHomographyDlt(noisy);
    ASSERT_TRUE(dlt.isOk());
    const auto refined = refineHomographySampson(*dlt, noisy);
    ASSERT_TRUE(refined.isOk());
    EXPECT_LE(refined->rms_sampson_px, rmsSampsonDistance(*dlt, noisy) + 1e-12);
    dlt_error += *meanGridTransferDifference(*dlt, trueH(), 640, 480, 640, 480, 20);
    refined_error += *meanGridTransferDifference(refined->H, trueH(), 640, 480, 640, 480, 20);
  }
  EXPECT_LT(refined_error, dlt_error);
  std::cout << "mean grid error vs truth over " << trials << " trials: DLT " << dlt_error / trials
            << " px, refined " << refined_error / trials << " px\n";
}

TEST(HomographyRefinement, RobustOptionRefinesOnTheInliers) {
  std::mt19937_64 rng(4);
  PointMatches matches = test_support::addPixelNoise(exactMatches(60, 5), 0.5, &rng);
  std::uniform_real_distribution<double> u(0.0, 639.0), v(0.0, 479.0);
  for (int i = 0; i < 20; ++i) matches.push_back({{u(rng), v(rng)}, {u(rng), v(rng)}});
  RobustHomographyOptions options;
  options.refine_nonlinear = true;
  const auto robust = estimateHomographyRobust(matches, options);
  ASSERT_TRUE(robust.isOk()) << robust.status().toString();
  EXPECT_GE(robust->inliers.size(), 50u);  // the adaptive 95% radius drops a few
  EXPECT_LT(*meanGridTransferDifference(robust->H, trueH(), 640, 480, 640, 480, 20), 0.5);
}

TEST(HomographyRefinement, FailureStatuses) {
  const PointMatches matches = exactMatches(10, 6);
  const PointMatches three(matches.begin(), matches.begin() + 3);
  EXPECT_EQ(refineHomographySampson(trueH(), three).status().code(), StatusCode::kTooFewPoints);
  Eigen::Matrix3d nan_h = trueH();
  nan_h(1, 1) = std::nan("");
  EXPECT_EQ(refineHomographySampson(nan_h, matches).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(refineHomographySampson(Eigen::Matrix3d::Zero(), matches).status().code(),
            StatusCode::kInvalidInput);
  PointMatches bad = matches;
  bad[2].reference.x() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(refineHomographySampson(trueH(), bad).status().code(), StatusCode::kInvalidInput);
  HomographyRefinementOptions options;
  options.max_iterations = 0;
  EXPECT_EQ(refineHomographySampson(trueH(), matches, options).status().code(),
            StatusCode::kInvalidInput);
}
