#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <random>

#include "support/geometry_fixtures.h"
#include "homography_teach_repeat/fast_hd/planar_pose_refinement.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

using namespace homography_teach_repeat;
using test_support::expectPoseNear;
using test_support::mathCamera;
using test_support::planeFromAngles;

namespace {
const PlanarPose kTruth(-1.1, 0.9, 0.45);  // scene B of docs/math.md §3.5
const ScenePlane kPlane = planeFromAngles(-0.5, 0.0, 7.0);

PointMatches matchesOf(const ScenePlane& plane, int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  return sampleVisiblePlaneMatches(mathCamera(800.0), plane, kTruth, count, &rng);
}
}  // namespace

TEST(PlanarPoseRefinement, ModelHomographyIsThePlaneInducedOne) {
  const Eigen::Matrix3d a = poseHomography(mathCamera(), kTruth, kPlane);
  const Eigen::Matrix3d b = planeInducedHomography(mathCamera(), kTruth, kPlane);
  EXPECT_LT((a / a.norm() - b).norm(), 1e-12);
}

TEST(PlanarPoseRefinement, ConvergesToTheTruthOnExactData) {
  const PointMatches matches = matchesOf(kPlane, 30, 1);
  const PlanarPose start(kTruth.x + 0.3, kTruth.z - 0.4, kTruth.theta + 0.05);
  const auto refined = refinePlanarPose(start, {{kPlane, matches}}, mathCamera(800.0));
  ASSERT_TRUE(refined.isOk()) << refined.status().toString();
  expectPoseNear(refined->pose, kTruth, 1e-9);
  EXPECT_LT(refined->rms_transfer_error_px, 1e-7);
  EXPECT_GT(refined->iterations, 1);
}

// Two planes refined jointly: each constrains the pose, together better than either.
TEST(PlanarPoseRefinement, JointRefinementOverTwoPlanes) {
  const ScenePlane second = planeFromAngles(0.6, 0.0, 5.0);
  const PointMatches a = matchesOf(kPlane, 25, 2);
  const PointMatches b = matchesOf(second, 25, 3);
  const auto refined = refinePlanarPose(PlanarPose(-1.0, 1.0, 0.4), {{kPlane, a}, {second, b}},
                                        mathCamera(800.0));
  ASSERT_TRUE(refined.isOk()) << refined.status().toString();
  expectPoseNear(refined->pose, kTruth, 1e-9);
  const auto only_a = refinePlanarPose(kTruth, {{kPlane, a}}, mathCamera(800.0));
  ASSERT_TRUE(only_a.isOk());
  EXPECT_LT(refined->covariance.trace(), only_a->covariance.trace());
}

// The sandwich covariance against a Monte Carlo of the refinement (fixed seed).
TEST(PlanarPoseRefinement, CovarianceAgreesWithMonteCarlo) {
  const PointMatches exact = matchesOf(kPlane, 20, 4);
  PoseRefinementOptions options;
  options.sigma_px = 1.0;
  const auto predicted = refinePlanarPose(kTruth, {{kPlane, exact}}, mathCamera(800.0), options);
  ASSERT_TRUE(predicted.isOk());
  std::mt19937_64 rng(12);
  const int trials = 500;
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int t = 0; t < trials; ++t) {
    const auto noisy = test_support::addPixelNoise(exact, 1.0, &rng);
    const auto refined = refinePlanarPose(kTruth, {{kPlane, noisy}}, mathCamera(800.0), options);
    ASSERT_TRUE(refined.isOk());
    const Eigen::Vector3d e(refined->pose.x - kTruth.x, refined->pose.z - kTruth.z,
                            wrapToPi(refined->pose.theta - kTruth.theta));
    sum += e;
    outer += e * e.transpose();
  }
  const Eigen::Vector3d mean = sum / trials;
  const Eigen::Matrix3d empirical = outer / trials - mean * mean.transpose();
  for (int k = 0; k < 3; ++k) {
    const double ratio = std::sqrt(predicted->covariance(k, k) / empirical(k, k));
    EXPECT_GT(ratio, 0.85) << "component " << k;
    EXPECT_LT(ratio, 1.18) << "component " << k;
  }
}

