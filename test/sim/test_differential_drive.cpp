// The odometry error model shared by the simulator's base and evaluate_sequence's synthesized
// odometry (sim/differential_drive.h).
#include <gtest/gtest.h>

#include <Eigen/Cholesky>

#include <cmath>
#include <vector>

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

// The odometry covariance the simulated base publishes is the spread of its odometry: 400 runs of
// the same 4 m arc (noise only) against the propagated covariance; NEES mean ~3 and each std
// within 12 % of the empirical one.
TEST(DifferentialDriveSim, OdometryCovarianceMatchesTheSpread) {
  OdometryErrorModel model;
  model.distance_noise = 0.02;
  model.heading_noise = 0.01;
  DriveLimits limits;
  constexpr int kRuns = 400;
  std::vector<Eigen::Vector3d> endpoints;
  Eigen::Matrix3d predicted = Eigen::Matrix3d::Zero();
  Pose2D truth_end;
  for (int run = 0; run < kRuns; ++run) {
    DifferentialDriveSim robot(Pose2D(1.0, 2.0, 0.3), model, limits, 100 + run);
    for (int step = 0; step < 400; ++step) robot.step(0.5, 0.2, 0.02);  // 4 m, 0.8 rad
    endpoints.emplace_back(robot.odometry().x, robot.odometry().y, robot.odometry().yaw);
    predicted = robot.odometryCovariance();
    truth_end = robot.truth();
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& e : endpoints) mean += e / kRuns;
  Eigen::Matrix3d spread = Eigen::Matrix3d::Zero();
  double nees = 0.0;
  const Eigen::Vector3d truth(truth_end.x, truth_end.y, truth_end.yaw);
  for (const auto& e : endpoints) {
    spread += (e - mean) * (e - mean).transpose() / (kRuns - 1);
    nees += (e - truth).dot(predicted.ldlt().solve(e - truth)) / kRuns;
  }
  EXPECT_NEAR(mean.z(), truth.z(), 0.003);  // no bias in the model: centred on the truth
  for (int i = 0; i < 3; ++i) {
    EXPECT_NEAR(std::sqrt(predicted(i, i)) / std::sqrt(spread(i, i)), 1.0, 0.12) << i;
  }
  EXPECT_GT(nees, 2.6);
  EXPECT_LT(nees, 3.4);
  // A reset starts a new covariance; no motion adds nothing.
  DifferentialDriveSim robot(Pose2D(0, 0, 0), model, limits, 1);
  robot.step(0.5, 0.0, 0.1);
  EXPECT_GT(robot.odometryCovariance()(0, 0), 0.0);
  robot.reset(Pose2D(0, 0, 0), Pose2D(0, 0, 0));
  robot.step(0.0, 0.0, 0.1);
  EXPECT_EQ(robot.odometryCovariance(), Eigen::Matrix3d::Zero());
}

// The velocity odometry reports over an interval: forward, backward and turning, its covariance
// from the random walk, and nothing for an empty interval.
TEST(VelocityFromOdometry, SignedSpeedYawRateAndCovariance) {
  OdometryErrorModel model;
  model.distance_noise = 0.01;
  model.heading_noise = 0.002;
  const Pose2D start(1.0, 1.0, M_PI / 2);
  const MeasuredVelocity forward = velocityFromOdometry(start, integrateArc(start, 0.4, 0.1, 0.5), 0.5, model);
  EXPECT_NEAR(forward.v, 0.4, 1e-3);  // chord of a gentle arc
  EXPECT_NEAR(forward.w, 0.1, 1e-12);
  EXPECT_NEAR(forward.covariance(0, 0), 1e-4 * 0.2 / 0.25, 1e-6);
  EXPECT_NEAR(forward.covariance(1, 1), 4e-6 * 0.2 / 0.25, 1e-8);
  const MeasuredVelocity backward = velocityFromOdometry(start, integrateArc(start, -0.3, 0.0, 0.5), 0.5, model);
  EXPECT_NEAR(backward.v, -0.3, 1e-12);
  const MeasuredVelocity none = velocityFromOdometry(start, start, 0.0, model);
  EXPECT_EQ(none.v, 0.0);
  EXPECT_EQ(none.covariance, Eigen::Matrix2d::Zero());
}
