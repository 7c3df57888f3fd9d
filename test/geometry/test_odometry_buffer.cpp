#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/geometry/odometry_buffer.h"

using namespace homography_teach_repeat;

TEST(OdometryBuffer, InterpolatesByStampIncludingAcrossThePiWrap) {
  OdometryBuffer buffer;
  ASSERT_TRUE(buffer.add(10.0, Pose2D(0.0, 0.0, M_PI - 0.1)).isOk());
  ASSERT_TRUE(buffer.add(10.2, Pose2D(1.0, 2.0, -M_PI + 0.1)).isOk());
  const auto mid = buffer.poseAt(10.1);
  ASSERT_TRUE(mid.isOk());
  EXPECT_NEAR(mid->x, 0.5, 1e-12);
  EXPECT_NEAR(mid->y, 1.0, 1e-12);
  EXPECT_NEAR(std::abs(mid->yaw), M_PI, 1e-12);
  EXPECT_NEAR(buffer.poseAt(10.2)->x, 1.0, 1e-12);
}

TEST(OdometryBuffer, RefusesNanOutOfOrderAndOutOfRange) {
  OdometryBuffer buffer(1.0, 0.3);
  EXPECT_EQ(buffer.poseAt(1.0).status().code(), StatusCode::kTooFewPoints);
  EXPECT_EQ(buffer.add(1.0, Pose2D(std::nan(""), 0, 0)).code(), StatusCode::kInvalidInput);
  EXPECT_TRUE(buffer.empty());
  ASSERT_TRUE(buffer.add(1.0, Pose2D(0, 0, 0)).isOk());
  ASSERT_TRUE(buffer.add(1.1, Pose2D(0.1, 0, 0)).isOk());
  EXPECT_EQ(buffer.add(1.05, Pose2D(0, 0, 0)).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(buffer.poseAt(1.2).status().code(), StatusCode::kNoConsensus);  // not yet
  EXPECT_EQ(buffer.poseAt(0.5).status().code(), StatusCode::kInvalidInput);
  ASSERT_TRUE(buffer.add(2.0, Pose2D(1, 0, 0)).isOk());  // 0.9 s gap
  EXPECT_EQ(buffer.poseAt(1.5).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(buffer.poseAt(0.95).status().code(), StatusCode::kInvalidInput);  // dropped (capacity)
}


// An image a little newer than the newest odometry gets the newest sample; much newer does not.
TEST(OdometryBuffer, PoseNearAcceptsASmallLag) {
  OdometryBuffer buffer;
  ASSERT_TRUE(buffer.add(1.0, Pose2D(0.0, 0.0, 0.0)).isOk());
  ASSERT_TRUE(buffer.add(1.1, Pose2D(0.1, 0.0, 0.0)).isOk());
  const auto interpolated = buffer.poseNear(1.05, 0.1);
  ASSERT_TRUE(interpolated);
  EXPECT_NEAR(interpolated->x, 0.05, 1e-12);
  const auto newest = buffer.poseNear(1.15, 0.1);
  ASSERT_TRUE(newest);
  EXPECT_EQ(newest->x, 0.1);
  EXPECT_EQ(buffer.poseNear(1.3, 0.1).status().code(), StatusCode::kNoConsensus);
  EXPECT_FALSE(buffer.poseNear(NAN, 0.1));
}