// The reference image's share of the covariance (reference_noise_covariance, docs/math.md §3.4):
// a Monte Carlo with noise on the reference pixels only spreads the pose as it says, one with noise
// on the current pixels only as the rest. The current camera has come 3 m closer to a wall 6 m
// away: the reference's pixels are magnified twice in it, so the reference's share is the larger
// (not the half that equal shares would give).
TEST(PlanarPoseRefinement, ReferenceNoiseCovarianceIsTheReferenceImagesShare) {
  const PlanarPose truth(0.3, 3.0, 0.1);
  const ScenePlane wall = planeFromAngles(0.2, 0.0, 6.0);
  std::mt19937_64 scene(4);
  const PointMatches exact = sampleVisiblePlaneMatches(mathCamera(800.0), wall, truth, 30, &scene);
  PoseRefinementOptions options;
  options.sigma_px = 1.0;
  const auto predicted = refinePlanarPose(truth, {{wall, exact}}, mathCamera(800.0), options);
  ASSERT_TRUE(predicted.isOk());
  const Eigen::Matrix3d reference_part = predicted->reference_noise_covariance;
  const Eigen::Matrix3d current_part = predicted->covariance - reference_part;
  EXPECT_GT(reference_part.eigenvalues().real().minCoeff(), 0.0);
  EXPECT_GT(current_part.eigenvalues().real().minCoeff(), 0.0);
  EXPECT_GT(reference_part(0, 0), 0.65 * predicted->covariance(0, 0));
  for (const bool noisy_reference : {true, false}) {
    std::mt19937_64 rng(noisy_reference ? 31 : 32);
    std::normal_distribution<double> noise(0.0, 1.0);
    const int trials = 500;
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (int t = 0; t < trials; ++t) {
      PointMatches noisy = exact;
      for (PointMatch& m : noisy) (noisy_reference ? m.reference : m.current) += Eigen::Vector2d(noise(rng), noise(rng));
      const auto refined = refinePlanarPose(truth, {{wall, noisy}}, mathCamera(800.0), options);
      ASSERT_TRUE(refined.isOk());
      const Eigen::Vector3d e(refined->pose.x - truth.x, refined->pose.z - truth.z,
                              wrapToPi(refined->pose.theta - truth.theta));
      sum += e;
      outer += e * e.transpose();
    }
    const Eigen::Vector3d mean = sum / trials;
    const Eigen::Matrix3d empirical = outer / trials - mean * mean.transpose();
    const Eigen::Matrix3d& part = noisy_reference ? reference_part : current_part;
    for (int k = 0; k < 3; ++k) {
      const double ratio = std::sqrt(part(k, k) / empirical(k, k));
      EXPECT_GT(ratio, 0.85) << (noisy_reference ? "reference" : "current") << " component " << k;
      EXPECT_LT(ratio, 1.18) << (noisy_reference ? "reference" : "current") << " component " << k;
    }
  }
}

// The plane's error moves the refined pose as plane_jacobian says (docs/math.md §3.6): each
// column against refining again with the plane turned by 1 mrad across its normal (both
// directions) about the matched points' centroid on it, or moved by 0.1 % of its distance, from
// noisy matches; the distance column is (Cx, Cz, 0): the translation scales with the distance.
TEST(PlanarPoseRefinement, PlaneJacobianIsHowTheRefinedPoseMovesWithThePlane) {
  std::mt19937_64 rng(21);
  const PointMatches noisy = test_support::addPixelNoise(matchesOf(kPlane, 60, 5), 0.5, &rng);
  PoseRefinementOptions options;
  options.sigma_px = 0.5;
  options.plane_sensitivity = true;
  const auto refined = refinePlanarPose(kTruth, {{kPlane, noisy}}, mathCamera(800.0), options);
  ASSERT_TRUE(refined.isOk()) << refined.status().toString();
  const Eigen::Matrix3d& J = refined->plane_jacobian;
  const auto [across1, across2] = directionsAcrossNormal(kPlane.normal);
  EXPECT_NEAR(across1.dot(kPlane.normal), 0.0, 1e-12);
  EXPECT_NEAR(across2.dot(kPlane.normal), 0.0, 1e-12);
  EXPECT_NEAR(across1.y(), 0.0, 1e-12);  // the wall turned about the vertical
  constexpr double kStep = 1e-3;
  std::vector<Eigen::Vector3d> rays;
  for (const PointMatch& match : noisy) rays.push_back(mathCamera(800.0).Kinverse() * match.reference.homogeneous());
  const auto centroid = centroidOnPlane(kPlane, rays);
  ASSERT_TRUE(centroid.has_value());
  for (int k = 0; k < 3; ++k) {
    ScenePlane moved = kPlane;
    if (k < 2) moved = turnedAbout(kPlane, kPlane.normal + kStep * (k == 0 ? across1 : across2), *centroid);
    if (k == 2) moved.distance = kPlane.distance * (1.0 + kStep);
    PoseRefinementOptions again = options;
    again.plane_sensitivity = false;
    const auto other = refinePlanarPose(refined->pose, {{moved, noisy}}, mathCamera(800.0), again);
    ASSERT_TRUE(other.isOk()) << other.status().toString();
    const Eigen::Vector3d change(other->pose.x - refined->pose.x, other->pose.z - refined->pose.z,
                                 wrapToPi(other->pose.theta - refined->pose.theta));
    const Eigen::Vector3d predicted = kStep * J.col(k);
    EXPECT_GT(predicted.norm(), 1e-5) << "column " << k;
    // Within 10 %: JᵀJ stands in for the Hessian, whose residual term (noisy matches) and the
    // height offset nuisance, which a leaning wall moves with it, make a few percent (4.7 % here).
    EXPECT_LT((change - predicted).norm(), 0.1 * predicted.norm() + 1e-9) << "column " << k << ": moved "
                                                                          << change.transpose() << ", predicted "
                                                                          << predicted.transpose();
  }
  EXPECT_NEAR(J(0, 2), refined->pose.x, 1e-3 * std::abs(refined->pose.x));
  EXPECT_NEAR(J(1, 2), refined->pose.z, 1e-3 * std::abs(refined->pose.z));
  EXPECT_NEAR(J(2, 2), 0.0, 1e-4);  // the heading does not scale with the distance (1e-5 with the noise)
  options.plane_sensitivity = false;
  const auto without = refinePlanarPose(kTruth, {{kPlane, noisy}}, mathCamera(800.0), options);
  ASSERT_TRUE(without.isOk());
  EXPECT_EQ(without->plane_jacobian, Eigen::Matrix3d::Zero());
}

