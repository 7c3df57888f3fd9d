// Someone in the way (test/launch/people_in_the_way.test): a person stands on the route's first
// leg until 12 s of simulated time. Judged by the simulator's ground truth and its `people`
// markers: the robot never comes closer than its radius (0.3 m) to the person, it waits for them
// (controller_node reports "something in the way"), and it finishes the lap at the start pose.
#include <gtest/gtest.h>

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/String.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <limits>

#include "homography_teach_repeat/eval/path_deviation.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

TEST(PeopleInTheWay, WaitsNeverTouchesAndFinishes) {
  ros::NodeHandle nh, private_nh("~");
  const auto route = loadRoute(private_nh.param<std::string>("route_directory", ""));
  ASSERT_TRUE(route) << route.status().message();
  std::vector<Pose2D> path;
  for (const auto& k : route->keyframes) path.push_back(k.pose);

  struct Body {
    Pose2D pose;
    double depth = 0.0, width = 0.0;
  };
  std::vector<Body> people;  // the latest markers
  Pose2D truth;
  bool have_truth = false;
  double clearance = std::numeric_limits<double>::infinity();
  double max_deviation = 0.0;
  bool told_in_the_way = false;
  std::string state;
  ros::Subscriber people_sub = nh.subscribe<visualization_msgs::MarkerArray>("people", 10, [&](const auto& m) {
    people.clear();
    for (const auto& marker : m->markers) {
      const auto& q = marker.pose.orientation;
      people.push_back({Pose2D(marker.pose.position.x, marker.pose.position.y, 2.0 * std::atan2(q.z, q.w)),
                        marker.scale.x, marker.scale.y});
    }
  });
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>("ground_truth", 50, [&](const auto& m) {
    const auto& q = m->pose.pose.orientation;
    truth = Pose2D(m->pose.pose.position.x, m->pose.pose.position.y, 2.0 * std::atan2(q.z, q.w));
    have_truth = true;
    for (const Body& b : people) {
      clearance = std::min(clearance, distanceToBox(Eigen::Vector2d(truth.x, truth.y), b.pose, b.depth, b.width));
    }
    max_deviation = std::max(max_deviation, deviationFromPath(path, truth).distance);
  });
  ros::Subscriber state_sub = nh.subscribe<std_msgs::String>("controller_node/state", 50, [&](const auto& m) {
    state = m->data;
    told_in_the_way = told_in_the_way || state.find("something in the way") != std::string::npos;
  });
  const double timeout = private_nh.param("timeout", 400.0);
  ASSERT_TRUE(test_support::spinUntil([&] { return state.rfind("finished", 0) == 0; }, timeout))
      << "controller state after " << timeout << " s: '" << state << "'";
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  ASSERT_TRUE(have_truth);
  const Pose2D& start = path.front();
  const double end_distance = std::hypot(truth.x - start.x, truth.y - start.y);
  RecordProperty("min_person_clearance_m", std::to_string(clearance));
  RecordProperty("max_path_deviation_m", std::to_string(max_deviation));
  std::cout << "people in the way: closest " << clearance << " m to a person, end " << end_distance
            << " m from the start pose, max path deviation " << max_deviation << " m\n";
  EXPECT_TRUE(std::isfinite(clearance)) << "no people markers seen";
  EXPECT_GT(clearance, 0.3);  // the robot's radius (robot_radius, config/controller_node.yaml)
  EXPECT_TRUE(told_in_the_way);
  EXPECT_LT(end_distance, 0.10);
  EXPECT_LT(max_deviation, 0.5);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_people_in_the_way");
  return RUN_ALL_TESTS();
}
