#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/control/potential_field_controller.h"

using namespace homography_teach_repeat;

namespace {

// Unicycle kinematics of a differential base.
Pose2D integrate(const Pose2D& pose, const VelocityCommand& c, double dt) {
  return Pose2D(pose.x + c.linear * std::cos(pose.yaw) * dt,
                pose.y + c.linear * std::sin(pose.yaw) * dt, wrapToPi(pose.yaw + c.angular * dt));
}

}  // namespace

// Eq. (3) at rest under a constant force: v → F cosψ / 2b, w → F h sinψ / 2b (limits off).
TEST(PotentialFieldController, SteadyStateOfEquation3) {
  PotentialFieldParameters p;
  p.max_linear_velocity = p.max_angular_velocity = 100.0;
  p.max_linear_acceleration = p.max_angular_acceleration = 1000.0;
  p.attraction_saturation = 10.0;
  PotentialFieldController controller(p);
  const double distance = 0.8, bearing = 0.3;
  VelocityCommand c;
  for (int k = 0; k < 2000; ++k) c = *controller.step(distance, bearing, {}, 0.01);
  const double force = p.attractive_gain * distance;
  EXPECT_NEAR(c.linear, force * std::cos(bearing) / (2.0 * p.viscous_friction), 1e-9);
  EXPECT_NEAR(c.angular, force * p.lever * std::sin(bearing) / (2.0 * p.viscous_friction), 1e-9);
}

// The exact integration does not depend on the step size.
TEST(PotentialFieldController, IntegrationIsExactForConstantForce) {
  PotentialFieldParameters p;
  p.max_linear_acceleration = p.max_angular_acceleration = 1000.0;
  PotentialFieldController coarse(p), fine(p);
  const auto a = *coarse.step(0.5, -0.4, {}, 0.2);
  VelocityCommand b;
  for (int k = 0; k < 20; ++k) b = *fine.step(0.5, -0.4, {}, 0.01);
  EXPECT_NEAR(a.linear, b.linear, 1e-12);
  EXPECT_NEAR(a.angular, b.angular, 1e-12);
}

// A goal 3 m away and 90° to the left is reached (ε = 0.7 m) with the limits respected.
TEST(PotentialFieldController, ReachesAGoalWithinLimits) {
  PotentialFieldParameters p;
  PotentialFieldController controller(p);
  Pose2D robot(0.0, 0.0, 0.0);
  const Pose2D goal(0.0, 3.0, M_PI / 2);
  VelocityCommand previous;
  bool reached = false;
  const double dt = 0.05;
  for (int k = 0; k < 2000 && !reached; ++k) {
    const auto c = controller.step(std::hypot(goal.x - robot.x, goal.y - robot.y),
                                   goalBearing(robot, goal), {}, dt);
    ASSERT_TRUE(c.isOk());
    EXPECT_LE(std::abs(c->linear), p.max_linear_velocity + 1e-12);
    EXPECT_LE(std::abs(c->angular), p.max_angular_velocity + 1e-12);
    EXPECT_LE(std::abs(c->linear - previous.linear), p.max_linear_acceleration * dt + 1e-12);
    EXPECT_LE(std::abs(c->angular - previous.angular), p.max_angular_acceleration * dt + 1e-12);
    EXPECT_GE(c->linear, 0.0);
    previous = *c;
    robot = integrate(robot, *c, dt);
    reached = goalReached(robot, goal, p);
  }
  EXPECT_TRUE(reached) << robot.x << " " << robot.y << " " << robot.yaw;
}

// The visual heading offset rotates the force: a robot that believes it faces the goal but is
// really turned 0.3 rad to the left steers right.
TEST(PotentialFieldController, HeadingOffsetCorrectsTheForceDirection) {
  const Pose2D robot(0.0, 0.0, 0.0), goal(2.0, 0.0, 0.0);
  EXPECT_NEAR(goalBearing(robot, goal), 0.0, 1e-12);
  EXPECT_NEAR(goalBearing(robot, goal, 0.3), -0.3, 1e-12);
  PotentialFieldController controller{PotentialFieldParameters()};
  const auto c = controller.step(2.0, goalBearing(robot, goal, 0.3), {}, 0.1);
  ASSERT_TRUE(c.isOk());
  EXPECT_LT(c->angular, 0.0);
}

