// A map of routes end to end in the simulator (test/launch/map_repeat_sim.test): repeat_node
// relocalizes from no hint and controller_node takes repeat_route goals with destinations. Judged
// by the simulator's ground truth and what the nodes publish:
//  - a destination not in the map is aborted with the reason;
//  - the route's end ("room", its last keyframe) is reached within 0.10 m of the taught keyframe,
//    and no linear command was given before repeat_node confirmed the place (integrity OK);
//  - from there, the route's first keyframe is not reachable (an open route): aborted with the reason.
#include <gtest/gtest.h>

#include <actionlib/client/simple_action_client.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <iostream>
#include <string>

#include "homography_teach_repeat/Integrity.h"
#include "homography_teach_repeat/RepeatRouteAction.h"
#include "homography_teach_repeat/network/route_map.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;
using Client = actionlib::SimpleActionClient<RepeatRouteAction>;

namespace {

// The goal's end state and result within `timeout` [s, wall].
struct Outcome {
  actionlib::SimpleClientGoalState state{actionlib::SimpleClientGoalState::LOST};
  std::string reason;
  bool reached = false;
};
Outcome run(Client& client, const std::string& destination, double timeout) {
  RepeatRouteGoal goal;
  goal.destination = destination;
  client.sendGoal(goal);
  Outcome outcome;
  EXPECT_TRUE(test_support::spinUntil([&] { return client.getState().isDone(); }, timeout))
      << destination << ": still " << client.getState().toString() << " after " << timeout << " s";
  outcome.state = client.getState();
  if (const auto result = client.getResult()) {
    outcome.reason = result->reason;
    outcome.reached = result->reached;
  }
  std::cout << "goal " << destination << ": " << outcome.state.toString() << ": " << outcome.reason << "\n";
  return outcome;
}

}  // namespace

TEST(MapRepeatSim, DestinationsAreReachedOrRefusedWithTheReason) {
  ros::NodeHandle nh, private_nh("~");
  const auto map = loadRouteMap(private_nh.param<std::string>("map_directory", ""));
  ASSERT_TRUE(map) << map.status().message();
  ASSERT_NE(map->find("room"), nullptr);
  const Pose2D end = map->find("room")->route.keyframes.back().pose;
  const double timeout = private_nh.param("timeout", 400.0);

  Pose2D truth;
  bool placed = false;           // an integrity OK was heard
  int linear_before_placed = 0;  // linear commands before that
  int lost_reports = 0;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>("ground_truth", 50, [&](const auto& m) {
    const auto& q = m->pose.pose.orientation;
    truth = Pose2D(m->pose.pose.position.x, m->pose.pose.position.y, 2.0 * std::atan2(q.z, q.w));
  });
  ros::Subscriber integrity_sub = nh.subscribe<Integrity>("repeat_node/integrity", 50, [&](const auto& m) {
    if (m->level == Integrity::OK) placed = true;
    if (!placed && m->level == Integrity::LOST && m->reason.rfind("relocalizing", 0) == 0) ++lost_reports;
  });
  ros::Subscriber command_sub = nh.subscribe<geometry_msgs::Twist>("cmd_vel", 50, [&](const auto& m) {
    if (!placed && std::abs(m->linear.x) > 1e-6) ++linear_before_placed;
  });
  Client client(nh, "repeat_route", false);
  ASSERT_TRUE(test_support::spinUntil([&] { return client.isServerConnected(); }, 60.0));

  const Outcome unknown = run(client, "nowhere:3", 60.0);
  EXPECT_EQ(unknown.state, actionlib::SimpleClientGoalState::ABORTED);
  EXPECT_NE(unknown.reason.find("nowhere:3 is not in the map"), std::string::npos) << unknown.reason;

  const Outcome to_end = run(client, "room", timeout);
  EXPECT_EQ(to_end.state, actionlib::SimpleClientGoalState::SUCCEEDED) << to_end.reason;
  EXPECT_TRUE(to_end.reached);
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  const double end_distance = std::hypot(truth.x - end.x, truth.y - end.y);
  std::cout << "map repeat: ended " << end_distance << " m from the route's last keyframe; " << lost_reports
            << " relocalizing reports before the place was confirmed\n";
  RecordProperty("end_distance_m", std::to_string(end_distance));
  EXPECT_LT(end_distance, 0.10);
  EXPECT_GT(lost_reports, 0);
  EXPECT_EQ(linear_before_placed, 0);

  const Outcome back = run(client, "room:0", 60.0);
  EXPECT_EQ(back.state, actionlib::SimpleClientGoalState::ABORTED);
  EXPECT_NE(back.reason.find("not reachable"), std::string::npos) << back.reason;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_map_repeat_sim");
  return RUN_ALL_TESTS();
}
