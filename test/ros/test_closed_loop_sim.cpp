// The closed loop in the simulator: planar_world_sim with drifting odometry (0.02 rad/m heading
// bias, 2 % scale error), repeat_node localizing against a route taught in the same world
// (make_test_sim_route), controller_node following it for one lap. Judged by the simulator's ground
// truth: the robot ends where it started (return_to_start) with the start heading, never strays
// far from the taught path, and vision was used (poses from repeat_node throughout).
#include <gtest/gtest.h>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/String.h>

#include <cmath>

#include "homography_teach_repeat/eval/path_deviation.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

TEST(ClosedLoopSim, OneLapEndsAtTheStartPose) {
  ros::NodeHandle nh, private_nh("~");
  const std::string directory = private_nh.param<std::string>("route_directory", "");
  const auto route = loadRoute(directory);
  ASSERT_TRUE(route) << route.status().message();
  std::vector<Pose2D> path;
  for (const auto& k : route->keyframes) path.push_back(k.pose);
  ASSERT_TRUE(isClosedLoop(path, 1.0));

  std::vector<Pose2D> truth;
  int poses = 0;
  std::string state;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>("ground_truth", 50, [&](const auto& m) {
    const auto& q = m->pose.pose.orientation;
    truth.emplace_back(m->pose.pose.position.x, m->pose.pose.position.y, 2.0 * std::atan2(q.z, q.w));
  });
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 50, [&](const auto&) { ++poses; });
  ros::Subscriber state_sub =
      nh.subscribe<std_msgs::String>("controller_node/state", 10, [&](const auto& m) { state = m->data; });
  const double timeout = private_nh.param("timeout", 400.0);
  ASSERT_TRUE(test_support::spinUntil([&] { return state.rfind("finished", 0) == 0; }, timeout))
      << "controller state after " << timeout << " s: '" << state << "', " << poses << " poses";
  ros::WallDuration(0.5).sleep();  // the last ground-truth messages after the stop
  ros::spinOnce();
  ASSERT_FALSE(truth.empty());

  const Pose2D& start = path.front();
  const Pose2D& end = truth.back();
  const double end_distance = std::hypot(end.x - start.x, end.y - start.y);
  const double end_heading = std::abs(wrapToPi(end.yaw - start.yaw));
  double max_deviation = 0.0;
  for (const auto& p : truth) max_deviation = std::max(max_deviation, deviationFromPath(path, p).distance);
  RecordProperty("end_distance_m", std::to_string(end_distance));
  RecordProperty("end_heading_deg", std::to_string(end_heading * 180.0 / M_PI));
  RecordProperty("max_path_deviation_m", std::to_string(max_deviation));
  std::cout << "closed loop: end " << end_distance << " m / " << end_heading * 180.0 / M_PI
            << " deg from the start pose, max path deviation " << max_deviation << " m, " << poses
            << " poses\n";
  EXPECT_LT(end_distance, 0.10);
  EXPECT_LT(end_heading, 2.0 * M_PI / 180.0);
  EXPECT_LT(max_deviation, 0.5);
  EXPECT_GT(poses, 50);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_closed_loop_sim");
  return RUN_ALL_TESTS();
}