TEST(PotentialFieldController, ObstaclesPushAway) {
  PotentialFieldController free_path{PotentialFieldParameters()};
  PotentialFieldController blocked{PotentialFieldParameters()};
  // An obstacle ahead-left: the robot turns right of where it would go.
  const auto a = *free_path.step(2.0, 0.0, {}, 0.1);
  const auto b = *blocked.step(2.0, 0.0, {Eigen::Vector2d(0.4, 0.2)}, 0.1);
  EXPECT_NEAR(a.angular, 0.0, 1e-12);
  EXPECT_LT(b.angular, 0.0);
  EXPECT_LT(b.linear, a.linear);
}

// The repulsion is the nearest point's: a wall beside the path pushes as hard seen by a scanner of
// 10 beams as of 1000 (summed over the beams, a person beside the path held the robot still).
TEST(PotentialFieldController, RepulsionDoesNotGrowWithTheScanResolution) {
  auto wall = [](int beams) {
    std::vector<Eigen::Vector2d> points;
    for (int i = 0; i < beams; ++i) points.emplace_back(-1.0 + 2.0 * i / (beams - 1), 0.45);  // y = 0.45, |x| <= 1
    points.emplace_back(0.0, 0.45);
    return points;
  };
  PotentialFieldController coarse{PotentialFieldParameters()}, fine{PotentialFieldParameters()};
  for (int k = 0; k < 20; ++k) {
    const auto a = coarse.step(2.0, 0.0, wall(10), 0.05);
    const auto b = fine.step(2.0, 0.0, wall(1000), 0.05);
    ASSERT_TRUE(a.isOk() && b.isOk());
    EXPECT_NEAR(a->linear, b->linear, 1e-12);
    EXPECT_NEAR(a->angular, b->angular, 1e-12);
  }
  EXPECT_GT(fine.state().linear, 0.2);  // it drives on past the wall, turning away from it
  EXPECT_LT(fine.state().angular, 0.0);
}

TEST(PotentialFieldController, GoalTest) {
  PotentialFieldParameters p;
  EXPECT_TRUE(goalReached(Pose2D(0.5, 0.3, 0.1), Pose2D(0.0, 0.0, 0.0), p));
  EXPECT_FALSE(goalReached(Pose2D(0.5, 0.6, 0.1), Pose2D(0.0, 0.0, 0.0), p));   // 0.78 m
  EXPECT_FALSE(goalReached(Pose2D(0.1, 0.0, 0.5), Pose2D(0.0, 0.0, 0.0), p));   // 29°
  EXPECT_TRUE(goalReached(Pose2D(0.0, 0.0, M_PI - 0.1), Pose2D(0.0, 0.0, -M_PI + 0.1), p));
}

// Any non-finite input: an explicit status and the state back to rest.
TEST(PotentialFieldController, BadInputStopsTheRobot) {
  PotentialFieldController controller{PotentialFieldParameters()};
  for (int k = 0; k < 10; ++k) ASSERT_TRUE(controller.step(2.0, 0.2, {}, 0.1).isOk());
  EXPECT_GT(controller.state().linear, 0.0);
  EXPECT_EQ(controller.step(std::nan(""), 0.2, {}, 0.1).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(controller.state().linear, 0.0);
  EXPECT_EQ(controller.state().angular, 0.0);
  EXPECT_EQ(controller.step(2.0, 0.2, {Eigen::Vector2d(std::nan(""), 1.0)}, 0.1).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(controller.step(2.0, 0.2, {}, 0.0).status().code(), StatusCode::kInvalidInput);
  PotentialFieldParameters bad;
  bad.viscous_friction = 0.0;
  EXPECT_THROW(PotentialFieldController{bad}, std::invalid_argument);
  bad = PotentialFieldParameters();
  bad.goal_heading_tolerance = 4.0;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}