TEST(PlanarPoseRefinement, FailureStatuses) {
  const PointMatches matches = matchesOf(kPlane, 10, 5);
  const PinholeCamera camera = mathCamera(800.0);
  EXPECT_EQ(refinePlanarPose(kTruth, {{kPlane, {matches[0]}}}, camera).status().code(),
            StatusCode::kTooFewPoints);
  EXPECT_EQ(refinePlanarPose(kTruth, {}, camera).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(refinePlanarPose(PlanarPose(std::nan(""), 0, 0), {{kPlane, matches}}, camera)
                .status()
                .code(),
            StatusCode::kInvalidInput);
  PointMatches bad = matches;
  bad[3].current.x() = std::numeric_limits<double>::infinity();
  EXPECT_EQ(refinePlanarPose(kTruth, {{kPlane, bad}}, camera).status().code(),
            StatusCode::kInvalidInput);
  // A start with the camera on the plane: the model homography is singular.
  const PlanarPose on_plane(kPlane.normal.x() * kPlane.distance, kPlane.normal.z() * kPlane.distance,
                            0.0);
  EXPECT_EQ(refinePlanarPose(on_plane, {{kPlane, matches}}, camera).status().code(),
            StatusCode::kDegenerate);
  PoseRefinementOptions options;
  options.max_iterations = 0;
  EXPECT_EQ(refinePlanarPose(kTruth, {{kPlane, matches}}, camera, options).status().code(),
            StatusCode::kInvalidInput);
}

// The current camera pitched 1° and rolled 0.6° (a robot without an IMU, docs/math.md §1.10): the
// 3-DoF model reads the tilt as a wrong pose; with the tilt as a nuisance pair it recovers the pose
// and the tilt exactly, and the covariance grows by the tilt's share.
TEST(PlanarPoseRefinement, TiltNuisanceRecoversATiltedCamera) {
  const double pitch = 1.0 * M_PI / 180.0, roll = 0.6 * M_PI / 180.0;
  Eigen::Matrix3d Rx, Rz;
  Rx << 1, 0, 0, 0, std::cos(pitch), -std::sin(pitch), 0, std::sin(pitch), std::cos(pitch);
  Rz << std::cos(roll), -std::sin(roll), 0, std::sin(roll), std::cos(roll), 0, 0, 0, 1;
  const PinholeCamera camera = mathCamera(800.0);
  const Eigen::Matrix3d rotate = camera.K() * Rx * Rz * camera.Kinverse();
  PointMatches tilted = matchesOf(kPlane, 40, 5);
  for (auto& m : tilted) m.current = (rotate * m.current.homogeneous()).hnormalized();

  PoseRefinementOptions level;
  level.sigma_px = 0.5;
  const auto biased = refinePlanarPose(kTruth, {{kPlane, tilted}}, camera, level);
  ASSERT_TRUE(biased.isOk()) << biased.status().toString();
  const double biased_error = std::hypot(biased->pose.x - kTruth.x, biased->pose.z - kTruth.z);
  EXPECT_GT(biased_error, 0.02);
  EXPECT_GT(biased->rms_transfer_error_px, 1.0);

  PoseRefinementOptions with_tilt = level;
  with_tilt.tilt_sigma_rad = 0.05;
  const auto refined = refinePlanarPose(PlanarPose(kTruth.x + 0.1, kTruth.z - 0.1, kTruth.theta + 0.02),
                                        {{kPlane, tilted}}, camera, with_tilt);
  ASSERT_TRUE(refined.isOk()) << refined.status().toString();
  expectPoseNear(refined->pose, kTruth, 1e-3);  // the prior pulls the tilt slightly towards 0
  EXPECT_LT(refined->rms_transfer_error_px, 0.05);
  EXPECT_LT((refined->tilt - Rx * Rz).norm(), 1e-3);

  // On level data the nuisance costs precision only: the same pose, a larger covariance.
  const PointMatches exact = matchesOf(kPlane, 40, 5);
  const auto plain = refinePlanarPose(kTruth, {{kPlane, exact}}, camera, level);
  const auto nuisance = refinePlanarPose(kTruth, {{kPlane, exact}}, camera, with_tilt);
  ASSERT_TRUE(plain.isOk() && nuisance.isOk());
  expectPoseNear(nuisance->pose, kTruth, 1e-9);
  EXPECT_GE(nuisance->covariance.trace(), plain->covariance.trace());
}
