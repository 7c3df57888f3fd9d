#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "homography_teach_repeat/network/route_map_command.h"
#include "network/network_fixtures.h"

using namespace homography_teach_repeat;
using namespace homography_teach_repeat::network_test;

namespace {

struct Result {
  int status = 0;
  std::string out;
  std::string err;
};

Result run(const std::vector<std::string>& args) {
  std::ostringstream out;
  std::ostringstream err;
  const int status = runRouteMapCommand(args, out, err);
  return {status, out.str(), err.str()};
}

// A single-route folder (the trunk, 6 keyframes) with a branch added after migration.
std::string makeMap() {
  const std::string dir = temporaryDirectory();
  writeTinyRoute(dir, straight(Pose2D(), 6));
  EXPECT_EQ(run({"migrate", dir, "trunk"}).status, 0);
  writeTinyRoute(dir + "/routes/room", straight(Pose2D(1.0, 0.0, 1.5), 3));
  auto map = loadRouteMap(dir);
  EXPECT_TRUE(map.isOk());
  EXPECT_TRUE(commitMapRoute(*map, "room", "routes/room").isOk());
  EXPECT_TRUE(addJunction(*map, junctionFromPoses({"trunk", 2}, Pose2D(1.0, 0.0, 0.0), {"room", 0},
                                                  Pose2D(1.0, 0.0, 1.5)))
                  .isOk());
  return dir;
}

}  // namespace

TEST(RouteMapCommand, ListsRoutesAndJunctions) {
  const std::string dir = makeMap();
  const Result text = run({"list", dir});
  EXPECT_EQ(text.status, 0) << text.err;
  EXPECT_NE(text.out.find("route trunk: 6 keyframes, 2.50 m (.)"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("junction trunk:2 -> room:0: 0.00 m, 85.94 deg, 100 inliers"), std::string::npos) << text.out;
  const Result json = run({"list", dir, "--json"});
  ASSERT_EQ(json.status, 0);
  const auto doc = nlohmann::json::parse(json.out);
  EXPECT_EQ(doc["routes"].size(), 2u);
  EXPECT_EQ(doc["routes"][1]["name"], "room");
  EXPECT_EQ(doc["junctions"][0]["inliers"], 100);
  EXPECT_TRUE(doc["orphan_folders"].empty());
}

TEST(RouteMapCommand, PlansAndSaysWhyNot) {
  const std::string dir = makeMap();
  const Result plan = run({"plan", dir, "trunk:0", "room:2", "--json"});
  ASSERT_EQ(plan.status, 0) << plan.err;
  const auto doc = nlohmann::json::parse(plan.out);
  EXPECT_EQ(doc["junctions_crossed"], 1);
  EXPECT_EQ(doc["keyframes"].size(), 6u);
  EXPECT_NEAR(doc["length_m"].get<double>(), 2.0, 1e-9);
  const Result text = run({"plan", dir, "trunk:0", "room:2"});
  EXPECT_NE(text.out.find("junction to room:0"), std::string::npos) << text.out;
  const Result unreachable = run({"plan", dir, "room:2", "trunk:0"});
  EXPECT_EQ(unreachable.status, 3);
  EXPECT_NE(unreachable.err.find("not reachable"), std::string::npos);
  const Result unknown = run({"plan", dir, "trunk:0", "kitchen:1"});
  EXPECT_EQ(unknown.status, 2);
  EXPECT_NE(unknown.err.find("kitchen:1"), std::string::npos);
  EXPECT_EQ(run({"plan", dir, "trunk:x", "room:1"}).status, 2);
  EXPECT_EQ(run({"plan", dir, "trunk", "room:1"}).status, 2);
}

TEST(RouteMapCommand, RenamesAndRemoves) {
  const std::string dir = makeMap();
  EXPECT_EQ(run({"rename", dir, "room", "kitchen"}).status, 0);
  EXPECT_NE(loadRouteMap(dir)->find("kitchen"), nullptr);
  EXPECT_EQ(run({"rename", dir, "room", "x"}).status, 2);
  const Result removed = run({"remove-junctions", dir, "kitchen"});
  EXPECT_EQ(removed.status, 0);
  EXPECT_EQ(removed.out, "removed 1 junction\n");
  EXPECT_EQ(run({"remove", dir, "kitchen"}).status, 0);
  EXPECT_EQ(loadRouteMap(dir)->routes.size(), 1u);
  EXPECT_EQ(run({"remove", dir, "trunk"}).status, 2);
}

TEST(RouteMapCommand, BadUsageAndBadMapsExitTwoWithTheReason) {
  EXPECT_EQ(run({}).status, 2);
  EXPECT_EQ(run({"--help"}).status, 0);
  EXPECT_EQ(run({"fly", "/tmp"}).err.substr(0, 35), "route_map: unknown command 'fly'\nus");
  EXPECT_EQ(run({"rename", "/tmp"}).status, 2);
  const std::string empty = temporaryDirectory();
  const Result nothing = run({"list", empty});
  EXPECT_EQ(nothing.status, 2);
  EXPECT_NE(nothing.err.find("neither map.yaml nor route.yaml"), std::string::npos);
}

TEST(RouteMapCommand, AddCopiesARouteIntoANewOrExistingMap) {
  const std::string taught = temporaryDirectory() + "/corridor";
  writeTinyRoute(taught, straight(Pose2D(), 4));
  const std::string dir = temporaryDirectory() + "/building";  // does not exist yet
  Result added = run({"add", dir, "corridor", taught});
  ASSERT_EQ(added.status, 0) << added.err;
  EXPECT_NE(added.out.find("added corridor (4 keyframes) as routes/corridor"), std::string::npos) << added.out;
  added = run({"add", dir, "lab", taught});
  ASSERT_EQ(added.status, 0) << added.err;
  auto map = loadRouteMap(dir);
  ASSERT_TRUE(map.isOk()) << map.status().toString();
  ASSERT_EQ(map->routes.size(), 2u);
  EXPECT_EQ(map->find("lab")->directory, "routes/lab");
  EXPECT_EQ(map->find("lab")->route.keyframes.size(), 4u);
  // Again under a taken name: replaced (re-taught), in a new folder; the old one is gone.
  added = run({"add", dir, "lab", taught});
  ASSERT_EQ(added.status, 0) << added.err;
  EXPECT_NE(added.out.find("replaced lab"), std::string::npos) << added.out;
  map = loadRouteMap(dir);
  EXPECT_EQ(map->find("lab")->directory, "routes/lab.2");
  EXPECT_FALSE(std::filesystem::exists(dir + "/routes/lab"));
  // A bad name, a missing route, a route of another feature type: refused, the map unchanged.
  EXPECT_EQ(run({"add", dir, "no good", taught}).status, 2);
  EXPECT_EQ(run({"add", dir, "x", "/nonexistent/route"}).status, 2);
  const std::string other = temporaryDirectory() + "/akaze";
  writeTinyRoute(other, straight(Pose2D(), 3), FeatureType::kAkaze);
  const Result refused = run({"add", dir, "akaze", other});
  EXPECT_EQ(refused.status, 2);
  EXPECT_EQ(loadRouteMap(dir)->routes.size(), 2u);
  EXPECT_TRUE(listRouteMapOrphans(*loadRouteMap(dir)).empty());
}
