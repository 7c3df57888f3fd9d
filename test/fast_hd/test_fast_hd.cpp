#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/homography/homography.h"

using namespace homography_teach_repeat;

namespace {

PinholeCamera camera() {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = 520.0;
  c.fy = 515.0;  // fv differs from fu: Fast-HD never needs it (docs/math.md §1.1)
  c.cx = 318.0;
  c.cy = 243.0;  // v0 ≠ 0: the printed normalisation by H(2,2) would fail here (§1.3)
  return PinholeCamera(c);
}

// n = (sinα, cosα sinβ, cosα cosβ) (docs/math.md §1.1).
ScenePlane plane(double alpha, double beta, double distance) {
  ScenePlane p;
  p.normal = Eigen::Vector3d(std::sin(alpha), std::cos(alpha) * std::sin(beta),
                             std::cos(alpha) * std::cos(beta));
  p.distance = distance;
  return p;
}

void expectPose(const PlanarPose& actual, const PlanarPose& expected, double tolerance) {
  EXPECT_NEAR(actual.x, expected.x, tolerance);
  EXPECT_NEAR(actual.z, expected.z, tolerance);
  EXPECT_NEAR(wrapToPi(actual.theta - expected.theta), 0.0, tolerance);
}

}  // namespace

// Scene A of docs/math.md §3.5: θ21 = 0.25, C = (0.6, −1.4), α = 0.35, β = 0.2, d1 = 5.
TEST(FastHd, ExactOnMathScene) {
  const PlanarPose truth(0.6, -1.4, -0.25);
  const ScenePlane p = plane(0.35, 0.2, 5.0);
  const auto solution = solveFastHd(planeInducedHomography(camera(), truth, p), camera(), p);
  ASSERT_TRUE(solution.isOk()) << solution.status().toString();
  expectPose(solution->pose, truth, 1e-9);
  EXPECT_NEAR(std::hypot(solution->sin_theta21, solution->cos_theta21), 1.0, 1e-12);
}

// Any scale and sign of H give the same pose (κ fixes both, docs/math.md §1.3, §1.5).
TEST(FastHd, InvariantToScaleAndSignOfH) {
  const PlanarPose truth(-0.4, 1.1, 0.3);
  const ScenePlane p = plane(-0.2, -0.3, 4.0);
  const Eigen::Matrix3d H = planeInducedHomography(camera(), truth, p);
  for (double scale : {1.0, -1.0, 1e-3, -250.0}) {
    const auto solution = solveFastHd(scale * H, camera(), p);
    ASSERT_TRUE(solution.isOk());
    expectPose(solution->pose, truth, 1e-9);
  }
}

TEST(FastHd, ExactOnRandomScenes) {
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> position(-2.5, 2.5), heading(-0.65, 0.65),
      alpha(-0.8, 0.8), beta(-0.5, 0.5), distance(3.0, 9.0);
  for (int trial = 0; trial < 300; ++trial) {
    const PlanarPose truth(position(rng), position(rng), heading(rng));
    const ScenePlane p = plane(alpha(rng), beta(rng), distance(rng));
    const auto solution = solveFastHd(planeInducedHomography(camera(), truth, p), camera(), p);
    ASSERT_TRUE(solution.isOk()) << "trial " << trial;
    expectPose(solution->pose, truth, 1e-9);
  }
}

// The whole chain from exact point matches: normalised DLT, then Fast-HD.
TEST(FastHd, ExactFromDltOfProjectedPoints) {
  const PlanarPose truth(0.5, -0.9, 0.2);
  const ScenePlane p = plane(0.3, 0.1, 6.0);
  const PinholeCamera cam = camera();
  const Eigen::Matrix3d R21 = truth.rotation21();
  PointMatches matches;
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(20.0, 620.0), v(20.0, 460.0);
  for (int i = 0; i < 30; ++i) {
    // Back-project a reference pixel onto the plane, then into camera 2.
    const Eigen::Vector3d ray = cam.Kinverse() * Eigen::Vector3d(u(rng), v(rng), 1.0);
    const Eigen::Vector3d X1 = ray * (p.distance / p.normal.dot(ray));
    const Eigen::Vector3d X2 = R21 * (X1 - truth.centre());
    const cv::Point2d p1 = cam.project(X1), p2 = cam.project(X2);
    matches.push_back({Eigen::Vector2d(p1.x, p1.y), Eigen::Vector2d(p2.x, p2.y)});
  }
  const auto H = estimateHomographyDlt(matches);
  ASSERT_TRUE(H.isOk());
  const auto solution = solveFastHd(*H, cam, p);
  ASSERT_TRUE(solution.isOk());
  expectPose(solution->pose, truth, 1e-9);
}

TEST(FastHd, FloorOrCeilingPlaneIsDegenerate) {
  ScenePlane floor;
  floor.normal = Eigen::Vector3d(0.0, 1.0, 0.0);  // nx = nz = 0
  floor.distance = 1.2;
  const auto solution = solveFastHd(Eigen::Matrix3d::Identity(), camera(), floor);
  ASSERT_FALSE(solution.isOk());
  EXPECT_EQ(solution.status().code(), StatusCode::kDegenerate);
  EXPECT_NE(solution.status().message().find("floor/ceiling"), std::string::npos);
}

TEST(FastHd, ZeroKappaIsDegenerate) {
  Eigen::Matrix3d H = planeInducedHomography(camera(), PlanarPose(0.1, 0.2, 0.05), plane(0.2, 0, 5));
  H(1, 1) = camera().cy() * H(2, 1);  // κ = H(2,2) − v0 H(3,2) = 0
  const auto solution = solveFastHd(H, camera(), plane(0.2, 0.0, 5.0));
  EXPECT_EQ(solution.status().code(), StatusCode::kDegenerate);
}

TEST(FastHd, NonFiniteHomography) {
  Eigen::Matrix3d H = Eigen::Matrix3d::Identity();
  H(0, 2) = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(solveFastHd(H, camera(), plane(0.1, 0.0, 5.0)).status().code(),
            StatusCode::kNotFinite);
}

TEST(FastHd, InvalidPlane) {
  ScenePlane p = plane(0.1, 0.0, 5.0);
  p.distance = 0.0;
  EXPECT_EQ(solveFastHd(Eigen::Matrix3d::Identity(), camera(), p).status().code(),
            StatusCode::kInvalidInput);
  p = plane(0.1, 0.0, 5.0);
  p.normal *= 2.0;
  EXPECT_EQ(solveFastHd(Eigen::Matrix3d::Identity(), camera(), p).status().code(),
            StatusCode::kInvalidInput);
}

// The identity homography of a static camera gives the zero pose.
TEST(FastHd, IdentityIsZeroMotion) {
  const auto solution = solveFastHd(Eigen::Matrix3d::Identity(), camera(), plane(0.3, 0.1, 4.0));
  ASSERT_TRUE(solution.isOk());
  expectPose(solution->pose, PlanarPose(), 1e-12);
}
