#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <Eigen/Eigenvalues>

#include "support/geometry_fixtures.h"
#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/fast_hd/fast_hd_covariance.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"
#include "homography_teach_repeat/homography/homography.h"

using namespace homography_teach_repeat;
using test_support::mathCamera;
using test_support::planeFromAngles;

namespace {

// Scene A of docs/math.md §3.5.
const PlanarPose kSceneAPose(0.6, -1.4, -0.25);
const ScenePlane kSceneAPlane = planeFromAngles(0.35, 0.2, 5.0);

Eigen::Vector3d poseVector(const PlanarPose& p) { return Eigen::Vector3d(p.x, p.z, p.theta); }

PointMatches sceneAMatches(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  return sampleVisiblePlaneMatches(mathCamera(), kSceneAPlane, kSceneAPose, count, &rng);
}

}  // namespace

// J_g against central differences of solveFastHd on each entry of H (docs/math.md §3.4 step 2).
TEST(FastHdCovariance, FastHdJacobianMatchesFiniteDifferences) {
  const Eigen::Matrix3d H = 3.7 * planeInducedHomography(mathCamera(), kSceneAPose, kSceneAPlane);
  const auto jacobian = fastHdJacobian(H, mathCamera(), kSceneAPlane);
  ASSERT_TRUE(jacobian.isOk()) << jacobian.status().toString();
  for (int k = 0; k < 9; ++k) {
    // Relative steps: the perspective entries are ~1e-3 of the others.
    const double step = 1e-5 * std::max(std::abs(H(k / 3, k % 3)), 1e-6 * H.norm());
    Eigen::Matrix3d plus = H, minus = H;
    plus(k / 3, k % 3) += step;
    minus(k / 3, k % 3) -= step;
    const Eigen::Vector3d numeric =
        (poseVector(solveFastHd(plus, mathCamera(), kSceneAPlane)->pose) -
         poseVector(solveFastHd(minus, mathCamera(), kSceneAPlane)->pose)) /
        (2.0 * step);
    EXPECT_LE((numeric - jacobian->col(k)).norm(), 1e-6 * jacobian->col(k).norm()) << "h" << k;
  }
}

// J_g·h = 0: scaling H does not move the pose (docs/math.md §3.4).
TEST(FastHdCovariance, FastHdJacobianAnnihilatesH) {
  const Eigen::Matrix3d H = planeInducedHomography(mathCamera(), kSceneAPose, kSceneAPlane);
  const auto jacobian = fastHdJacobian(H, mathCamera(), kSceneAPlane);
  ASSERT_TRUE(jacobian.isOk());
  Eigen::Matrix<double, 9, 1> h;
  for (int k = 0; k < 9; ++k) h(k) = H(k / 3, k % 3);
  EXPECT_LT((*jacobian * h).norm(), 1e-10 * jacobian->norm());
}

// The chain J_g J_h against central differences of the whole pipeline (DLT then Fast-HD) on
// every pixel coordinate.
TEST(FastHdCovariance, PipelineJacobianMatchesFiniteDifferences) {
  const PointMatches matches = sceneAMatches(12, 3);
  ASSERT_EQ(matches.size(), 12u);
  const auto dlt = solveNormalizedDlt(matches);
  ASSERT_TRUE(dlt.isOk());
  const auto j_g = fastHdJacobian(dlt->H_unscaled, mathCamera(), kSceneAPlane);
  ASSERT_TRUE(j_g.isOk());
  const Eigen::MatrixXd analytic = *j_g * normalizedDltJacobian(*dlt, matches);
  ASSERT_EQ(analytic.cols(), 48);
  auto pipeline = [&](const PointMatches& m) {
    return poseVector(
        solveFastHd(solveNormalizedDlt(m)->H_unscaled, mathCamera(), kSceneAPlane)->pose);
  };
  const double step = 1e-5;
  double worst = 0.0;
  for (int j = 0; j < analytic.cols(); ++j) {
    PointMatches plus = matches, minus = matches;
    auto& p = plus[j / 4];
    auto& q = minus[j / 4];
    double* a = (j % 4 < 2) ? &p.reference(j % 2) : &p.current(j % 2);
    double* b = (j % 4 < 2) ? &q.reference(j % 2) : &q.current(j % 2);
    *a += step;
    *b -= step;
    const Eigen::Vector3d numeric = (pipeline(plus) - pipeline(minus)) / (2.0 * step);
    worst = std::max(worst, (numeric - analytic.col(j)).norm());
  }
  EXPECT_LT(worst, 1e-6 * analytic.norm());
}

