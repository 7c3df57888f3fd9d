#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

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

// A run that learns at consecutive keyframes measures each pair of its views as the teach run
// measured its keyframes (match residual, tilt to the next): the route's measured noise then takes
// in what the learning run saw. Here its camera is noisier than the teach run's, and the route's
// residual grows; a reload keeps the measurements, and a corrupt one is refused naming the
// keyframe and the experience.
TEST(ExperienceRecorder, MeasuresTheNoiseOfTheViewsItLearned) {
  const test_support::SyntheticWall wall;
  const std::string directory = test_support::teachSyntheticRoute(wall, FeatureType::kOrb, 16);
  auto route = loadRoute(directory);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  ASSERT_TRUE(routeMatchResidual(*route).has_value());
  const double taught = *routeMatchResidual(*route);
  std::vector<Pose2D> poses;
  for (const auto& k : route->keyframes) poses.push_back(k.pose);
  ASSERT_GE(poses.size(), 4u);
  ExperienceRecorder recorder(poses, ExperienceLearningOptions());
  cv::RNG rng(7);
  for (const Pose2D& pose : poses) {
    ExperienceObservation o = observation(pose);
    cv::Mat image;
    wall.imageAt(rep103ToCameraAxes(pose)).convertTo(image, CV_32F);
    cv::Mat noise(image.size(), CV_32F);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, 12.0);
    image += noise;
    image.convertTo(o.image, CV_8U);  // saturated
    recorder.observe(o);
  }
  ASSERT_EQ(recorder.candidates().size(), poses.size());
  FeatureExtractor extractor(FeatureOptions{FeatureType::kOrb, kRouteMaxFeatures});
  const auto added = recorder.commit(*route, extractor);
  ASSERT_TRUE(added.isOk()) << added.status().toString();
  int measured = 0;
  for (std::size_t k = 0; k + 1 < poses.size(); ++k) {
    ASSERT_EQ(route->keyframes[k].experiences.size(), 1u);
    const RouteExperience& e = route->keyframes[k].experiences.front();
    if (e.match_residual) ++measured;
    if (e.tilt_to_next) {
      EXPECT_LT(std::abs(e.tilt_to_next->pitch), 0.01);  // the images are level
      EXPECT_LT(std::abs(e.tilt_to_next->roll), 0.01);
    }
  }
  EXPECT_FALSE(route->keyframes.back().experiences.front().match_residual.has_value());  // no next one
  EXPECT_GE(measured, static_cast<int>(poses.size()) - 2);
  ASSERT_TRUE(routeMatchResidual(*route).has_value());
  EXPECT_GT(*routeMatchResidual(*route), taught);

  auto reloaded = loadRoute(directory);
  ASSERT_TRUE(reloaded.isOk()) << reloaded.status().toString();
  EXPECT_DOUBLE_EQ(*routeMatchResidual(*reloaded), *routeMatchResidual(*route));
  EXPECT_EQ(routeTiltSigma(*reloaded), routeTiltSigma(*route));

  // One experience's residual made non-finite in the index.
  const std::string index = directory + "/route.yaml";
  std::ifstream in(index);
  std::stringstream text;
  text << in.rdbuf();
  std::string yaml = text.str();
  std::size_t at = std::string::npos;
  for (std::size_t line = 0; line < yaml.size();) {
    const std::size_t end = yaml.find('\n', line);
    const std::string row = yaml.substr(line, end - line);
    if (row.find("- {id:") != std::string::npos && row.find("rms_px: ") != std::string::npos) {
      at = line + row.find("rms_px: ") + 8;
      break;
    }
    line = end == std::string::npos ? yaml.size() : end + 1;
  }
  ASSERT_NE(at, std::string::npos) << yaml;
  yaml.replace(at, yaml.find(',', at) - at, ".nan");
  std::ofstream(index) << yaml;
  const auto corrupt = loadRoute(directory);
  ASSERT_FALSE(corrupt.isOk());
  EXPECT_NE(corrupt.status().message().find("experience 1: match_residual.rms_px must be finite"), std::string::npos)
      << corrupt.status().message();
  std::filesystem::remove_all(directory);
}
