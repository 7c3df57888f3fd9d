// A gtest fixture: the synthetic wall and a route taught along it once per test suite (AKAZE),
// removed at the end. For the tests of the repeat phase.
#pragma once

#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"
#include "support/synthetic_route.h"

namespace homography_teach_repeat {
namespace test_support {

class SyntheticRouteTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    wall_ = new SyntheticWall();
    directory_ = teachSyntheticRoute(*wall_, FeatureType::kAkaze);
  }
  static void TearDownTestSuite() {
    std::filesystem::remove_all(directory_);
    delete wall_;
    wall_ = nullptr;
  }
  static Route route() {
    auto r = loadRoute(directory_);
    EXPECT_TRUE(r.isOk()) << r.status().toString();
    return *r;
  }
  // An estimate of a frame of the drive past keyframe 1 (FramesBetweenDetectionsAreTracked,
  // test_background_detection.cpp), detected or tracked: a pose within 3 mm / 0.05° of the camera's
  // (measured ~1 mm, 0.02°) with a covariance, from over 300 inliers.
  static void expectAccurateAgainstKeyframe1(const RepeatEstimate& estimate, const PlanarPose& camera_pose,
                                             std::size_t step) {
    EXPECT_EQ(estimate.keyframe, 1) << step;
    EXPECT_FALSE(estimate.degraded) << step;
    EXPECT_TRUE(estimate.covariance_known) << step;
    EXPECT_GT(estimate.inliers, 300) << step;
    const Pose2D truth = cameraAxesToRep103(camera_pose);
    EXPECT_NEAR(estimate.base_pose.x, truth.x, 0.003) << step;
    EXPECT_NEAR(estimate.base_pose.y, truth.y, 0.003) << step;
    EXPECT_NEAR(wrapToPi(estimate.base_pose.yaw - truth.yaw), 0.0, 0.05 * M_PI / 180.0) << step;
  }
  inline static SyntheticWall* wall_ = nullptr;
  inline static std::string directory_;
};

}  // namespace test_support
}  // namespace homography_teach_repeat
