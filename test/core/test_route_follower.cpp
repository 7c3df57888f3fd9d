#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/route_follower.h"

using namespace homography_teach_repeat;

namespace {

// A 4 x 3 m loop with a keyframe at each corner, heading to the next corner (paper 002's room).
std::vector<Pose2D> squareRoute() {
  return {Pose2D(0, 0, 0), Pose2D(4, 0, M_PI / 2), Pose2D(4, 3, M_PI), Pose2D(0, 3, -M_PI / 2)};
}

Pose2D integrate(const Pose2D& pose, const VelocityCommand& c, double dt) {
  return Pose2D(pose.x + c.linear * std::cos(pose.yaw) * dt,
                pose.y + c.linear * std::sin(pose.yaw) * dt, wrapToPi(pose.yaw + c.angular * dt));
}

}  // namespace

// With a perfect fix every step the robot goes round the loop twice and stops at the end.
TEST(RouteFollower, DrivesTheLoopForEveryLapThenStops) {
  RouteFollowerOptions options;
  options.laps = 2;
  options.start_index = 1;  // the robot starts at keyframe 0
  options.end_index = -1;
  RouteFollower follower(squareRoute(), options);
  Pose2D robot(0.0, 0.0, 0.0);
  const double dt = 0.05;
  int goals_seen = 0, last_goal = -1;
  FollowOutput out;
  for (int k = 0; k < 20000; ++k) {
    const double now = k * dt;
    ASSERT_TRUE(follower.setFix(robot, now).isOk());
    out = follower.update(now, dt);
    if (out.state == FollowState::kFinished) break;
    ASSERT_EQ(out.state, FollowState::kFollowing) << out.reason;
    if (out.goal_index != last_goal) {
      ++goals_seen;
      last_goal = out.goal_index;
    }
    robot = integrate(robot, out.command, dt);
  }
  EXPECT_EQ(out.state, FollowState::kFinished);
  EXPECT_EQ(out.command.linear, 0.0);
  EXPECT_EQ(out.command.angular, 0.0);
  EXPECT_EQ(goals_seen, 6);  // keyframes 1, 2, 3 twice
  EXPECT_LT(std::hypot(robot.x - 0.0, robot.y - 3.0), options.controller.goal_tolerance);
}

TEST(RouteFollower, SafetyStops) {
  RouteFollowerOptions options;
  options.pose_timeout = 0.5;
  RouteFollower follower(squareRoute(), options);
  // No fix yet.
  auto out = follower.update(0.0, 0.05);
  EXPECT_EQ(out.state, FollowState::kWaiting);
  EXPECT_EQ(out.command.linear, 0.0);
  ASSERT_TRUE(follower.setFix(Pose2D(0.5, 0.0, 0.0), 10.0).isOk());
  for (int k = 0; k < 10; ++k) out = follower.update(10.0 + 0.01 * k, 0.05);
  EXPECT_EQ(out.state, FollowState::kFollowing);
  EXPECT_GT(out.command.linear, 0.0);
  // The fix grows old: zero command.
  out = follower.update(10.6, 0.05);
  EXPECT_EQ(out.state, FollowState::kStopped);
  EXPECT_EQ(out.command.linear, 0.0);
  EXPECT_EQ(out.command.angular, 0.0);
  EXPECT_NE(out.reason.find("pose_timeout"), std::string::npos);
  // Lost tracking: zero until a new fix.
  ASSERT_TRUE(follower.setFix(Pose2D(0.6, 0.0, 0.0), 11.0).isOk());
  follower.setLost("no keyframe matches");
  out = follower.update(11.05, 0.05);
  EXPECT_EQ(out.state, FollowState::kStopped);
  EXPECT_EQ(out.command.linear, 0.0);
  ASSERT_TRUE(follower.setFix(Pose2D(0.6, 0.0, 0.0), 11.1).isOk());
  EXPECT_EQ(follower.update(11.15, 0.05).state, FollowState::kFollowing);
  // NaN fix.
  EXPECT_EQ(follower.setFix(Pose2D(std::nan(""), 0.0, 0.0), 11.2).code(), StatusCode::kInvalidInput);
  out = follower.update(11.25, 0.05);
  EXPECT_EQ(out.state, FollowState::kStopped);
  EXPECT_EQ(out.command.linear, 0.0);
}

TEST(RouteFollower, BadOptions) {
  RouteFollowerOptions options;
  EXPECT_THROW(RouteFollower({}, options), std::invalid_argument);
  options.start_index = 7;
  EXPECT_THROW(RouteFollower(squareRoute(), options), std::invalid_argument);
  options = RouteFollowerOptions();
  options.laps = 0;
  EXPECT_THROW(RouteFollower(squareRoute(), options), std::invalid_argument);
  options = RouteFollowerOptions();
  options.pose_timeout = -1.0;
  EXPECT_THROW(RouteFollower(squareRoute(), options), std::invalid_argument);
}

// dynamic_reconfigure retunes the controller and the timeout; a bad value changes nothing.
TEST(RouteFollower, RetuneChangesTheTunablesOnly) {
  RouteFollowerOptions options;
  options.laps = 2;
  RouteFollower follower(squareRoute(), options);
  ASSERT_TRUE(follower.setFix(Pose2D(0.1, 0.0, 0.0), 0.0).isOk());
  RouteFollowerOptions tuned = options;
  tuned.pose_timeout = 2.0;
  tuned.controller.max_linear_velocity = 0.2;
  tuned.laps = 5;  // ignored: the goal sequence stays
  follower.retune(tuned);
  EXPECT_EQ(follower.options().pose_timeout, 2.0);
  EXPECT_EQ(follower.controller().parameters().max_linear_velocity, 0.2);
  EXPECT_EQ(follower.options().laps, 2);
  // The fix at t = 0 is still fresh at 1.5 s with the new timeout.
  EXPECT_EQ(follower.update(1.5, 0.05).state, FollowState::kFollowing);
  RouteFollowerOptions bad = tuned;
  bad.pose_timeout = 0.0;
  EXPECT_THROW(follower.retune(bad), std::invalid_argument);
  EXPECT_EQ(follower.options().pose_timeout, 2.0);
}
