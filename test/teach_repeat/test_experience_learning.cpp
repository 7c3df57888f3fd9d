#include <gtest/gtest.h>

#include <filesystem>

#include "homography_teach_repeat/teach_repeat/experience_learning.h"
#include "support/synthetic_route.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

namespace {

ExperienceObservation observation(const Pose2D& pose, int taught_inliers = -1, double sigma = 0.01) {
  ExperienceObservation o;
  o.stamp = 10.0;
  o.image = test_support::makeTexture(320, 240, 5);
  o.pose = pose;
  o.covariance = Eigen::Vector3d(sigma * sigma, sigma * sigma, 1e-5).asDiagonal();
  o.trusted = true;
  o.taught_inliers = taught_inliers;
  return o;
}

}  // namespace

// What is learned: a frame where the taught view was weak, the pose trusted and known to within
// max_position_sigma, near a keyframe facing the same way; per keyframe the one nearest to it.
TEST(ExperienceRecorder, KeepsTheNearestTrustedFrameWhereTheTaughtViewWasWeak) {
  ExperienceRecorder recorder({Pose2D(0, 0, 0), Pose2D(1, 0, 0), Pose2D(2, 0, M_PI / 2)}, ExperienceLearningOptions());
  ExperienceObservation untrusted = observation(Pose2D(1.05, 0, 0));
  untrusted.trusted = false;
  recorder.observe(untrusted);
  recorder.observe(observation(Pose2D(1.05, 0, 0), 100));          // the taught view still works
  recorder.observe(observation(Pose2D(1.05, 0, 0), -1, 0.2));      // the pose is not known well enough
  recorder.observe(observation(Pose2D(1.3, 0, 0)));                // too far from every keyframe
  recorder.observe(observation(Pose2D(1.05, 0, 0.5)));             // facing another way
  EXPECT_TRUE(recorder.candidates().empty());
  recorder.observe(observation(Pose2D(1.1, 0, 0), 12));            // weak: 12 inliers
  ASSERT_EQ(recorder.candidates().size(), 1u);
  EXPECT_NEAR(recorder.candidates().at(1), 0.1, 1e-12);
  recorder.observe(observation(Pose2D(0.96, 0.0, 0.02)));          // nearer: replaces it
  EXPECT_NEAR(recorder.candidates().at(1), 0.04, 1e-12);
  recorder.observe(observation(Pose2D(1.15, 0, 0)));               // farther: kept out
  EXPECT_NEAR(recorder.candidates().at(1), 0.04, 1e-12);
  recorder.observe(observation(Pose2D(2.0, 0.1, M_PI / 2)));       // the corner keyframe
  EXPECT_EQ(recorder.candidates().size(), 2u);
  ExperienceLearningOptions bad;
  bad.max_experiences = 0;
  EXPECT_THROW(ExperienceRecorder({Pose2D()}, bad), std::invalid_argument);
}

// Committing writes each candidate into the route as an experience of its keyframe (features of the
// route's type), which a reload reads back; the candidates are then forgotten.
TEST(ExperienceRecorder, CommitsItsCandidatesToTheRoute) {
  const test_support::SyntheticWall wall;
  const std::string directory = test_support::teachSyntheticRoute(wall, FeatureType::kOrb, 8);
  auto route = loadRoute(directory);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  std::vector<Pose2D> poses;
  for (const auto& k : route->keyframes) poses.push_back(k.pose);
  ExperienceRecorder recorder(poses, ExperienceLearningOptions());
  recorder.observe(observation(poses[1].compose(Pose2D(0.03, 0.0, 0.0))));
  ASSERT_EQ(recorder.candidates().size(), 1u);
  FeatureExtractor extractor(FeatureOptions{FeatureType::kOrb, 500});
  const auto added = recorder.commit(*route, extractor);
  ASSERT_TRUE(added.isOk()) << added.status().toString();
  EXPECT_EQ(*added, 1);
  EXPECT_TRUE(recorder.candidates().empty());
  const auto reloaded = loadRoute(directory);
  ASSERT_TRUE(reloaded.isOk()) << reloaded.status().toString();
  ASSERT_EQ(reloaded->keyframes[1].experiences.size(), 1u);
  EXPECT_NEAR(reloaded->keyframes[1].experiences[0].pose.x, poses[1].compose(Pose2D(0.03, 0.0, 0.0)).x, 1e-9);
  EXPECT_NEAR(reloaded->keyframes[1].experiences[0].pose_covariance(0, 0), 1e-4, 1e-12);
  const auto features = loadExperienceFeatures(*reloaded, 1, 0);
  ASSERT_TRUE(features.isOk()) << features.status().toString();
  EXPECT_GT(features->keypoints.size(), 50u);
  std::filesystem::remove_all(directory);
}
