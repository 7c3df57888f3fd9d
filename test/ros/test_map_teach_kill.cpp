// SIGKILL of teach_node during a merge into a map (test/launch/map_teach_kill.test): once the branch
// is driven, ~finish is called on a thread and teach_node is killed the moment map.yaml changes
// (the route committed; the junctions and the place index are written next). Whatever the kill
// interrupted, the map loads, its old route is intact, and the committed branch is whole.
#include <gtest/gtest.h>

#include <ros/ros.h>
#include <std_msgs/Bool.h>
#include <std_srvs/Trigger.h>

#include <csignal>
#include <cstdio>
#include <filesystem>
#include <iostream>
#include <string>
#include <thread>

#include "homography_teach_repeat/TeachStatus.h"
#include "homography_teach_repeat/network/route_map.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

namespace {

// The pid of the launched teach_node (-1: none).
int teachNodePid() {
  FILE* pipe = popen("pgrep -f '__name:=teach_node'", "r");
  if (pipe == nullptr) return -1;
  int pid = -1;
  if (std::fscanf(pipe, "%d", &pid) != 1) pid = -1;
  pclose(pipe);
  return pid;
}

}  // namespace

TEST(MapTeachKill, AMergeKilledAtTheCommitLeavesAMapThatLoads) {
  ros::NodeHandle nh, private_nh("~");
  const std::string directory = private_nh.param<std::string>("map_directory", "");
  const std::filesystem::path index = std::filesystem::path(directory) / "map.yaml";
  ASSERT_TRUE(std::filesystem::exists(index));
  unsigned keyframes = 0;
  bool driven = false;
  ros::Subscriber status_sub =
      nh.subscribe<TeachStatus>("teach_node/status", 10, [&](const auto& m) { keyframes = m->keyframes; });
  ros::Subscriber done_sub =
      nh.subscribe<std_msgs::Bool>("route_driver/done", 1, [&](const auto& m) { driven = m->data; });
  // The branch: east along "room" and north off it (about 7 keyframes; how many depends on where the
  // turn's keyframes fall); the driver reports done at its last waypoint.
  ASSERT_TRUE(test_support::spinUntil([&] { return driven; }, 180.0)) << "the drive did not end";
  ASSERT_GE(keyframes, 5U) << "the branch was not recorded";
  ros::WallDuration(3.0).sleep();
  ros::spinOnce();
  const unsigned taught = keyframes;
  const int pid = teachNodePid();
  ASSERT_GT(pid, 0);
  const auto before = std::filesystem::last_write_time(index);

  std::thread finish([] {
    std_srvs::Trigger trigger;
    ros::service::call("teach_node/finish", trigger);  // fails when the node is killed: expected
  });
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(60.0);
  bool changed = false;
  while (ros::WallTime::now() < deadline) {
    std::error_code error;
    const auto now = std::filesystem::last_write_time(index, error);
    if (!error && now != before) {
      changed = true;
      break;
    }
    ros::WallDuration(0.0005).sleep();
  }
  ASSERT_EQ(::kill(pid, SIGKILL), 0);
  finish.join();
  ASSERT_TRUE(changed) << "map.yaml did not change within 60 s of ~finish";

  const auto map = loadRouteMap(directory);
  ASSERT_TRUE(map) << map.status().message();
  ASSERT_NE(map->find("room"), nullptr);
  EXPECT_EQ(map->find("room")->route.keyframes.size(), 14U);
  ASSERT_NE(map->find("spur"), nullptr);  // the first rewrite is the route's
  EXPECT_EQ(map->find("spur")->route.keyframes.size(), taught);
  std::cout << "killed after the route's commit: the map loads with " << map->routes.size() << " routes and "
            << map->junctions.size() << " junction(s); orphan folders: " << listRouteMapOrphans(*map).size() << "\n";
  RecordProperty("junctions_after_kill", std::to_string(map->junctions.size()));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_map_teach_kill");
  return RUN_ALL_TESTS();
}