// The O(n) covariance equals σ² (J_g J_h)(J_g J_h)ᵀ with the dense J_h.
TEST(FastHdCovariance, MatchesDenseProduct) {
  std::mt19937_64 rng(5);
  const PointMatches matches = test_support::addPixelNoise(sceneAMatches(40, 4), 0.5, &rng);
  const auto dlt = solveNormalizedDlt(matches);
  ASSERT_TRUE(dlt.isOk());
  const auto covariance =
      fastHdCovariance(*dlt, matches, mathCamera(), kSceneAPlane, 0.7, /*second_order=*/false);
  ASSERT_TRUE(covariance.isOk());
  const Eigen::MatrixXd j =
      *fastHdJacobian(dlt->H_unscaled, mathCamera(), kSceneAPlane) *
      normalizedDltJacobian(*dlt, matches);
  const Eigen::Matrix3d dense = 0.49 * j * j.transpose();
  EXPECT_LT((*covariance - dense).norm(), 1e-10 * dense.norm());

  // The second-order term only adds (positive semidefinite) and is small in this well-posed
  // scene.
  const auto full = fastHdCovariance(*dlt, matches, mathCamera(), kSceneAPlane, 0.7);
  ASSERT_TRUE(full.isOk());
  const Eigen::Matrix3d added = *full - *covariance;
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(added).eigenvalues().minCoeff(),
            -1e-12 * dense.norm());
  EXPECT_LT(added.norm(), 0.05 * dense.norm());
}

// The pose map's Jacobian and Hessians (behind the second-order term) against central
// differences of g(x21, z21, S, C), at a point where S² + C² ≠ 1 (noisy data).
TEST(FastHdCovariance, PoseMapDerivativesMatchFiniteDifferences) {
  auto g = [](const Eigen::Vector4d& s) {
    const double theta21 = std::atan2(s(2), s(3));
    const double c = std::cos(theta21), sn = std::sin(theta21);
    return Eigen::Vector3d(c * s(0) + sn * s(1), -sn * s(0) + c * s(1), -theta21);
  };
  const Eigen::Vector4d s0(0.7, -1.3, 0.31, 0.97);
  FastHdSolution solution;
  solution.x21 = s0(0);
  solution.z21 = s0(1);
  solution.sin_theta21 = s0(2);
  solution.cos_theta21 = s0(3);
  const Eigen::Vector3d pose = g(s0);
  solution.pose = PlanarPose(pose(0), pose(1), pose(2));
  const Eigen::Matrix<double, 3, 4> jacobian = fastHdPoseMapJacobian(solution);
  const auto hessians = fastHdPoseMapHessians(solution);
  const double h = 1e-4;
  for (int a = 0; a < 4; ++a) {
    const Eigen::Vector4d ea = Eigen::Vector4d::Unit(a) * h;
    EXPECT_LT(((g(s0 + ea) - g(s0 - ea)) / (2 * h) - jacobian.col(a)).norm(), 1e-7);
    for (int b = 0; b < 4; ++b) {
      const Eigen::Vector4d eb = Eigen::Vector4d::Unit(b) * h;
      const Eigen::Vector3d numeric =
          (g(s0 + ea + eb) - g(s0 + ea - eb) - g(s0 - ea + eb) + g(s0 - ea - eb)) / (4 * h * h);
      for (int i = 0; i < 3; ++i) EXPECT_NEAR(hessians[i](a, b), numeric(i), 1e-6) << i << a << b;
    }
  }
}

TEST(FastHdCovariance, SecondOrderTermGrowsWithNoiseAsSigmaToTheFourth) {
  const PointMatches matches = sceneAMatches(20, 13);
  const auto dlt = solveNormalizedDlt(matches);
  ASSERT_TRUE(dlt.isOk());
  auto secondOrderPart = [&](double sigma) {
    return (*fastHdCovariance(*dlt, matches, mathCamera(), kSceneAPlane, sigma) -
            *fastHdCovariance(*dlt, matches, mathCamera(), kSceneAPlane, sigma, false))
        .norm();
  };
  const double small = secondOrderPart(0.5);
  const double large = secondOrderPart(1.0);
  ASSERT_GT(small, 0.0);
  EXPECT_NEAR(large / small, 16.0, 1e-6 * 16.0);
}

