// repeat_node on a single-route folder given as map_directory (test/launch/map_repeat_single_route.test):
// the folder of route format 2 is read as a map of one route named "route" (docs/map_format.md,
// "Single-route folders"), nothing is written into it, and ~plan_way answers with the outcome and
// the reason: a destination not in the map, and one in it while the place is not known yet.
#include <gtest/gtest.h>

#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <visualization_msgs/MarkerArray.h>

#include <filesystem>
#include <string>

#include "homography_teach_repeat/PlanWay.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

namespace {

PlanWay::Response plan(const std::string& destination) {
  PlanWay way;
  way.request.destination = destination;
  EXPECT_TRUE(ros::service::call("repeat_node/plan_way", way)) << destination;
  return way.response;
}

}  // namespace

TEST(MapRepeatSingleRoute, AVersion2RouteFolderIsAMapOfOneRoute) {
  ros::NodeHandle nh, private_nh("~");
  const std::string directory = private_nh.param<std::string>("map_directory", "");
  const auto route = loadRoute(directory);
  ASSERT_TRUE(route) << route.status().message();
  EXPECT_EQ(route->loaded_format_version, kRouteFormatVersion);
  ASSERT_TRUE(ros::service::waitForService("repeat_node/plan_way", ros::Duration(60.0)));

  const auto unknown_route = plan("corridor");
  EXPECT_FALSE(unknown_route.success);
  EXPECT_EQ(unknown_route.outcome, PlanWay::Response::NOT_IN_MAP);
  EXPECT_NE(unknown_route.reason.find("its routes: route"), std::string::npos) << unknown_route.reason;
  const auto unknown_keyframe = plan("route:9999");
  EXPECT_EQ(unknown_keyframe.outcome, PlanWay::Response::NOT_IN_MAP);
  EXPECT_NE(unknown_keyframe.reason.find("route:9999 is not in the map"), std::string::npos) << unknown_keyframe.reason;
  const auto malformed = plan("route:x");
  EXPECT_EQ(malformed.outcome, PlanWay::Response::NOT_IN_MAP);
  EXPECT_NE(malformed.reason.find("not a number"), std::string::npos) << malformed.reason;
  // No image came: the place is not known.
  const auto early = plan("route");
  EXPECT_FALSE(early.success);
  EXPECT_EQ(early.outcome, PlanWay::Response::NOT_PLACED);
  EXPECT_NE(early.reason.find("not known yet"), std::string::npos) << early.reason;
  EXPECT_TRUE(early.path.poses.empty());

  // The map for rviz: the one route, named.
  bool named = false;
  ros::Subscriber markers = nh.subscribe<visualization_msgs::MarkerArray>(
      "repeat_node/map_markers", 1, [&](const auto& m) {
        for (const auto& marker : m->markers) named = named || (marker.ns == "route_names" && marker.text == "route");
      });
  EXPECT_TRUE(test_support::spinUntil([&] { return named; }, 20.0));

  std_srvs::Trigger relocalize;
  ASSERT_TRUE(ros::service::call("repeat_node/relocalize", relocalize));
  EXPECT_TRUE(relocalize.response.success) << relocalize.response.message;
  // Read, never written: the folder is still a single route.
  EXPECT_FALSE(std::filesystem::exists(std::filesystem::path(directory) / "map.yaml"));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_map_repeat_single_route");
  return RUN_ALL_TESTS();
}
