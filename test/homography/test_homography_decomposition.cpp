#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "support/geometry_fixtures.h"
#include "homography_teach_repeat/homography/homography_decomposition.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

using namespace homography_teach_repeat;
using test_support::expectPoseNear;
using test_support::mathCamera;
using test_support::planeFromAngles;

namespace {

std::vector<Eigen::Vector2d> referencePixels(const PointMatches& matches) {
  std::vector<Eigen::Vector2d> pixels;
  for (const auto& m : matches) pixels.push_back(m.reference);
  return pixels;
}

// Index of the solution with the true normal, or -1.
int findTrue(const std::vector<HomographyDecomposition>& solutions, const ScenePlane& plane,
             const PlanarPose& pose) {
  for (std::size_t i = 0; i < solutions.size(); ++i) {
    const PlanarPose p = solutions[i].planarPose(plane.distance);
    if ((solutions[i].normal - plane.normal).norm() < 1e-8 && std::abs(p.x - pose.x) < 1e-8 &&
        std::abs(p.z - pose.z) < 1e-8 && std::abs(wrapToPi(p.theta - pose.theta)) < 1e-8) {
      return static_cast<int>(i);
    }
  }
  return -1;
}

}  // namespace

// docs/math.md §1.8/§2.1: positive depth always keeps the true solution; for β ≠ 0 the planar-motion
// test then leaves only it.
TEST(HomographyDecomposition, ClassicKeepsTheTruthAndPlanarTestDisambiguates) {
  std::mt19937_64 rng(21);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int unique_after_planar_test = 0;
  const int scenes = 40;
  for (int s = 0; s < scenes; ++s) {
    const PlanarPose pose(u(rng), u(rng), 0.4 * u(rng));
    const ScenePlane plane = planeFromAngles(0.4 * u(rng), 0.1 + 0.3 * std::abs(u(rng)),
                                             5.0 + 2.0 * u(rng));
    const PointMatches matches = sampleVisiblePlaneMatches(mathCamera(), plane, pose, 30, &rng);
    ASSERT_GE(matches.size(), 10u);
    const auto all = decomposeHomographyClassic(planeInducedHomography(mathCamera(), pose, plane),
                                                mathCamera());
    ASSERT_TRUE(all.isOk());
    const auto visible = filterByPositiveDepth(*all, mathCamera(), referencePixels(matches));
    ASSERT_GE(findTrue(visible, plane, pose), 0) << "scene " << s;
    int planar = 0;
    for (const auto& d : visible) planar += d.isPlanarMotion(1e-6) ? 1 : 0;
    unique_after_planar_test += planar == 1 ? 1 : 0;
  }
  EXPECT_EQ(unique_after_planar_test, scenes);
}

TEST(HomographyDecomposition, PlanarHdContainsTheExactSolution) {
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int s = 0; s < 30; ++s) {
    const PlanarPose pose(u(rng), u(rng), 0.5 * u(rng));
    const ScenePlane plane = planeFromAngles(0.4 * u(rng), 0.3 * u(rng), 6.0 + u(rng));
    const PointMatches matches = sampleVisiblePlaneMatches(mathCamera(), plane, pose, 20, &rng);
    const Eigen::Matrix3d H = -2.5 * planeInducedHomography(mathCamera(), pose, plane);
    const auto solutions = decomposeHomographyPlanar(H, mathCamera(), referencePixels(matches));
    ASSERT_TRUE(solutions.isOk());
    EXPECT_LE(solutions->size(), 2u);
    EXPECT_GE(findTrue(*solutions, plane, pose), 0) << "scene " << s;
  }
}

TEST(HomographyDecomposition, PureRotationHasNoTranslation) {
  const PlanarPose pose(0.0, 0.0, 0.2);
  const auto solutions = decomposeHomographyPlanar(
      planeInducedHomography(mathCamera(), pose, planeFromAngles(0.1, 0.0, 5.0)), mathCamera());
  ASSERT_TRUE(solutions.isOk());
  bool found = false;
  for (const auto& d : *solutions) {
    if (d.translation_over_distance.norm() < 1e-9) {
      expectPoseNear(d.planarPose(5.0), pose, 1e-9);
      found = true;
    }
  }
  EXPECT_TRUE(found);
}

TEST(HomographyDecomposition, NonFiniteAndDegenerateInput) {
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity();
  H(0, 1) = std::nan("");
  EXPECT_EQ(decomposeHomographyClassic(H, mathCamera()).status().code(), StatusCode::kNotFinite);
  EXPECT_EQ(decomposeHomographyPlanar(H, mathCamera()).status().code(), StatusCode::kNotFinite);
  EXPECT_EQ(decomposeHomographyPlanar(Eigen::Matrix3d::Zero(), mathCamera()).status().code(),
            StatusCode::kDegenerate);
}

// A few reference pixels behind the plane (noise near the vanishing point in forward motion): with
// all of them required the true solution goes; with min_fraction 0.9 it stays, and at most one of
// each (N, −N) pair passes.
TEST(HomographyDecomposition, PositiveDepthByFractionKeepsTheTruthDespiteAFewStrayPixels) {
  std::mt19937_64 rng(5);
  const PlanarPose pose(0.1, 0.8, 0.05);
  const ScenePlane plane = planeFromAngles(0.3, 0.2, 5.0);
  const PointMatches matches = sampleVisiblePlaneMatches(mathCamera(), plane, pose, 40, &rng);
  const auto all = decomposeHomographyClassic(planeInducedHomography(mathCamera(), pose, plane), mathCamera());
  ASSERT_TRUE(all.isOk());
  std::vector<Eigen::Vector2d> pixels = referencePixels(matches);
  // Two pixels whose ray misses the plane (behind it: Nᵀ K⁻¹ p < 0), 5 % of 40.
  // The ray (−k nx, −k ny, 1) has Nᵀr = −k (nx² + ny²) + nz < 0 for k beyond nz / (nx² + ny²).
  const Eigen::Vector3d& n = plane.normal;
  const double k = 2.0 * n.z() / (n.x() * n.x() + n.y() * n.y()) + 0.1;
  for (int i = 0; i < 2; ++i) {
    const Eigen::Vector3d ray(-k * n.x() * (1.0 + 0.1 * i), -k * n.y(), 1.0);
    pixels[static_cast<std::size_t>(i)] = (mathCamera().K() * ray).hnormalized();
  }
  const Eigen::Matrix3d K_inverse = mathCamera().Kinverse();
  ASSERT_LT(plane.normal.dot(K_inverse * pixels[0].homogeneous()), 0.0);
  EXPECT_LT(findTrue(filterByPositiveDepth(*all, mathCamera(), pixels), plane, pose), 0);
  const auto kept = filterByPositiveDepth(*all, mathCamera(), pixels, 0.9);
  EXPECT_GE(findTrue(kept, plane, pose), 0);
  for (std::size_t i = 0; i < kept.size(); ++i) {
    for (std::size_t j = i + 1; j < kept.size(); ++j) EXPECT_GT((kept[i].normal + kept[j].normal).norm(), 1e-6);
  }
}