// Predicted std against a Monte Carlo of the pipeline (docs/math.md §3.5, scene A at 1 px; the
// evaluation program runs 2000 trials per cell, this smaller run checks the order of magnitude
// and the ratio band with a fixed seed).
TEST(FastHdCovariance, AgreesWithMonteCarlo) {
  const PointMatches exact = sceneAMatches(40, 8);
  const auto dlt = solveNormalizedDlt(exact);
  const auto predicted = fastHdCovariance(*dlt, exact, mathCamera(), kSceneAPlane, 1.0);
  ASSERT_TRUE(predicted.isOk());
  std::mt19937_64 rng(11);
  const int trials = 600;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  for (int t = 0; t < trials; ++t) {
    const PointMatches noisy = test_support::addPixelNoise(exact, 1.0, &rng);
    const auto solution =
        solveFastHd(solveNormalizedDlt(noisy)->H_unscaled, mathCamera(), kSceneAPlane);
    ASSERT_TRUE(solution.isOk());
    const Eigen::Vector3d e = poseVector(solution->pose) - poseVector(kSceneAPose);
    sum += e;
    outer += e * e.transpose();
  }
  const Eigen::Vector3d mean = sum / trials;
  const Eigen::Matrix3d empirical = outer / trials - mean * mean.transpose();
  for (int k = 0; k < 3; ++k) {
    const double ratio = std::sqrt((*predicted)(k, k) / empirical(k, k));
    EXPECT_GT(ratio, 0.85) << "component " << k;
    EXPECT_LT(ratio, 1.18) << "component " << k;
  }
}

// The reference image's share of the first-order covariance against a Monte Carlo with noise on
// the reference pixels only (1 px); the rest against noise on the current pixels only. The
// current camera has come 3 m closer to a wall 6 m away: the reference's pixels are magnified
// twice in it, so the reference's share is the larger (not the half of equal shares).
TEST(FastHdCovariance, ReferenceNoiseCovarianceIsTheReferenceImagesShare) {
  const PlanarPose truth(0.3, 3.0, 0.1);
  const ScenePlane wall = planeFromAngles(0.2, 0.1, 6.0);
  std::mt19937_64 scene(8);
  const PointMatches exact = sampleVisiblePlaneMatches(mathCamera(), wall, truth, 40, &scene);
  const auto dlt = solveNormalizedDlt(exact);
  Eigen::Matrix3d reference_part;
  const auto predicted = fastHdCovariance(*dlt, exact, mathCamera(), wall, 1.0, /*second_order=*/false,
                                          &reference_part);
  ASSERT_TRUE(predicted.isOk());
  const Eigen::Matrix3d current_part = *predicted - reference_part;
  EXPECT_GT(reference_part(0, 0), 0.65 * (*predicted)(0, 0));
  for (const bool noisy_reference : {true, false}) {
    std::mt19937_64 rng(noisy_reference ? 41 : 42);
    std::normal_distribution<double> noise(0.0, 1.0);
    const int trials = 600;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
    for (int t = 0; t < trials; ++t) {
      PointMatches noisy = exact;
      for (PointMatch& m : noisy) (noisy_reference ? m.reference : m.current) += Eigen::Vector2d(noise(rng), noise(rng));
      const auto solution = solveFastHd(solveNormalizedDlt(noisy)->H_unscaled, mathCamera(), wall);
      ASSERT_TRUE(solution.isOk());
      const Eigen::Vector3d e = poseVector(solution->pose) - poseVector(truth);
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

TEST(FastHdCovariance, RejectsBadSigmaAndForeignMatches) {
  const PointMatches matches = sceneAMatches(20, 9);
  const auto dlt = solveNormalizedDlt(matches);
  ASSERT_TRUE(dlt.isOk());
  EXPECT_EQ(fastHdCovariance(*dlt, matches, mathCamera(), kSceneAPlane, -1.0).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(fastHdCovariance(*dlt, matches, mathCamera(), kSceneAPlane, std::nan("")).status().code(),
            StatusCode::kInvalidInput);
  const PointMatches fewer(matches.begin(), matches.begin() + 10);
  EXPECT_EQ(fastHdCovariance(*dlt, fewer, mathCamera(), kSceneAPlane, 1.0).status().code(),
            StatusCode::kInvalidInput);
  ScenePlane floor;
  floor.normal = Eigen::Vector3d::UnitY();
  floor.distance = 1.2;
  EXPECT_EQ(fastHdCovariance(*dlt, matches, mathCamera(), floor, 1.0).status().code(),
            StatusCode::kDegenerate);
}
