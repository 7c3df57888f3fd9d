// Teaching into a map in the simulator (test/launch/map_teach_sim.test): teach_node with
// map_directory records "north", which starts on the map's route "trunk", leaves it and rejoins it;
// judged by the map on disk after ~finish and the simulator's truth (both routes' odometry frames
// are the world frame: perfect odometry started at the world poses they were taught from).
#include <gtest/gtest.h>

#include <ros/ros.h>

#include <cmath>
#include <iostream>
#include <string>

#include "homography_teach_repeat/TeachStatus.h"
#include "homography_teach_repeat/network/route_map.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

TEST(MapTeachSim, ABranchThatLeavesAndRejoinsTheRouteGetsBothJunctions) {
  ros::NodeHandle nh, private_nh("~");
  const std::string directory = private_nh.param<std::string>("map_directory", "");
  const double timeout = private_nh.param("timeout", 300.0);
  std::string state, message, place;
  unsigned contacts = 0;
  bool seen_on_map = false;
  ros::Subscriber status_sub = nh.subscribe<TeachStatus>("teach_node/status", 10, [&](const auto& m) {
    state = m->state;
    message = m->message;
    place = m->map_place;
    contacts = m->map_contacts;
    if (!place.empty()) seen_on_map = true;
  });
  ASSERT_TRUE(test_support::spinUntil([&] { return state == "finished"; }, timeout))
      << "teach_node state '" << state << "': " << message;
  std::cout << "teach_node: " << message << "\n";
  EXPECT_TRUE(seen_on_map) << "~status never named a map place";
  EXPECT_GE(contacts, 1U);

  const auto map = loadRouteMap(directory);
  ASSERT_TRUE(map) << map.status().message();
  ASSERT_NE(map->find("north"), nullptr) << message;
  const int branch_keyframes = static_cast<int>(map->find("north")->route.keyframes.size());
  bool leaves = false, rejoins = false;
  EXPECT_TRUE(listRouteMapOrphans(*map).empty());
  int junctions = 0;
  for (const Junction& j : map->junctions) {
    const bool from_trunk = j.from.route == "trunk" && j.to.route == "north";
    const bool from_branch = j.from.route == "north" && j.to.route == "trunk";
    if (!from_trunk && !from_branch) continue;
    ++junctions;
    const int branch_keyframe = from_trunk ? j.to.keyframe : j.from.keyframe;
    leaves = leaves || branch_keyframe < branch_keyframes / 3;
    rejoins = rejoins || branch_keyframe >= 2 * branch_keyframes / 3;
    const auto poseOf = [&](const KeyframeRef& ref) { return *map->keyframePose(ref); };
    const Pose2D truth = poseOf(j.from).inverse().compose(poseOf(j.to));
    const double position_error = std::hypot(j.to_in_from.x - truth.x, j.to_in_from.y - truth.y);
    const double heading_error = std::abs(wrapToPi(j.to_in_from.yaw - truth.yaw));
    std::cout << "junction " << toString(j.from) << " -> " << toString(j.to) << ": " << position_error << " m, "
              << heading_error * 180.0 / M_PI << " deg from the truth, " << j.inliers << " inliers\n";
    RecordProperty("junction_" + std::to_string(junctions) + "_error_m", std::to_string(position_error));
    EXPECT_LT(position_error, 0.05) << toString(j.from) << " -> " << toString(j.to);
    EXPECT_LT(heading_error, M_PI / 180.0) << toString(j.from) << " -> " << toString(j.to);
  }
  EXPECT_GE(junctions, 2) << message;
  EXPECT_TRUE(leaves) << "no junction in the first third of the branch: " << message;
  EXPECT_TRUE(rejoins) << "no junction in the last third of the branch: " << message;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_map_teach_sim");
  return RUN_ALL_TESTS();
}
