// Shared fixtures of the geometry tests: the camera and planes of docs/math.md §3.5 and helpers.
#pragma once

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {
namespace test_support {

// fv ≠ fu (Fast-HD never needs fv) and v0 ≠ 0 (the printed normalisation would fail, §1.3).
inline PinholeCamera mathCamera(double fu = 520.0) {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = fu;
  c.fy = fu - 5.0;
  c.cx = 318.0;
  c.cy = 243.0;
  return PinholeCamera(c);
}

// n = (sinα, cosα sinβ, cosα cosβ) (docs/math.md §1.1).
inline ScenePlane planeFromAngles(double alpha, double beta, double distance) {
  ScenePlane p;
  p.normal = Eigen::Vector3d(std::sin(alpha), std::cos(alpha) * std::sin(beta),
                             std::cos(alpha) * std::cos(beta));
  p.distance = distance;
  return p;
}

inline void expectPoseNear(const PlanarPose& actual, const PlanarPose& expected,
                           double tolerance) {
  EXPECT_NEAR(actual.x, expected.x, tolerance);
  EXPECT_NEAR(actual.z, expected.z, tolerance);
  EXPECT_NEAR(wrapToPi(actual.theta - expected.theta), 0.0, tolerance);
}

// Adds iid N(0, σ²) to every coordinate of every match.
template <typename Matches>
Matches addPixelNoise(Matches matches, double sigma, std::mt19937_64* rng) {
  std::normal_distribution<double> noise(0.0, sigma);
  for (auto& m : matches) {
    m.reference += Eigen::Vector2d(noise(*rng), noise(*rng));
    m.current += Eigen::Vector2d(noise(*rng), noise(*rng));
  }
  return matches;
}

}  // namespace test_support
}  // namespace homography_teach_repeat
