#include <gtest/gtest.h>

#include "homography_teach_repeat/common/status.h"

using namespace homography_teach_repeat;

TEST(Status, DefaultIsOk) {
  const Status status;
  EXPECT_TRUE(status.isOk());
  EXPECT_EQ(status.toString(), "OK");
}

TEST(Status, FailureCarriesCodeAndMessage) {
  const Status status(StatusCode::kDegenerate, "collinear points");
  EXPECT_FALSE(status.isOk());
  EXPECT_EQ(status.code(), StatusCode::kDegenerate);
  EXPECT_EQ(status.toString(), "DEGENERATE: collinear points");
}

TEST(Expected, HoldsValue) {
  const Expected<int> value(42);
  ASSERT_TRUE(value.isOk());
  EXPECT_EQ(*value, 42);
  EXPECT_TRUE(value.status().isOk());
}

TEST(Expected, FailureHasNoValueAndThrowsOnAccess) {
  const Expected<int> failure(Status(StatusCode::kTooFewPoints, "3 matches"));
  EXPECT_FALSE(failure.isOk());
  EXPECT_FALSE(static_cast<bool>(failure));
  EXPECT_EQ(failure.status().code(), StatusCode::kTooFewPoints);
  EXPECT_THROW(failure.value(), std::logic_error);
}

TEST(Expected, RefusesOkStatusWithoutValue) {
  EXPECT_THROW(Expected<int>(Status::ok()), std::logic_error);
}
