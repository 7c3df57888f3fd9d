#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/eval/pose_fusion.h"

using namespace homography_teach_repeat;

TEST(PoseFusion, SingleEstimateIsUnchanged) {
  PoseWithCovariance e{PlanarPose(1.0, 2.0, 0.3), Eigen::Vector3d(0.1, 0.2, 0.01).asDiagonal()};
  const auto fused = fusePoseEstimates({e});
  ASSERT_TRUE(fused.isOk());
  EXPECT_NEAR(fused->pose.x, 1.0, 1e-12);
  EXPECT_NEAR(fused->pose.theta, 0.3, 1e-12);
  EXPECT_LT((fused->covariance - e.covariance).norm(), 1e-12);
}

// Diagonal covariances: each component is the inverse-variance weighted mean.
TEST(PoseFusion, InverseVarianceWeighting) {
  PoseWithCovariance a{PlanarPose(0.0, 0.0, 0.0), Eigen::Vector3d(1.0, 4.0, 0.01).asDiagonal()};
  PoseWithCovariance b{PlanarPose(3.0, 5.0, 0.1), Eigen::Vector3d(2.0, 1.0, 0.01).asDiagonal()};
  const auto fused = fusePoseEstimates({a, b});
  ASSERT_TRUE(fused.isOk());
  EXPECT_NEAR(fused->pose.x, (0.0 / 1.0 + 3.0 / 2.0) / (1.0 + 0.5), 1e-12);
  EXPECT_NEAR(fused->pose.z, (0.0 / 4.0 + 5.0 / 1.0) / (0.25 + 1.0), 1e-12);
  EXPECT_NEAR(fused->pose.theta, 0.05, 1e-12);
  EXPECT_NEAR(fused->covariance(0, 0), 1.0 / 1.5, 1e-12);
  EXPECT_NEAR(fused->covariance(2, 2), 0.005, 1e-12);
}

// Headings on both sides of ±π average to π, not to 0.
TEST(PoseFusion, AnglesAreAveragedAcrossTheWrap) {
  const Eigen::Matrix3d cov = Eigen::Matrix3d::Identity() * 0.01;
  const auto fused = fusePoseEstimates({{PlanarPose(0, 0, M_PI - 0.1), cov},
                                        {PlanarPose(0, 0, -M_PI + 0.1), cov}});
  ASSERT_TRUE(fused.isOk());
  EXPECT_NEAR(std::abs(fused->pose.theta), M_PI, 1e-12);
}

TEST(PoseFusion, RejectsBadInput) {
  EXPECT_EQ(fusePoseEstimates({}).status().code(), StatusCode::kInvalidInput);
  const Eigen::Matrix3d not_pd = Eigen::Vector3d(1.0, -1.0, 1.0).asDiagonal();
  EXPECT_EQ(fusePoseEstimates({{PlanarPose(), not_pd}}).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(fusePoseEstimates({{PlanarPose(std::nan(""), 0, 0), Eigen::Matrix3d::Identity()}})
                .status()
                .code(),
            StatusCode::kInvalidInput);
  Eigen::Matrix3d asymmetric = Eigen::Matrix3d::Identity();
  asymmetric(0, 1) = 0.5;
  EXPECT_EQ(fusePoseEstimates({{PlanarPose(), asymmetric}}).status().code(),
            StatusCode::kInvalidInput);
}
