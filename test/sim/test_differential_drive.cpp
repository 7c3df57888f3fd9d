// The odometry error model shared by the simulator's base and evaluate_sequence's synthesized
// odometry (sim/differential_drive.h).
#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/sim/differential_drive.h"

using namespace homography_teach_repeat;

TEST(SynthesizedOdometry, ExactWithoutErrors) {
  SynthesizedOdometry odometry(OdometryErrorModel(), 1);
  const Pose2D start(2.0, 1.0, 0.5);
  EXPECT_NEAR(odometry.add(start).x, 2.0, 1e-12);
  Pose2D last;
  for (int i = 1; i <= 20; ++i) last = odometry.add(Pose2D(2.0 + 0.1 * i, 1.0 + 0.05 * i, 0.5 + 0.01 * i));
  EXPECT_NEAR(last.x, 4.0, 1e-9);
  EXPECT_NEAR(last.y, 2.0, 1e-9);
  EXPECT_NEAR(last.yaw, 0.7, 1e-9);
}

TEST(SynthesizedOdometry, ScaleErrorAndHeadingBiasGrowWithDistance) {
  OdometryErrorModel model;
  model.scale_error = 0.02;
  model.heading_bias_per_metre = 0.02;
  SynthesizedOdometry odometry(model, 1);
  odometry.add(Pose2D(0, 0, 0));
  Pose2D last;
  double length = 0.0;
  for (int i = 1; i <= 100; ++i) {
    last = odometry.add(Pose2D(0.1 * i, 0.0, 0.0));  // 10 m straight
  }
  EXPECT_NEAR(last.yaw, 0.2, 1e-9);                  // 0.02 rad/m x 10 m
  Pose2D previous(0, 0, 0);
  SynthesizedOdometry again(model, 1);
  again.add(previous);
  for (int i = 1; i <= 100; ++i) {
    const Pose2D p = again.add(Pose2D(0.1 * i, 0.0, 0.0));
    length += std::hypot(p.x - previous.x, p.y - previous.y);
    previous = p;
  }
  EXPECT_NEAR(length, 10.2, 1e-9);  // 2 % long
  OdometryErrorModel bad;
  bad.scale_error = std::nan("");
  EXPECT_THROW(SynthesizedOdometry(bad, 1), std::invalid_argument);
}

TEST(MeasuredMotion, NoiseIsSeeded) {
  OdometryErrorModel model;
  model.distance_noise = 0.01;
  model.heading_noise = 0.01;
  cv::RNG a(7), b(7);
  const auto first = measuredMotion(1.0, 0.1, model, a);
  const auto second = measuredMotion(1.0, 0.1, model, b);
  EXPECT_DOUBLE_EQ(first.first, second.first);
  EXPECT_DOUBLE_EQ(first.second, second.second);
  EXPECT_NE(first.first, 1.0);
}
