#include <gtest/gtest.h>

#include <random>

#include "support/geometry_fixtures.h"
#include "homography_teach_repeat/eval/epipolar_baselines.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

using namespace homography_teach_repeat;
using test_support::expectPoseNear;
using test_support::mathCamera;

namespace {

// Points spread in depth (a general scene: F and E are well posed).
PointMatches generalScene(const PlanarPose& pose, int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> lateral(-3.0, 3.0), height(-1.5, 1.5), depth(4.0, 12.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 4 * count; ++i) points.emplace_back(lateral(rng), height(rng), depth(rng));
  PointMatches matches = projectPlanePoints(mathCamera(), pose, points);
  matches.resize(std::min<std::size_t>(matches.size(), static_cast<std::size_t>(count)));
  return matches;
}

}  // namespace

TEST(EpipolarBaselines, EightPointRecoversGeneralMotion) {
  const PlanarPose pose(0.8, 1.2, 0.2);
  const auto motion = motionFromEightPointF(generalScene(pose, 60, 1), mathCamera());
  ASSERT_TRUE(motion.isOk()) << motion.status().toString();
  expectPoseNear(motion->planarPose(std::hypot(pose.x, pose.z)), pose, 1e-6);
}

TEST(EpipolarBaselines, FivePointRecoversGeneralMotion) {
  const PlanarPose pose(-0.6, 0.9, -0.3);
  const auto motion = motionFromFivePointE(generalScene(pose, 60, 2), mathCamera());
  ASSERT_TRUE(motion.isOk()) << motion.status().toString();
  expectPoseNear(motion->planarPose(std::hypot(pose.x, pose.z)), pose, 1e-5);
}

TEST(EpipolarBaselines, TooFewMatches) {
  const PointMatches few = generalScene(PlanarPose(0.5, 0.5, 0.1), 7, 3);
  EXPECT_EQ(motionFromEightPointF(few, mathCamera()).status().code(), StatusCode::kTooFewPoints);
  const PointMatches four(few.begin(), few.begin() + 4);
  EXPECT_EQ(motionFromFivePointE(four, mathCamera()).status().code(), StatusCode::kTooFewPoints);
}
