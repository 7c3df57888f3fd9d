#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

#include "homography_teach_repeat/sim/differential_drive.h"
#include "homography_teach_repeat/eval/path_deviation.h"
#include "homography_teach_repeat/control/route_follower.h"

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

// A taught loop like scripts/demo's: keyframes every 0.5 m along a 3 x 2 m rectangle and two more
// while turning in place at each corner, including the start corner where the teach run ends
// turning back to its start heading.
std::vector<Pose2D> taughtLoop() {
  const std::vector<Eigen::Vector2d> corners = {{1, 1}, {4, 1}, {4, 3}, {1, 3}, {1, 1}};
  std::vector<Pose2D> route;
  for (std::size_t c = 0; c + 1 < corners.size(); ++c) {
    const Eigen::Vector2d edge = corners[c + 1] - corners[c];
    const double yaw = std::atan2(edge.y(), edge.x());
    if (c > 0) {
      const double previous = route.back().yaw;
      for (int k = 1; k <= 2; ++k) {
        route.emplace_back(corners[c].x(), corners[c].y(), wrapToPi(previous + k / 3.0 * wrapToPi(yaw - previous)));
      }
    }
    const double length = edge.norm();
    for (double s = 0.0; s < length - (c + 2 == corners.size() ? 0.45 : 0.25); s += 0.5) {
      const Eigen::Vector2d p = corners[c] + s / length * edge;
      route.emplace_back(p.x(), p.y(), yaw);
    }
  }
  for (int k = 1; k <= 2; ++k) route.emplace_back(1.0, 1.0, -M_PI / 2 + k / 3.0 * M_PI / 2);
  return route;
}

// Closed-loop run with fixes at 10 Hz that are 0.05 s old when they arrive, control at 20 Hz.
Pose2D runClosedLoop(RouteFollower& follower, Pose2D robot, int max_steps, FollowOutput* last = nullptr,
                     const std::vector<Pose2D>* path = nullptr, double* max_deviation = nullptr) {
  const double dt = 0.05;
  Pose2D fix = robot;
  FollowOutput out;
  for (int k = 0; k < max_steps; ++k) {
    const double now = k * dt;
    if (k % 2 == 0) {
      EXPECT_TRUE(follower.setFix(fix, now).isOk());
    }
    fix = robot;
    out = follower.update(now, dt);
    if (out.state == FollowState::kFinished) break;
    EXPECT_EQ(out.state, FollowState::kFollowing) << out.reason;
    robot = integrateArc(robot, out.command.linear, out.command.angular, dt);
    if (path != nullptr && max_deviation != nullptr) {
      *max_deviation = std::max(*max_deviation, deviationFromPath(*path, robot).distance);
    }
  }
  if (last != nullptr) *last = out;
  return robot;
}

}  // namespace

// A closed route ends where the robot started: after the laps the follower goes back to the
// keyframe before start_index and turns to its heading (the end pose of the run, not a point
// within ε of the last keyframe).
TEST(RouteFollower, ClosedLoopEndsAtTheStartPose) {
  const std::vector<Pose2D> route = taughtLoop();
  ASSERT_TRUE(isClosedLoop(route, 1.0));
  RouteFollowerOptions options;
  options.laps = 5;
  options.start_index = 1;
  options.controller.goal_tolerance = 0.4;
  RouteFollower follower(route, options);
  FollowOutput out;
  double max_deviation = 0.0;
  const Pose2D end = runClosedLoop(follower, route.front(), 40000, &out, &route, &max_deviation);
  ASSERT_EQ(out.state, FollowState::kFinished) << out.reason;
  // Corners where the teach run turned in place are turned at (corner_tolerance), not cut at ε.
  EXPECT_LT(max_deviation, 0.2);
  EXPECT_EQ(out.command.linear, 0.0);
  EXPECT_EQ(out.command.angular, 0.0);
  EXPECT_LT(std::hypot(end.x - route.front().x, end.y - route.front().y), options.final_goal_tolerance + 0.01);
  EXPECT_LT(std::abs(wrapToPi(end.yaw - route.front().yaw)), options.final_heading_tolerance + 0.01);
  EXPECT_EQ(out.lap, 4);

  options.return_to_start = false;  // ends at the last keyframe instead, with its heading
  RouteFollower open_end(route, options);
  const Pose2D end2 = runClosedLoop(open_end, route.front(), 40000, &out);
  ASSERT_EQ(out.state, FollowState::kFinished) << out.reason;
  EXPECT_LT(std::hypot(end2.x - route.back().x, end2.y - route.back().y), options.final_goal_tolerance + 0.01);
  EXPECT_LT(std::abs(wrapToPi(end2.yaw - route.back().yaw)), options.final_heading_tolerance + 0.01);
}

