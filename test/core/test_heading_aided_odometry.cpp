#include "homography_teach_repeat/heading_aided_odometry.h"

#include <gtest/gtest.h>

#include <cmath>

namespace homography_teach_repeat {
namespace {

// A robot drives a straight line of `metres` along +x of the route frame in 1 cm steps; its
// odometry has a heading bias of `bias_per_metre` rad per metre, so the odometry believes it
// curves. Returns the final route-frame pose from HeadingAidedOdometry, with a true heading fix
// every `fix_every` steps (0: never).
Pose2D driveStraight(double metres, double bias_per_metre, int fix_every, HeadingAidedOdometry& odometry) {
  const double step = 0.01;
  Pose2D odom(0.0, 0.0, 0.0);
  EXPECT_TRUE(odometry.align(Pose2D(0.0, 0.0, 0.0), odom).isOk());
  Pose2D estimate;
  const int steps = static_cast<int>(std::lround(metres / step));
  for (int i = 1; i <= steps; ++i) {
    // Odometry integrates the true forward step with a biased heading increment.
    odom = odom.compose(Pose2D(step, 0.0, bias_per_metre * step));
    if (fix_every > 0 && i % fix_every == 0) {
      EXPECT_TRUE(odometry.correctHeading(/*true yaw*/ 0.0, odom).isOk());
    }
    const auto pose = odometry.routePose(odom);
    EXPECT_TRUE(pose.isOk());
    estimate = *pose;
  }
  return estimate;
}

TEST(HeadingAidedOdometry, HeadingFixesRemoveTheDriftOfABiasedOdometry) {
  HeadingAidedOdometry without, with;
  const Pose2D drifted = driveStraight(10.0, 0.02, 0, without);
  const Pose2D corrected = driveStraight(10.0, 0.02, 10, with);
  // Without fixes: the 0.2 rad heading error of the odometry bends the path by ~1 m.
  EXPECT_NEAR(drifted.yaw, 0.2, 1e-9);
  EXPECT_GT(std::abs(drifted.y), 0.9);
  // With a fix every 10 cm the heading error never exceeds 0.002 rad: the lateral error stays
  // below 1 cm.
  EXPECT_NEAR(corrected.x, 10.0, 1e-3);
  EXPECT_LT(std::abs(corrected.y), 0.01);
  EXPECT_LT(std::abs(corrected.yaw), 0.0021);
}

TEST(HeadingAidedOdometry, AlignmentPlacesTheRobotAtTheGivenRoutePose) {
  HeadingAidedOdometry odometry;
  const Pose2D route(2.0, -1.0, 0.5), odom(10.0, 3.0, -1.2);
  ASSERT_TRUE(odometry.align(route, odom).isOk());
  const auto pose = odometry.routePose(odom);
  ASSERT_TRUE(pose.isOk());
  EXPECT_NEAR(pose->x, 2.0, 1e-12);
  EXPECT_NEAR(pose->y, -1.0, 1e-12);
  EXPECT_NEAR(pose->yaw, 0.5, 1e-12);
  // 1 m forward in odometry is 1 m forward along the route heading.
  const auto ahead = odometry.routePose(odom.compose(Pose2D(1.0, 0.0, 0.0)));
  ASSERT_TRUE(ahead.isOk());
  EXPECT_NEAR(ahead->x, 2.0 + std::cos(0.5), 1e-12);
  EXPECT_NEAR(ahead->y, -1.0 + std::sin(0.5), 1e-12);
}

TEST(HeadingAidedOdometry, AFixRotatesAboutTheRobotPositionAndHonoursTheGain) {
  HeadingAidedOdometryOptions options;
  options.correction_gain = 0.5;
  HeadingAidedOdometry odometry(options);
  const Pose2D odom(1.0, 1.0, 0.3);
  ASSERT_TRUE(odometry.align(Pose2D(4.0, 5.0, 0.3), odom).isOk());
  ASSERT_TRUE(odometry.correctHeading(0.1, odom).isOk());
  const auto pose = odometry.routePose(odom);
  ASSERT_TRUE(pose.isOk());
  EXPECT_NEAR(pose->x, 4.0, 1e-12);
  EXPECT_NEAR(pose->y, 5.0, 1e-12);
  EXPECT_NEAR(pose->yaw, 0.2, 1e-12);  // half of the 0.2 rad error applied
}

TEST(HeadingAidedOdometry, CovarianceGrowsWithDistanceAndTheHeadingShrinksAtAFix) {
  HeadingAidedOdometryOptions options;
  HeadingAidedOdometry odometry(options);
  ASSERT_TRUE(odometry.align(Pose2D(), Pose2D()).isOk());
  ASSERT_TRUE(odometry.routePose(Pose2D(2.0, 0.0, 0.0)).isOk());
  const Eigen::Matrix3d before = odometry.covariance();
  EXPECT_NEAR(before(0, 0), 2.0 * options.position_variance_per_metre, 1e-12);
  EXPECT_NEAR(before(2, 2), options.heading_fix_variance + 2.0 * options.heading_variance_per_metre, 1e-12);
  ASSERT_TRUE(odometry.correctHeading(0.0, Pose2D(2.0, 0.0, 0.0)).isOk());
  const Eigen::Matrix3d after = odometry.covariance();
  EXPECT_NEAR(after(0, 0), before(0, 0), 1e-12);  // a heading fix does not fix the position
  EXPECT_NEAR(after(2, 2), options.heading_fix_variance, 1e-12);
  EXPECT_EQ(after(0, 1), 0.0);
}

TEST(HeadingAidedOdometry, BadInputIsAStatusNeverAPose) {
  HeadingAidedOdometry odometry;
  EXPECT_EQ(odometry.routePose(Pose2D()).status().code(), StatusCode::kNoConsensus);
  EXPECT_EQ(odometry.correctHeading(0.0, Pose2D()).code(), StatusCode::kNoConsensus);
  EXPECT_EQ(odometry.align(Pose2D(NAN, 0.0, 0.0), Pose2D()).code(), StatusCode::kInvalidInput);
  ASSERT_TRUE(odometry.align(Pose2D(), Pose2D()).isOk());
  EXPECT_EQ(odometry.routePose(Pose2D(0.0, NAN, 0.0)).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(odometry.correctHeading(NAN, Pose2D()).code(), StatusCode::kInvalidInput);
  HeadingAidedOdometryOptions bad;
  bad.correction_gain = 0.0;
  EXPECT_THROW(HeadingAidedOdometry{bad}, std::invalid_argument);
  bad = HeadingAidedOdometryOptions();
  bad.position_variance_per_metre = -1.0;
  EXPECT_THROW(HeadingAidedOdometry{bad}, std::invalid_argument);
}

}  // namespace
}  // namespace homography_teach_repeat
