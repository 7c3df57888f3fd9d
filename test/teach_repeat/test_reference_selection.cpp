// ReferenceSelector: which keyframes an image is tried against, and tracking along the route.
#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/teach_repeat/reference_selection.h"

using namespace homography_teach_repeat;

namespace {

// A square loop of 8 keyframes 1 m apart (the last 1 m from the first).
std::vector<Pose2D> squareLoop() {
  std::vector<Pose2D> poses;
  for (int i = 0; i < 8; ++i) {
    const int side = i / 2;
    const double along = (i % 2) * 1.0;
    const double yaw = side * M_PI / 2.0;
    const Eigen::Vector2d corner[4] = {{0, 0}, {2, 0}, {2, 2}, {0, 2}};
    const Eigen::Vector2d p = corner[side] + along * Eigen::Vector2d(std::cos(yaw), std::sin(yaw));
    poses.emplace_back(p.x(), p.y(), yaw);
  }
  return poses;
}

}  // namespace

TEST(ReferenceSelector, CandidatesAreTheTrackedKeyframeThenItsNeighboursNearestFirst) {
  ReferenceSelector open(squareLoop(), 0.0);
  EXPECT_FALSE(open.closedRoute());
  open.setTracked(3);
  EXPECT_EQ(open.candidates(2), (std::vector<int>{3, 4, 2, 5, 1}));
  open.setTracked(0);
  EXPECT_EQ(open.candidates(2), (std::vector<int>{0, 1, 2}));
  open.setTracked(99);  // clamped
  EXPECT_EQ(open.tracked(), 7);
}

TEST(ReferenceSelector, AClosedRouteWrapsAround) {
  ReferenceSelector loop(squareLoop(), 1.5);
  ASSERT_TRUE(loop.closedRoute());
  loop.setTracked(7);
  EXPECT_EQ(loop.candidates(2), (std::vector<int>{7, 0, 6, 1, 5}));
  loop.advanceTo(Pose2D(0.1, 0.0, 0.0));  // back at the start: lap 2
  EXPECT_EQ(loop.tracked(), 0);
}

TEST(ReferenceSelector, TrackingMovesOnNeverBackAndIgnoresNonFinitePositions) {
  ReferenceSelector selector(squareLoop(), 0.0);
  selector.advanceTo(Pose2D(2.0, 0.1, M_PI / 2.0));
  EXPECT_EQ(selector.tracked(), 2);
  selector.advanceTo(Pose2D(0.0, 0.0, 0.0));
  EXPECT_EQ(selector.tracked(), 2);
  selector.advanceTo(Pose2D(NAN, 1.0, 0.0));
  EXPECT_EQ(selector.tracked(), 2);
  selector.advanceTo(Pose2D(0.0, 0.9, -M_PI / 2.0));  // past the end of an open route
  EXPECT_EQ(selector.tracked(), 7);
}

TEST(ReferenceSelector, TrackingLeavesALoopsSeamForTheKeyframesAhead) {
  // A loop whose last keyframe was taken back at the start, heading 0.1 rad right of keyframe 0
  // (the teach run's turn in place stopped short): the robot leaves the start heading like the
  // last keyframe. Keyframe 0 shares the last one's place, so it is never closer than the last
  // one; keyframes 1 and 2, straight ahead, are.
  const std::vector<Pose2D> poses{{0.0, 0.0, 0.0},        {0.5, 0.0, 0.0},          {1.0, 0.0, 0.0},
                                  {1.0, 0.5, M_PI / 2.0}, {1.0, 1.0, M_PI},         {0.5, 1.0, M_PI},
                                  {0.0, 1.0, -M_PI / 2.0}, {0.0, 0.5, -M_PI / 2.0}, {0.02, 0.0, -0.1}};
  ReferenceSelector loop(poses, 1.0);
  ASSERT_TRUE(loop.closedRoute());
  loop.setTracked(8);
  loop.advanceTo(Pose2D(0.4, 0.01, -0.1));  // 0.4 m down the first leg
  EXPECT_EQ(loop.tracked(), 1);
  loop.advanceTo(Pose2D(0.9, 0.0, -0.05));
  EXPECT_EQ(loop.tracked(), 2);
}