// The last goal beside or behind the robot: it turns towards it first instead of circling it.
TEST(RouteFollower, FinalApproachFromAnyDirection) {
  const std::vector<Pose2D> route = {Pose2D(0, 0, 0), Pose2D(1, 0, 0), Pose2D(1.3, 0.0, 1.0)};
  RouteFollowerOptions options;
  options.start_index = 2;
  for (const Pose2D& start : {Pose2D(1.0, 0.5, 0.0), Pose2D(2.0, 0.2, 0.0), Pose2D(1.5, -0.3, -2.5)}) {
    RouteFollower follower(route, options);
    FollowOutput out;
    const Pose2D end = runClosedLoop(follower, start, 4000, &out);
    ASSERT_EQ(out.state, FollowState::kFinished) << out.reason;
    EXPECT_LT(std::hypot(end.x - 1.3, end.y), options.final_goal_tolerance + 0.01);
    EXPECT_LT(std::abs(wrapToPi(end.yaw - 1.0)), options.final_heading_tolerance + 0.01);
  }
  options.align_final_heading = false;  // stops at the point with whatever heading it has
  RouteFollower follower(route, options);
  FollowOutput out;
  const Pose2D end = runClosedLoop(follower, Pose2D(1.0, 0.0, 0.0), 4000, &out);
  ASSERT_EQ(out.state, FollowState::kFinished);
  EXPECT_LT(std::hypot(end.x - 1.3, end.y), options.final_goal_tolerance + 0.01);
  EXPECT_GT(std::abs(wrapToPi(end.yaw - 1.0)), 0.5);
}

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

// A failure report for a frame whose pose already arrived (same stamp or older) does not stop the
// robot; a newer one does.
TEST(RouteFollower, LostReportOlderThanTheFixIsIgnored) {
  RouteFollower follower(squareRoute(), RouteFollowerOptions());
  ASSERT_TRUE(follower.setFix(Pose2D(0.1, 0.0, 0.0), 10.0).isOk());
  follower.setLost("no heading fix", 10.0);
  EXPECT_EQ(follower.update(10.05, 0.05).state, FollowState::kFollowing);
  follower.setLost("no heading fix", 9.9);
  EXPECT_EQ(follower.update(10.1, 0.05).state, FollowState::kFollowing);
  follower.setLost("lost", 10.1);
  EXPECT_EQ(follower.update(10.15, 0.05).state, FollowState::kStopped);
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
  for (double RouteFollowerOptions::*field :
       {&RouteFollowerOptions::final_approach_distance, &RouteFollowerOptions::final_goal_tolerance,
        &RouteFollowerOptions::final_turn_angle, &RouteFollowerOptions::final_approach_gain,
        &RouteFollowerOptions::final_turn_gain, &RouteFollowerOptions::final_heading_tolerance,
        &RouteFollowerOptions::closed_route_gap, &RouteFollowerOptions::degraded_speed_factor,
        &RouteFollowerOptions::lost_search_delay, &RouteFollowerOptions::lost_search_angle,
        &RouteFollowerOptions::lost_search_velocity, &RouteFollowerOptions::corner_deceleration}) {
    options = RouteFollowerOptions();
    options.*field = std::nan("");
    EXPECT_THROW(RouteFollower(squareRoute(), options), std::invalid_argument);
  }
}

