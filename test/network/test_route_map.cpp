#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "homography_teach_repeat/network/route_map.h"
#include "network/network_fixtures.h"

using namespace homography_teach_repeat;
using namespace homography_teach_repeat::network_test;
namespace fs = std::filesystem;

namespace {

// A map with a trunk of 6 keyframes and a branch of 4 leaving at trunk:2.
RouteMap makeTwoRouteMap(const std::string& dir) {
  RouteMap map;
  map.directory = dir;
  writeTinyRoute(dir + "/routes/trunk", straight(Pose2D(), 6));
  writeTinyRoute(dir + "/routes/branch", straight(Pose2D(1.0, 0.0, 1.5), 4));
  EXPECT_TRUE(commitMapRoute(map, "trunk", "routes/trunk").isOk());
  EXPECT_TRUE(commitMapRoute(map, "branch", "routes/branch").isOk());
  EXPECT_TRUE(addJunction(map, junctionFromPoses({"trunk", 2}, Pose2D(1.0, 0.0, 0.0), {"branch", 0},
                                                 Pose2D(1.0, 0.0, 1.5)))
                  .isOk());
  return map;
}

void writeText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

std::string readText(const std::string& path) {
  std::ifstream in(path);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST(RouteMap, RoundTrip) {
  const std::string dir = temporaryDirectory();
  const RouteMap written = makeTwoRouteMap(dir);
  auto loaded = loadRouteMap(dir);
  ASSERT_TRUE(loaded.isOk()) << loaded.status().toString();
  EXPECT_EQ(loaded->loaded_format_version, kRouteMapFormatVersion);
  ASSERT_EQ(loaded->routes.size(), 2u);
  EXPECT_EQ(loaded->routes[0].name, "trunk");
  EXPECT_EQ(loaded->routes[1].directory, "routes/branch");
  EXPECT_EQ(loaded->routes[1].route.keyframes.size(), 4u);
  ASSERT_EQ(loaded->junctions.size(), 1u);
  const Junction& j = loaded->junctions[0];
  EXPECT_EQ(j.from, (KeyframeRef{"trunk", 2}));
  EXPECT_EQ(j.to, (KeyframeRef{"branch", 0}));
  EXPECT_DOUBLE_EQ(j.to_in_from.yaw, written.junctions[0].to_in_from.yaw);
  EXPECT_DOUBLE_EQ(j.covariance(2, 2), 1e-5);
  EXPECT_EQ(j.inliers, 100);
  EXPECT_EQ(loaded->keyframePosition({"branch", 3}), 3);
  EXPECT_EQ(loaded->keyframePosition({"branch", 4}), -1);
  EXPECT_EQ(loaded->keyframePosition({"nowhere", 0}), -1);
  EXPECT_TRUE(listRouteMapOrphans(*loaded).empty());
}

TEST(RouteMap, SingleRouteFolderLoadsAsAMapAndMigrates) {
  const std::string dir = temporaryDirectory();
  writeTinyRoute(dir, straight(Pose2D(), 3));
  auto before = loadRouteMap(dir);
  ASSERT_TRUE(before.isOk()) << before.status().toString();
  EXPECT_EQ(before->loaded_format_version, kRouteFormatVersion);
  ASSERT_EQ(before->routes.size(), 1u);
  EXPECT_EQ(before->routes[0].name, "route");
  EXPECT_EQ(before->routes[0].directory, ".");
  EXPECT_FALSE(fs::exists(dir + "/map.yaml"));

  ASSERT_TRUE(migrateToRouteMap(dir, "corridor").isOk());
  auto after = loadRouteMap(dir);
  ASSERT_TRUE(after.isOk()) << after.status().toString();
  EXPECT_EQ(after->loaded_format_version, kRouteMapFormatVersion);
  EXPECT_EQ(after->routes[0].name, "corridor");
  EXPECT_EQ(after->routes[0].route.keyframes.size(), 3u);
  // The single-route workflow still reads the folder as a route, and a second migration is a no-op.
  EXPECT_TRUE(loadRoute(dir).isOk());
  const std::string index = readText(dir + "/map.yaml");
  EXPECT_TRUE(migrateToRouteMap(dir, "other").isOk());
  EXPECT_EQ(readText(dir + "/map.yaml"), index);
  // A branch can be added to the migrated map; removing the migrated route keeps its files.
  writeTinyRoute(dir + "/routes/branch", straight(Pose2D(0.5, 0.0, 1.0), 2));
  ASSERT_TRUE(commitMapRoute(*after, "branch", "routes/branch").isOk());
  ASSERT_TRUE(removeMapRoute(*after, "corridor").isOk());
  EXPECT_TRUE(fs::exists(dir + "/route.yaml"));
  EXPECT_EQ(loadRouteMap(dir)->routes.size(), 1u);
}

TEST(RouteMap, CorruptIndexIsRefusedNamingTheFileAndTheProblem) {
  const std::string dir = temporaryDirectory();
  makeTwoRouteMap(dir);
  const std::string index = dir + "/map.yaml";
  const std::string good = readText(index);
  auto expectRefused = [&](const std::string& text, const std::string& problem) {
    writeText(index, text);
    const auto loaded = loadRouteMap(dir);
    ASSERT_FALSE(loaded.isOk()) << "accepted: " << text;
    EXPECT_EQ(loaded.status().code(), StatusCode::kInvalidInput);
    EXPECT_NE(loaded.status().message().find("map.yaml"), std::string::npos) << loaded.status().message();
    EXPECT_NE(loaded.status().message().find(problem), std::string::npos) << loaded.status().message();
  };
  expectRefused(good.substr(0, good.size() / 3), "");
  expectRefused("", "not a YAML map");
  expectRefused("format_version: 7\nroutes: []\n", "unknown format_version 7");
  expectRefused("format_version: 3\nroutes: []\n", "lists no route");
  expectRefused("format_version: 3\nroutes:\n  - {name: a, directory: ../elsewhere}\n", "outside the map");
  expectRefused("format_version: 3\nroutes:\n  - {name: a, directory: /abs}\n", "outside the map");
  expectRefused("format_version: 3\nroutes:\n  - {name: 'a b', directory: routes/trunk}\n", "route name 'a b'");
  expectRefused("format_version: 3\nroutes:\n  - {name: a, directory: routes/missing}\n", "route 'a'");
  expectRefused(
      "format_version: 3\nroutes:\n  - {name: a, directory: routes/trunk}\n  - {name: a, directory: routes/branch}\n",
      "listed twice");
  const std::string routes =
      "format_version: 3\nroutes:\n  - {name: trunk, directory: routes/trunk}\n"
      "  - {name: branch, directory: routes/branch}\njunctions:\n";
  expectRefused(routes + "  - {from: {route: trunk, keyframe: 2}, to: {route: room, keyframe: 0}, pose: {x: 0, "
                         "y: 0, yaw: 0}, covariance: [0,0,0,0,0,0,0,0,0], inliers: 3}\n",
                "no route 'room'");
  expectRefused(routes + "  - {from: {route: trunk, keyframe: 9}, to: {route: branch, keyframe: 0}, pose: {x: 0, "
                         "y: 0, yaw: 0}, covariance: [0,0,0,0,0,0,0,0,0], inliers: 3}\n",
                "no keyframe 9");
  expectRefused(routes + "  - {from: {route: trunk, keyframe: 2}, to: {route: branch, keyframe: 0}, pose: {x: .nan, "
                         "y: 0, yaw: 0}, covariance: [0,0,0,0,0,0,0,0,0], inliers: 3}\n",
                "not finite");
  expectRefused(routes + "  - {from: {route: trunk, keyframe: 2}, to: {route: branch, keyframe: 0}, pose: {x: 0, "
                         "y: 0, yaw: 0}, covariance: [0,0,0], inliers: 3}\n",
                "9 numbers");
  expectRefused(routes + "  - {from: {route: trunk, keyframe: 2}, to: {route: trunk, keyframe: 2}, pose: {x: 0, "
                         "y: 0, yaw: 0}, covariance: [0,0,0,0,0,0,0,0,0], inliers: 3}\n",
                "to itself");
  writeText(index, good);
  EXPECT_TRUE(loadRouteMap(dir).isOk());
  // A route's own corrupt index is named through the map.
  writeText(dir + "/routes/branch/route.yaml", "format_version: 2\nfeature_type: orb\n");
  const auto broken = loadRouteMap(dir);
  ASSERT_FALSE(broken.isOk());
  EXPECT_NE(broken.status().message().find("routes/branch/route.yaml"), std::string::npos)
      << broken.status().message();
}

TEST(RouteMap, NeitherMapNorRouteIsAClearError) {
  const std::string dir = temporaryDirectory();
  const auto loaded = loadRouteMap(dir);
  ASSERT_FALSE(loaded.isOk());
  EXPECT_NE(loaded.status().message().find("neither map.yaml nor route.yaml"), std::string::npos);
  EXPECT_FALSE(loadRouteMap(dir + "/missing").isOk());
  EXPECT_FALSE(migrateToRouteMap(dir).isOk());
}

TEST(RouteMap, RoutesOfAnotherCameraOrFeatureTypeAreRefused) {
  const std::string dir = temporaryDirectory();
  RouteMap map = makeTwoRouteMap(dir);
  writeTinyRoute(dir + "/routes/sift", straight(Pose2D(), 2), FeatureType::kSift);
  const Status refused = commitMapRoute(map, "sift", "routes/sift");
  EXPECT_EQ(refused.code(), StatusCode::kInvalidInput);
  EXPECT_NE(refused.message().find("feature type"), std::string::npos) << refused.message();
  EXPECT_EQ(map.routes.size(), 2u);
  EXPECT_EQ(loadRouteMap(dir)->routes.size(), 2u);
  EXPECT_EQ(listRouteMapOrphans(map), std::vector<std::string>{"routes/sift"});
}

TEST(RouteMap, RenameCarriesTheJunctions) {
  const std::string dir = temporaryDirectory();
  RouteMap map = makeTwoRouteMap(dir);
  ASSERT_TRUE(renameMapRoute(map, "branch", "room_a").isOk());
  auto loaded = loadRouteMap(dir);
  ASSERT_TRUE(loaded.isOk()) << loaded.status().toString();
  EXPECT_NE(loaded->find("room_a"), nullptr);
  EXPECT_EQ(loaded->find("branch"), nullptr);
  EXPECT_EQ(loaded->junctions[0].to.route, "room_a");
  EXPECT_EQ(loaded->routes[1].directory, "routes/branch");  // only the name changes
  EXPECT_FALSE(renameMapRoute(map, "missing", "x").isOk());
  EXPECT_FALSE(renameMapRoute(map, "trunk", "room_a").isOk());
  EXPECT_FALSE(renameMapRoute(map, "trunk", "bad/name").isOk());
  EXPECT_FALSE(renameMapRoute(map, "trunk", "").isOk());
  EXPECT_EQ(loadRouteMap(dir)->routes[0].name, "trunk");
}

TEST(RouteMap, RemoveDeletesTheRouteAndItsJunctions) {
  const std::string dir = temporaryDirectory();
  RouteMap map = makeTwoRouteMap(dir);
  ASSERT_TRUE(removeMapRoute(map, "branch").isOk());
  EXPECT_FALSE(fs::exists(dir + "/routes/branch"));
  auto loaded = loadRouteMap(dir);
  ASSERT_TRUE(loaded.isOk()) << loaded.status().toString();
  EXPECT_EQ(loaded->routes.size(), 1u);
  EXPECT_TRUE(loaded->junctions.empty());
  EXPECT_FALSE(removeMapRoute(map, "branch").isOk());
  EXPECT_FALSE(removeMapRoute(map, "trunk").isOk());  // the only route
}

TEST(RouteMap, JunctionsAreAddedReplacedAndRemoved) {
  const std::string dir = temporaryDirectory();
  RouteMap map = makeTwoRouteMap(dir);
  Junction reverse = map.junctions[0];
  std::swap(reverse.from, reverse.to);
  reverse.to_in_from = reverse.to_in_from.inverse();
  reverse.inliers = 250;
  ASSERT_TRUE(addJunction(map, reverse).isOk());  // the same two keyframes: replaced
  ASSERT_EQ(map.junctions.size(), 1u);
  EXPECT_EQ(map.junctions[0].inliers, 250);
  Junction rejoin = junctionFromPoses({"branch", 3}, Pose2D(1.0, 1.5, 1.5), {"trunk", 5}, Pose2D(2.5, 0.0, 0.0));
  ASSERT_TRUE(addJunction(map, rejoin).isOk());
  Junction bad = rejoin;
  bad.to.keyframe = 6;
  EXPECT_FALSE(addJunction(map, bad).isOk());
  bad = rejoin;
  bad.covariance(0, 0) = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(addJunction(map, bad).isOk());
  EXPECT_EQ(loadRouteMap(dir)->junctions.size(), 2u);
  EXPECT_EQ(removeJunctions(map, {"trunk", 5}).value(), 1);
  EXPECT_EQ(removeJunctions(map, {"trunk", 5}).value(), 0);
  EXPECT_EQ(removeJunctions(map, {"branch", -1}).value(), 1);
  EXPECT_FALSE(removeJunctions(map, {"nowhere", -1}).isOk());
  EXPECT_TRUE(loadRouteMap(dir)->junctions.empty());
}

TEST(RouteMap, ReteachingReplacesTheRouteAndKeepsItsJunctions) {
  const std::string dir = temporaryDirectory();
  RouteMap map = makeTwoRouteMap(dir);
  ASSERT_TRUE(addJunction(map, junctionFromPoses({"branch", 3}, Pose2D(1.0, 1.5, 1.5), {"trunk", 5},
                                                 Pose2D(2.5, 0.0, 0.0)))
                  .isOk());
  const std::string again = newRouteDirectory(map, "branch");
  EXPECT_EQ(again, "routes/branch.2");
  writeTinyRoute(dir + "/" + again, straight(Pose2D(1.0, 0.0, 1.5), 3));  // shorter: keyframe 3 is gone
  std::vector<Junction> dropped;
  ASSERT_TRUE(commitMapRoute(map, "branch", again, &dropped).isOk());
  ASSERT_EQ(dropped.size(), 1u);
  EXPECT_EQ(dropped[0].from, (KeyframeRef{"branch", 3}));
  EXPECT_FALSE(fs::exists(dir + "/routes/branch"));
  auto loaded = loadRouteMap(dir);
  ASSERT_TRUE(loaded.isOk()) << loaded.status().toString();
  EXPECT_EQ(loaded->find("branch")->directory, again);
  EXPECT_EQ(loaded->find("branch")->route.keyframes.size(), 3u);
  ASSERT_EQ(loaded->junctions.size(), 1u);
  EXPECT_EQ(loaded->junctions[0].to, (KeyframeRef{"branch", 0}));
  EXPECT_EQ(newRouteDirectory(*loaded, "branch"), "routes/branch");
}

TEST(RouteMap, ACrashBeforeTheCommitLeavesThePreviousMap) {
  const std::string dir = temporaryDirectory();
  makeTwoRouteMap(dir);
  const std::string index = readText(dir + "/map.yaml");
  // A teach that died while writing its route, and a temporary index that never got renamed.
  auto loaded = loadRouteMap(dir);
  ASSERT_TRUE(loaded.isOk());
  const std::string half = newRouteDirectory(*loaded, "room");
  writeTinyRoute(dir + "/" + half, straight(Pose2D(), 2));
  fs::remove(dir + "/" + half + "/route.yaml");
  writeText(dir + "/map.yaml.tmp.4242", index.substr(0, index.size() / 2));
  auto after = loadRouteMap(dir);
  ASSERT_TRUE(after.isOk()) << after.status().toString();
  EXPECT_EQ(after->routes.size(), 2u);
  EXPECT_EQ(readText(dir + "/map.yaml"), index);
  EXPECT_EQ(listRouteMapOrphans(*after), std::vector<std::string>{"routes/room"});
  // Committing the unfinished folder is refused and changes nothing.
  EXPECT_FALSE(commitMapRoute(*after, "room", half).isOk());
  EXPECT_EQ(readText(dir + "/map.yaml"), index);
}

TEST(RouteMap, RouteNames) {
  EXPECT_TRUE(isValidRouteName("corridor_2-east"));
  EXPECT_FALSE(isValidRouteName(""));
  EXPECT_FALSE(isValidRouteName("a.b"));
  EXPECT_FALSE(isValidRouteName("../x"));
  EXPECT_FALSE(isValidRouteName(std::string(65, 'a')));
  EXPECT_EQ(toString(KeyframeRef{"trunk", 12}), "trunk:12");
}

TEST(RouteMap, KeyframeReferencesParseOrSayWhy) {
  const auto ref = parseKeyframeRef("room-a:12");
  ASSERT_TRUE(ref.isOk()) << ref.status().toString();
  EXPECT_EQ(ref->route, "room-a");
  EXPECT_EQ(ref->keyframe, 12);
  EXPECT_EQ(toString(*ref), "room-a:12");
  for (const std::string bad : {"room", ":3", "room:", "room:x", "room:-1", "room:3.5", ""}) {
    const auto refused = parseKeyframeRef(bad);
    EXPECT_EQ(refused.status().code(), StatusCode::kInvalidInput) << bad;
    EXPECT_NE(refused.status().message().find("'" + bad), std::string::npos) << refused.status().message();
  }
}
