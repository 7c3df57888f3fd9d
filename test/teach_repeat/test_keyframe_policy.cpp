#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/teach_repeat/keyframe_policy.h"

using namespace homography_teach_repeat;

TEST(KeyframePolicy, DistanceOrAngle) {
  KeyframePolicy policy;
  policy.distance = 1.0;
  policy.angle = 0.3;
  EXPECT_TRUE(policy.shouldStore(std::nullopt, Pose2D()));
  EXPECT_FALSE(policy.shouldStore(Pose2D(0, 0, 0), Pose2D(0.5, 0.5, 0.1)));
  EXPECT_TRUE(policy.shouldStore(Pose2D(0, 0, 0), Pose2D(0.8, 0.7, 0.0)));
  EXPECT_TRUE(policy.shouldStore(Pose2D(0, 0, M_PI - 0.1), Pose2D(0, 0, -M_PI + 0.25)));
  policy.distance = 0.0;
  EXPECT_THROW(policy.validate(), std::invalid_argument);
}