// The pose's integrity: DEGRADED caps the speeds at degraded_speed_factor of the limits; LOST
// stops the robot at once (no linear motion while LOST), then after lost_search_delay turns it in
// place to each side by lost_search_angle; OK again, it follows the route at full speed. An
// integrity report older than the last one is ignored.
TEST(RouteFollower, IntegritySlowsDownStopsAndSearches) {
  RouteFollowerOptions options;
  options.controller.max_linear_velocity = 0.5;
  options.degraded_speed_factor = 0.4;
  options.lost_search_delay = 1.0;
  options.lost_search_angle = 0.6;
  options.lost_search_velocity = 0.3;
  RouteFollower follower(squareRoute(), options);
  double now = 10.0;
  FollowOutput out;
  auto run = [&](double seconds, PoseTrust trust, double* max_linear = nullptr, double* turned = nullptr) {
    for (double t = 0.0; t < seconds; t += 0.05) {
      now += 0.05;
      EXPECT_TRUE(follower.setFix(Pose2D(0.5, 0.0, 0.0), now).isOk());
      follower.setTrust(trust, "test", now);
      out = follower.update(now, 0.05);
      if (max_linear != nullptr) *max_linear = std::max(*max_linear, out.command.linear);
      if (turned != nullptr) *turned += out.command.angular * 0.05;
    }
  };
  double full = 0.0, slow = 0.0;
  run(3.0, PoseTrust::kOk, &full);
  EXPECT_GT(full, 0.45);  // the dynamics of eq. (3) approach the limit
  run(3.0, PoseTrust::kDegraded);
  run(1.0, PoseTrust::kDegraded, &slow);
  EXPECT_NEAR(slow, 0.2, 1e-9);
  EXPECT_EQ(out.state, FollowState::kFollowing);
  EXPECT_NE(out.reason.find("DEGRADED"), std::string::npos) << out.reason;
  // LOST: at once no linear motion; standing for lost_search_delay, then turning to each side.
  double linear = 0.0, turned = 0.0;
  run(0.05, PoseTrust::kLost, &linear);
  EXPECT_EQ(out.command.linear, 0.0);
  EXPECT_EQ(out.state, FollowState::kStopped);
  run(0.9, PoseTrust::kLost, &linear, &turned);
  EXPECT_EQ(linear, 0.0);
  EXPECT_EQ(turned, 0.0);
  run(2.0, PoseTrust::kLost, &linear, &turned);
  EXPECT_EQ(out.state, FollowState::kSearching);
  EXPECT_NE(out.reason.find("turning in place"), std::string::npos) << out.reason;
  EXPECT_GT(turned, 0.4);  // towards +0.6 rad within the acceleration limit
  double extreme = turned;
  for (int i = 0; i < 200; ++i) {
    run(0.05, PoseTrust::kLost, &linear, &turned);
    extreme = std::max(extreme, std::abs(turned));
  }
  EXPECT_EQ(linear, 0.0);  // never a linear motion while LOST
  EXPECT_LT(extreme, 0.7);
  EXPECT_GT(extreme, 0.5);
  // An older report does not change the verdict; a new OK does.
  follower.setTrust(PoseTrust::kOk, "old", now - 1.0);
  now += 0.05;
  EXPECT_TRUE(follower.setFix(Pose2D(0.5, 0.0, 0.0), now).isOk());
  EXPECT_EQ(follower.update(now, 0.05).state, FollowState::kSearching);
  double back = 0.0;
  run(3.0, PoseTrust::kOk, &back);
  EXPECT_EQ(out.state, FollowState::kFollowing);
  EXPECT_GT(back, 0.45);
}

// lost_search_angle 0: a LOST robot stands.
TEST(RouteFollower, LostWithoutSearchStands) {
  RouteFollowerOptions options;
  options.lost_search_angle = 0.0;
  RouteFollower follower(squareRoute(), options);
  FollowOutput out;
  for (int k = 0; k < 100; ++k) {
    const double now = 1.0 + 0.05 * k;
    ASSERT_TRUE(follower.setFix(Pose2D(0.5, 0.0, 0.0), now).isOk());
    follower.setTrust(PoseTrust::kLost, "covered", now);
    out = follower.update(now, 0.05);
    EXPECT_EQ(out.command.linear, 0.0);
    EXPECT_EQ(out.command.angular, 0.0);
  }
  EXPECT_EQ(out.state, FollowState::kStopped);
  EXPECT_NE(out.reason.find("covered"), std::string::npos) << out.reason;
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

// The fix is of the instant its image was taken: with fresh odometry it is carried to now on the
// odometry's increment (any odom frame), and stops the robot only after carried_pose_timeout;
// without fresh odometry the fix alone counts, with pose_timeout.
TEST(RouteFollower, CarriesTheFixForwardOnOdometry) {
  RouteFollowerOptions options;
  options.pose_timeout = 0.5;
  options.carried_pose_timeout = 1.5;
  options.odometry_timeout = 0.2;
  RouteFollower follower(squareRoute(), options);
  // The odom frame is turned and shifted against the route frame: only increments matter.
  auto odometry = [](double t) { return Pose2D(2.0, 1.0 + 0.5 * (t - 9.9), M_PI / 2); };
  for (double t = 9.9; t < 10.31; t += 0.05) ASSERT_TRUE(follower.addOdometry(odometry(t), t).isOk());
  ASSERT_TRUE(follower.setFix(Pose2D(0.5, 0.0, 0.0), 10.0).isOk());
  auto out = follower.update(10.3, 0.05);
  EXPECT_EQ(out.state, FollowState::kFollowing);
  EXPECT_NEAR(out.distance_to_goal, 4.0 - (0.5 + 0.5 * 0.3), 1e-9);  // goal (4, 0), moved 0.15 m
  // Older than pose_timeout, carried: still following, from where the odometry says it is.
  for (double t = 10.35; t < 11.21; t += 0.05) ASSERT_TRUE(follower.addOdometry(odometry(t), t).isOk());
  out = follower.update(11.2, 0.05);
  EXPECT_EQ(out.state, FollowState::kFollowing) << out.reason;
  EXPECT_NEAR(out.distance_to_goal, 4.0 - (0.5 + 0.5 * 1.2), 1e-6);
  // Older than carried_pose_timeout: stopped.
  for (double t = 11.25; t < 11.61; t += 0.05) ASSERT_TRUE(follower.addOdometry(odometry(t), t).isOk());
  out = follower.update(11.6, 0.05);
  EXPECT_EQ(out.state, FollowState::kStopped);
  EXPECT_EQ(out.command.linear, 0.0);
  EXPECT_NE(out.reason.find("carried_pose_timeout"), std::string::npos) << out.reason;
  // A new fix while the odometry has gone silent: the fix alone, and pose_timeout.
  ASSERT_TRUE(follower.setFix(Pose2D(1.0, 0.0, 0.0), 11.9).isOk());
  out = follower.update(12.0, 0.05);
  EXPECT_EQ(out.state, FollowState::kFollowing);
  EXPECT_NEAR(out.distance_to_goal, 3.0, 1e-9);
  out = follower.update(12.5, 0.05);
  EXPECT_EQ(out.state, FollowState::kStopped);
  EXPECT_NE(out.reason.find("than pose_timeout"), std::string::npos) << out.reason;
  // Bad odometry is refused and changes nothing.
  EXPECT_EQ(follower.addOdometry(Pose2D(std::nan(""), 0.0, 0.0), 12.6).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(follower.addOdometry(odometry(11.0), 11.0).code(), StatusCode::kInvalidInput);  // stamp goes back
}

TEST(RouteFollower, RefusesOdometryTimeoutsOutOfRange) {
  RouteFollowerOptions options;
  options.carried_pose_timeout = -1.0;
  EXPECT_THROW(RouteFollower(squareRoute(), options), std::invalid_argument);
  options = RouteFollowerOptions();
  options.odometry_timeout = std::nan("");
  EXPECT_THROW(RouteFollower(squareRoute(), options), std::invalid_argument);
  options.odometry_timeout = 0.0;
  EXPECT_THROW(RouteFollower(squareRoute(), options), std::invalid_argument);
}

// Keyframes 0.5 m apart on a straight leg with ε 0.4 m: the attraction towards the next keyframe
// alone settles at v = F/2b = d/2 (0.2-0.45 m/s, 0.32 on average); with the straight leg beyond the goal it reaches
// the speed limit, and it still slows down before the corner.
TEST(RouteFollower, KeepsItsSpeedAlongAStraightLeg) {
  std::vector<Pose2D> goals;
  for (int k = 0; k <= 12; ++k) goals.emplace_back(0.5 * k, 0.0, 0.0);  // 6 m straight
  goals.emplace_back(6.0, 0.0, M_PI / 2);                             // a turn in place
  goals.emplace_back(6.0, 0.5, M_PI / 2);
  auto averageSpeed = [&](double straight_leg_angle, double* speed_before_corner) {
    RouteFollowerOptions options;
    options.controller.goal_tolerance = 0.4;
    options.controller.max_linear_velocity = 0.5;
    options.straight_leg_angle = straight_leg_angle;
    if (straight_leg_angle == 0.0) options.corner_deceleration = 0.0;  // paper 002's field
    RouteFollower follower(goals, options);
    Pose2D pose(0.0, 0.0, 0.0);
    double sum = 0.0;
    int samples = 0;
    const double dt = 0.05;
    for (double t = 0.0; t < 30.0 && pose.x < 5.85; t += dt) {
      EXPECT_TRUE(follower.setFix(pose, t).isOk());
      const FollowOutput out = follower.update(t, dt);
      EXPECT_EQ(out.state, FollowState::kFollowing) << out.reason;
      if (pose.x > 1.0 && pose.x < 4.5) {
        sum += out.command.linear;
        ++samples;
      }
      if (pose.x > 5.75) *speed_before_corner = out.command.linear;
      pose = integrate(pose, out.command, dt);
    }
    return sum / std::max(1, samples);
  };
  double before_corner_paper = 0.0, before_corner = 0.0;
  const double paper = averageSpeed(0.0, &before_corner_paper);
  const double straight = averageSpeed(0.35, &before_corner);
  EXPECT_LT(paper, 0.35);
  EXPECT_GT(straight, 0.45);
  EXPECT_LT(before_corner, 0.45);  // slowing down for the turn in place at x = 6
  std::printf("straight leg: %.2f m/s with the leg beyond the goal, %.2f m/s towards the goal alone; "
              "%.2f m/s 0.15-0.25 m before the corner\n", straight, paper, before_corner);
}

// Towards a corner the paper's attraction settles at v = d/2: the robot crawled the last metre of
// every leg (0.1 m/s 0.2 m before the corner). Braking at corner_deceleration it keeps its speed to
// about 0.4 m before the corner and still turns where the route turns.
TEST(RouteFollower, BrakesLateForACorner) {
  const std::vector<Pose2D> route = taughtLoop();
  struct Run {
    double time = 0.0, max_deviation = 0.0, speed_before = 0.0, corner_miss = 0.0;
  };
  auto lap = [&](double corner_deceleration) {
    RouteFollowerOptions options;
    options.start_index = 1;
    options.controller.goal_tolerance = 0.4;
    options.corner_deceleration = corner_deceleration;
    RouteFollower follower(route, options);
    Pose2D robot = route.front();
    Run run;
    const double dt = 0.05;
    FollowOutput out;
    for (int k = 0; k < 4000; ++k) {
      EXPECT_TRUE(follower.setFix(robot, k * dt).isOk());
      out = follower.update(k * dt, dt);
      if (out.state == FollowState::kFinished) break;
      EXPECT_EQ(out.state, FollowState::kFollowing) << out.reason;
      robot = integrateArc(robot, out.command.linear, out.command.angular, dt);
      run.time += dt;
      run.max_deviation = std::max(run.max_deviation, deviationFromPath(route, robot).distance);
      // On the first leg (y = 1, towards the corner at x = 4): the speed 0.5 m before the corner,
      // and how far the robot stood from the corner when it turned there.
      if (std::abs(robot.yaw) < 0.05 && robot.x > 3.45 && robot.x < 3.5) run.speed_before = out.command.linear;
      if (std::abs(out.command.angular) > 0.3 && out.command.linear < 0.01 && robot.x > 3.0 && robot.y < 1.5) {
        run.corner_miss = std::max(run.corner_miss, std::hypot(robot.x - 4.0, robot.y - 1.0));
      }
    }
    EXPECT_EQ(out.state, FollowState::kFinished) << out.reason;
    return run;
  };
  const Run paper = lap(0.0), braking = lap(0.3);
  std::printf("lap: %.1f s braking at 0.3 m/s^2 (%.2f m/s 0.5 m before the corner, turned %.3f m from it, "
              "%.3f m off the path), %.1f s with the paper's field (%.2f m/s, %.3f m, %.3f m)\n",
              braking.time, braking.speed_before, braking.corner_miss, braking.max_deviation, paper.time,
              paper.speed_before, paper.corner_miss, paper.max_deviation);
  EXPECT_LT(braking.time, paper.time - 4.0);
  EXPECT_GT(braking.speed_before, 0.45);
  EXPECT_LT(paper.speed_before, 0.4);
  EXPECT_LT(braking.corner_miss, RouteFollowerOptions().corner_tolerance);
  EXPECT_LT(braking.max_deviation, 0.2);
}

// With config/controller_node.yaml's ε (0.7 m, keyframes 0.5 m apart) the goals passed at a corner
// include the next leg's first ones: the turn in place stopped at turn_in_place_angle (0.5 rad)
// instead of turn_in_place_exit_angle, the robot left every corner 0.3 rad off and bowed 0.26 m
// off the next leg (the demo: 0.2 m in every world, while its pose was within millimetres).
TEST(RouteFollower, LeavesEveryCornerAlongTheNextLeg) {
  const std::vector<Pose2D> route = taughtLoop();
  RouteFollowerOptions options;
  options.start_index = 1;
  options.controller.goal_tolerance = 0.7;
  RouteFollower follower(route, options);
  FollowOutput out;
  double max_deviation = 0.0;
  runClosedLoop(follower, route.front(), 4000, &out, &route, &max_deviation);
  ASSERT_EQ(out.state, FollowState::kFinished) << out.reason;
  std::printf("epsilon 0.7 m: %.3f m off the taught loop at most\n", max_deviation);
  EXPECT_LT(max_deviation, 0.1);
}

// A person standing on the route: the robot slows down, stops short of them (the cap and the
// repulsion together; never closer than its radius) and waits; once they step aside it drives on to the end. The
// obstacle is given as laser points on the person's front (robot frame), as the scan shows them.
TEST(RouteFollower, WaitsForSomeoneStandingInTheWay) {
  std::vector<Pose2D> goals;
  for (int k = 0; k <= 8; ++k) goals.emplace_back(0.5 * k, 0.0, 0.0);  // 4 m straight
  RouteFollowerOptions options;
  options.controller.goal_tolerance = 0.4;
  RouteFollower follower(goals, options);
  const Eigen::Vector2d person(2.5, 0.05);  // centre; a 0.3 x 0.5 m body
  auto pointsOfPerson = [&](const Pose2D& robot) {
    std::vector<Eigen::Vector2d> points;
    for (double y = -0.25; y <= 0.25; y += 0.02) {
      const Eigen::Vector2d world(person.x() - 0.15, person.y() + y);  // the side facing the robot
      const double dx = world.x() - robot.x, dy = world.y() - robot.y;
      points.emplace_back(std::cos(robot.yaw) * dx + std::sin(robot.yaw) * dy,
                          -std::sin(robot.yaw) * dx + std::cos(robot.yaw) * dy);
    }
    return points;
  };
  Pose2D pose(0.0, 0.0, 0.0);
  const double dt = 0.05;
  double closest = 1e9;
  bool waited = false;
  FollowOutput out;
  double t = 0.0;
  for (; t < 60.0; t += dt) {
    const bool standing = t < 20.0;
    ASSERT_TRUE(follower.setFix(pose, t).isOk());
    out = follower.update(t, dt, standing ? pointsOfPerson(pose) : std::vector<Eigen::Vector2d>{});
    if (out.state == FollowState::kFinished) break;
    ASSERT_EQ(out.state, FollowState::kFollowing) << out.reason;
    if (standing) {
      closest = std::min(closest, person.x() - 0.15 - pose.x);
      if (t > 15.0) {
        EXPECT_NEAR(out.command.linear, 0.0, 1e-3);  // creeping to the stop gap at most
        EXPECT_NE(out.reason.find("something in the way"), std::string::npos) << out.reason;
        waited = true;
      }
    }
    pose = integrate(pose, out.command, dt);
  }
  EXPECT_TRUE(waited);
  EXPECT_EQ(out.state, FollowState::kFinished) << out.reason;
  EXPECT_GT(closest, options.robot_radius + 0.5 * options.obstacle_stop_gap);
  EXPECT_LT(closest, options.robot_radius + options.obstacle_slow_gap);  // it did come up to them
  EXPECT_NEAR(pose.x, 4.0, 0.1);
  std::printf("stopped %.2f m from the person's front (radius %.2f), finished at t = %.1f s\n", closest,
              options.robot_radius, t);
}

// Someone standing beside the path, their body reaching 0.15 m into the corridor (the simulator's
// visitor pausing by the room's route): the robot moves onto a lane beside them (pass_offset),
// keeps most of its speed, never comes within its radius of them, and comes back to the route.
// Without passing (pass_offset 0) the same robot crawls up to them and waits for good.
TEST(RouteFollower, PassesSomeoneStandingBesideThePath) {
  std::vector<Pose2D> goals;
  for (int k = 0; k <= 10; ++k) goals.emplace_back(0.5 * k, 0.0, 0.0);  // 5 m straight
  // A 0.3 x 0.5 m body centred 0.4 m right of the path at x = 2.5: its near edge 0.15 m off it.
  const double near_edge = -0.15, far_edge = -0.65, front = 2.35, back = 2.65;
  auto pointsOfPerson = [&](const Pose2D& robot) {
    std::vector<Eigen::Vector2d> points;
    auto add = [&](double x, double y) {
      const double dx = x - robot.x, dy = y - robot.y;
      points.emplace_back(std::cos(robot.yaw) * dx + std::sin(robot.yaw) * dy,
                          -std::sin(robot.yaw) * dx + std::cos(robot.yaw) * dy);
    };
    for (double y = far_edge; y <= near_edge + 1e-9; y += 0.02) add(front, y);
    for (double x = front; x <= back + 1e-9; x += 0.02) add(x, near_edge);
    return points;
  };
  auto clearance = [&](const Pose2D& robot) {  // from the robot's centre to the body
    const double dx = std::max({front - robot.x, 0.0, robot.x - back});
    const double dy = std::max({far_edge - robot.y, 0.0, robot.y - near_edge});
    return std::hypot(dx, dy);
  };
  struct Run {
    bool finished = false;
    double speed = 0.0;    // [m/s] mean from 1.35 m before the body to 0.85 m past it
    double closest = 1e9;  // [m] from the robot's centre to the body
    double end_offset = 0.0;  // [m] from the route's line at the end
  };
  auto drive = [&](const RouteFollowerOptions& options) {
    RouteFollower follower(goals, options);
    Pose2D pose(0.0, 0.0, 0.0);
    const double dt = 0.05;
    Run run;
    double distance = 0.0, time_near = 0.0;
    for (double t = 0.0; t < 40.0; t += dt) {
      EXPECT_TRUE(follower.setFix(pose, t).isOk());
      const FollowOutput out = follower.update(t, dt, pointsOfPerson(pose));
      if (out.state == FollowState::kFinished) {
        run.finished = true;
        break;
      }
      EXPECT_EQ(out.state, FollowState::kFollowing) << out.reason;
      const Pose2D next = integrate(pose, out.command, dt);
      if (pose.x > 1.0 && pose.x < 3.5) {
        distance += std::hypot(next.x - pose.x, next.y - pose.y);
        time_near += dt;
      }
      run.closest = std::min(run.closest, clearance(pose));
      pose = next;
    }
    run.speed = time_near > 0.0 ? distance / time_near : 0.0;
    run.end_offset = pose.y;
    return run;
  };
  RouteFollowerOptions options;
  options.controller.goal_tolerance = 0.4;
  const Run passing = drive(options);
  EXPECT_TRUE(passing.finished);
  EXPECT_GT(passing.closest, options.robot_radius);
  EXPECT_GT(passing.speed, 0.6 * options.controller.max_linear_velocity);
  EXPECT_LT(std::abs(passing.end_offset), 0.05);
  RouteFollowerOptions waiting_options = options;
  waiting_options.pass_offset = 0.0;
  const Run waiting = drive(waiting_options);
  EXPECT_FALSE(waiting.finished);
  EXPECT_LT(waiting.speed, 0.3 * options.controller.max_linear_velocity);
  std::printf("passing: %.2f m/s (limit %.2f), closest %.2f m to the body (radius %.2f), end %.3f m off the line; "
              "without passing: %.2f m/s\n",
              passing.speed, options.controller.max_linear_velocity, passing.closest, options.robot_radius,
              passing.end_offset, waiting.speed);
}

// Turning out of a corner, the corridor follows the arc the robot drives: someone standing 0.65 m
// beside the new leg, straight ahead of the robot while it is still turning (the room's guard), does
// not hold it back; someone on the new leg does.
TEST(RouteFollower, TurnsOutOfACornerPastSomeoneBesideTheNextLeg) {
  std::vector<Pose2D> goals;
  for (int k = 0; k <= 4; ++k) goals.emplace_back(0.5 * k, 0.0, 0.0);
  goals.emplace_back(2.0, 0.0, M_PI_4);  // the teach run turned in place here
  for (int k = 0; k <= 6; ++k) goals.emplace_back(2.0, 0.5 * k, M_PI_2);
  struct Box {
    double x0, x1, y0, y1;
  };
  auto pointsOf = [](const Box& box, const Pose2D& robot) {
    std::vector<Eigen::Vector2d> points;
    auto add = [&](double x, double y) {
      const double dx = x - robot.x, dy = y - robot.y;
      points.emplace_back(std::cos(robot.yaw) * dx + std::sin(robot.yaw) * dy,
                          -std::sin(robot.yaw) * dx + std::cos(robot.yaw) * dy);
    };
    for (double x = box.x0; x <= box.x1 + 1e-9; x += 0.02) {
      add(x, box.y0);
      add(x, box.y1);
    }
    for (double y = box.y0; y <= box.y1 + 1e-9; y += 0.02) {
      add(box.x0, y);
      add(box.x1, y);
    }
    return points;
  };
  auto clearance = [](const Box& box, const Pose2D& robot) {
    return std::hypot(std::max({box.x0 - robot.x, 0.0, robot.x - box.x1}), std::max({box.y0 - robot.y, 0.0, robot.y - box.y1}));
  };
  // [s] from the corner (x > 1.9) until 1 m up the next leg; closest [m] to the body, [s] held back
  // for something in the way.
  double off_route = 0.0;  // [m] the farthest from the route's two legs in the last run
  auto drive = [&](const std::optional<Box>& box, double* closest, double* held_back) {
    off_route = 0.0;
    RouteFollowerOptions options;
    options.controller.goal_tolerance = 0.2;
    RouteFollower follower(goals, options);
    Pose2D pose(0.0, 0.0, 0.0);
    const double dt = 0.05;
    double since_corner = -1.0;
    *closest = 1e9;
    *held_back = 0.0;
    for (double t = 0.0; t < 60.0; t += dt) {
      EXPECT_TRUE(follower.setFix(pose, t).isOk());
      const FollowOutput out = follower.update(t, dt, box ? pointsOf(*box, pose) : std::vector<Eigen::Vector2d>{});
      if (out.state == FollowState::kFinished || pose.y > 1.0) break;
      if (since_corner < 0.0 && pose.x > 1.9) since_corner = 0.0;
      if (since_corner >= 0.0) since_corner += dt;
      if (box) *closest = std::min(*closest, clearance(*box, pose));
      if (out.reason.find("in the way") != std::string::npos) *held_back += dt;
      off_route = std::max(off_route, std::min(pose.x < 2.0 ? std::abs(pose.y) : std::hypot(pose.x - 2.0, std::min(pose.y, 0.0)),
                                               pose.y > 0.0 ? std::abs(pose.x - 2.0) : std::hypot(pose.x - 2.0, pose.y)));
      pose = integrate(pose, out.command, dt);
    }
    return pose.y > 1.0 ? since_corner : std::numeric_limits<double>::infinity();
  };
  double closest = 0.0, held_back = 0.0;
  const double free_way = drive(std::nullopt, &closest, &held_back);
  const double free_way_off_route = off_route;
  const double beside = drive(Box{2.5, 2.8, 0.85, 1.35}, &closest, &held_back);  // 0.65 m east of the leg
  const RouteFollowerOptions defaults;
  EXPECT_GT(closest, defaults.robot_radius);
  EXPECT_LT(held_back, 1.5);  // the corridor straight ahead held it back 3.15 s
  EXPECT_LT(beside, free_way + 1.0);  // 0.35 s more; 1.25 s before the turn in place went on to 0.1 rad
  EXPECT_LT(free_way_off_route, 0.15);
  const double beside_held_back = held_back;
  // Someone just clear of the next leg's line (0.39 m), beside the robot's own band as it turns: the
  // nearest free lane is the line itself, and the robot still turns in place onto it first (it once
  // drove the lane's pure pursuit from the corner and looped 0.4 m off the route).
  const double just_clear = drive(Box{2.39, 2.69, 0.85, 1.35}, &closest, &held_back);
  EXPECT_TRUE(std::isfinite(just_clear));
  EXPECT_GT(closest, defaults.robot_radius);
  const double just_clear_off_route = off_route;
  EXPECT_LT(just_clear_off_route, 0.15);
  const double on_the_leg = drive(Box{1.85, 2.15, 1.2, 1.7}, &closest, &held_back);  // on the next leg
  EXPECT_TRUE(std::isinf(on_the_leg));
  EXPECT_GT(closest, defaults.robot_radius);
  std::printf("corner to 1 m up the next leg: %.2f s (%.3f m off the route at most); %.2f s with someone 0.65 m beside it (held back %.2f s); "
              "%.2f s with someone 0.39 m beside it (%.3f m off the route at most)\n",
              free_way, free_way_off_route, beside, beside_held_back, just_clear, just_clear_off_route);
}

// A robot a little off the route's line (0.11 m, as after a corner) with someone standing 0.4 m
// beside the line ahead, on the robot's side: the line is clear of them, the robot's own band is
// not. It drives back onto the line (the line is the nearest free lane) and past, instead of
// waiting for them to leave (the room's visitor held it 4 s).
TEST(RouteFollower, GetsBackOntoTheLinePastSomeoneBesideIt) {
  std::vector<Pose2D> goals;
  for (int k = 0; k <= 8; ++k) goals.emplace_back(0.5 * k, 0.0, 0.0);
  const double x0 = 1.1, x1 = 1.4, y0 = 0.4, y1 = 0.9;  // the body: 0.4 m left of the line
  auto drive = [&](const RouteFollowerOptions& options, double* closest) {
    RouteFollower follower(goals, options);
    Pose2D pose(0.0, 0.11, 0.0);
    const double dt = 0.05;
    *closest = 1e9;
    double t = 0.0;
    for (; t < 30.0 && pose.x < 2.5; t += dt) {
      std::vector<Eigen::Vector2d> points;
      for (double x = x0; x <= x1 + 1e-9; x += 0.02) {
        for (double y = y0; y <= y1 + 1e-9; y += 0.02) {
          if (x > x0 && x < x1 && y > y0 && y < y1) continue;  // its outline
          const double dx = x - pose.x, dy = y - pose.y;
          points.emplace_back(std::cos(pose.yaw) * dx + std::sin(pose.yaw) * dy,
                              -std::sin(pose.yaw) * dx + std::cos(pose.yaw) * dy);
        }
      }
      EXPECT_TRUE(follower.setFix(pose, t).isOk());
      const FollowOutput out = follower.update(t, dt, points);
      *closest = std::min(*closest, std::hypot(std::max({x0 - pose.x, 0.0, pose.x - x1}),
                                               std::max({y0 - pose.y, 0.0, pose.y - y1})));
      pose = integrate(pose, out.command, dt);
    }
    return t;
  };
  RouteFollowerOptions options;
  options.controller.goal_tolerance = 0.4;
  double closest = 0.0;
  const double passing = drive(options, &closest);
  EXPECT_GT(closest, options.robot_radius);
  RouteFollowerOptions waiting_options = options;
  waiting_options.pass_offset = 0.0;
  double closest_waiting = 0.0;
  const double waiting = drive(waiting_options, &closest_waiting);
  EXPECT_LT(passing, waiting - 1.0);  // 5.5 s against 6.8 s
  std::printf("2.5 m past someone 0.4 m beside the line: %.2f s (closest %.2f m); without lanes %.2f s\n", passing,
              closest, waiting);
}

// The obstacle parameters are checked: a slow gap not beyond the stop gap, a negative radius.
TEST(RouteFollower, RefusesObstacleGapsOutOfOrder) {
  RouteFollowerOptions options;
  options.obstacle_slow_gap = 0.2;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options = RouteFollowerOptions();
  options.robot_radius = -0.1;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options = RouteFollowerOptions();
  options.robot_radius = 0.0;  // off
  EXPECT_NO_THROW(options.validate());
  // Passing beside: a negative or NaN offset or clearance, a lookahead that is not positive.
  for (const double bad : {-0.1, std::nan("")}) {
    options = RouteFollowerOptions();
    options.pass_offset = bad;
    EXPECT_THROW(options.validate(), std::invalid_argument);
    options = RouteFollowerOptions();
    options.pass_clearance = bad;
    EXPECT_THROW(options.validate(), std::invalid_argument);
  }
  options = RouteFollowerOptions();
  options.pass_lookahead = 0.0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options = RouteFollowerOptions();
  options.pass_offset = 0.0;  // never passes
  EXPECT_NO_THROW(options.validate());
}
