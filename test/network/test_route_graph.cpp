#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/network/map_relocalizer.h"
#include "homography_teach_repeat/network/path_route.h"
#include "homography_teach_repeat/network/route_graph.h"
#include "network/network_fixtures.h"

using namespace homography_teach_repeat;
using namespace homography_teach_repeat::network_test;

namespace {

constexpr double kHalfPi = M_PI / 2.0;

// The world: a trunk along x (10 keyframes, 0.5 m apart); room_a leaves at trunk:3 to the left
// (+y), room_b at trunk:7 to the right; hall continues from room_a's end. Each route was taught in
// its own odometry frame: `odometry` is that frame's pose in the world.
struct TWorld {
  std::vector<Pose2D> trunk = straight(Pose2D(), 10);
  std::vector<Pose2D> room_a = straight(Pose2D(1.5, 0.05, kHalfPi), 5);
  std::vector<Pose2D> room_b = straight(Pose2D(3.5, -0.05, -kHalfPi), 4);
  std::vector<Pose2D> hall = straight(Pose2D(1.55, 2.1, kHalfPi + 0.3), 3, 0.6);
  Pose2D room_a_odometry{0.7, -2.0, 0.4};
  Pose2D hall_odometry{-3.0, 1.0, -1.0};

  static std::vector<Pose2D> inFrame(const Pose2D& frame, const std::vector<Pose2D>& world) {
    std::vector<Pose2D> poses;
    for (const Pose2D& p : world) poses.push_back(frame.inverse().compose(p));
    return poses;
  }

  RouteMap map() const {
    RouteMap m;
    m.directory = "/maps/test";
    m.routes.push_back(memoryRoute("trunk", trunk));
    m.routes.push_back(memoryRoute("room_a", inFrame(room_a_odometry, room_a)));
    m.routes.push_back(memoryRoute("room_b", room_b));
    m.routes.push_back(memoryRoute("hall", inFrame(hall_odometry, hall)));
    m.junctions.push_back(junctionFromPoses({"trunk", 3}, trunk[3], {"room_a", 0}, room_a[0]));
    m.junctions.push_back(junctionFromPoses({"trunk", 7}, trunk[7], {"room_b", 0}, room_b[0]));
    // Stored the other way round: a junction is usable both ways.
    m.junctions.push_back(junctionFromPoses({"hall", 0}, hall[0], {"room_a", 4}, room_a[4]));
    return m;
  }
};

std::vector<KeyframeRef> refs(const std::string& route, int first, int last) {
  std::vector<KeyframeRef> out;
  for (int k = first; k <= last; ++k) out.push_back({route, k});
  return out;
}

}  // namespace

TEST(RouteGraph, FollowsTheTrunkAndTurnsIntoABranch) {
  const RouteMap map = TWorld().map();
  const RouteGraph graph(map);
  EXPECT_EQ(graph.vertexCount(), 22u);
  EXPECT_EQ(graph.edgeCount(), 9u + 4u + 3u + 2u + 2u * 3u);
  const auto path = graph.shortestPath({"trunk", 0}, {"room_a", 4});
  ASSERT_TRUE(path.isOk()) << path.status().toString();
  std::vector<KeyframeRef> expected = refs("trunk", 0, 3);
  for (const auto& r : refs("room_a", 0, 4)) expected.push_back(r);
  EXPECT_EQ(path->keyframes, expected);
  EXPECT_EQ(path->junctions_crossed, 1);
  EXPECT_NEAR(path->length_m, 1.5 + 0.05 + 2.0, 1e-9);
  EXPECT_NEAR(path->cost, path->length_m + 0.2 * kHalfPi, 1e-9);
}

TEST(RouteGraph, CrossesTwoJunctions) {
  const RouteGraph graph(TWorld().map());
  const auto path = graph.shortestPath({"trunk", 1}, {"hall", 2});
  ASSERT_TRUE(path.isOk()) << path.status().toString();
  EXPECT_EQ(path->junctions_crossed, 2);
  EXPECT_EQ(path->keyframes.front(), (KeyframeRef{"trunk", 1}));
  EXPECT_EQ(path->keyframes[3], (KeyframeRef{"room_a", 0}));
  EXPECT_EQ(path->keyframes[8], (KeyframeRef{"hall", 0}));
  EXPECT_EQ(path->keyframes.size(), 11u);
}

TEST(RouteGraph, AnOpenRouteIsNotRepeatedBackwards) {
  const RouteGraph graph(TWorld().map());
  const auto back = graph.shortestPath({"trunk", 5}, {"trunk", 2});
  ASSERT_FALSE(back.isOk());
  EXPECT_EQ(back.status().code(), StatusCode::kNoConsensus);
  EXPECT_NE(back.status().message().find("not reachable"), std::string::npos);
  // room_b is a dead end; the junction itself can be crossed either way.
  EXPECT_FALSE(graph.shortestPath({"room_b", 3}, {"trunk", 9}).isOk());
  const auto across = graph.shortestPath({"room_b", 0}, {"trunk", 9});
  ASSERT_TRUE(across.isOk());
  EXPECT_EQ(across->keyframes, (std::vector<KeyframeRef>{{"room_b", 0}, {"trunk", 7}, {"trunk", 8}, {"trunk", 9}}));
}

TEST(RouteGraph, ALoopWrapsAround) {
  RouteMap map;
  map.directory = "/maps/loop";
  std::vector<Pose2D> square;
  for (int side = 0; side < 4; ++side) {
    for (int k = 0; k < 4; ++k) {
      const Pose2D corner = Pose2D().compose(Pose2D(0, 0, side * kHalfPi));
      const Eigen::Vector2d offsets[] = {{0, 0}, {2, 0}, {2, 2}, {0, 2}};
      square.push_back(Pose2D(offsets[side].x(), offsets[side].y(), corner.yaw).compose(Pose2D(0.5 * k, 0, 0)));
    }
  }
  map.routes.push_back(memoryRoute("loop", square));
  const auto path = RouteGraph(map).shortestPath({"loop", 14}, {"loop", 1});
  ASSERT_TRUE(path.isOk()) << path.status().toString();
  EXPECT_EQ(path->keyframes, (std::vector<KeyframeRef>{{"loop", 14}, {"loop", 15}, {"loop", 0}, {"loop", 1}}));
  EXPECT_EQ(path->junctions_crossed, 0);
  // Without the wrap (a larger gap than the route closes) the same goal is not reachable.
  RouteGraphOptions strict;
  strict.closed_route_gap = 0.1;
  EXPECT_FALSE(RouteGraph(map, strict).shortestPath({"loop", 14}, {"loop", 1}).isOk());
}

TEST(RouteGraph, TakesTheShorterOfTwoWays) {
  // A detour leaves the trunk at 2 and rejoins at 8; going straight on is shorter.
  TWorld world;
  RouteMap map = world.map();
  std::vector<Pose2D> detour = {Pose2D(1.0, 0.0, 1.0), Pose2D(1.5, 1.5, 0.0), Pose2D(3.5, 1.5, -1.0),
                                Pose2D(4.0, 0.0, 0.0)};
  map.routes.push_back(memoryRoute("detour", detour));
  map.junctions.push_back(junctionFromPoses({"trunk", 2}, world.trunk[2], {"detour", 0}, detour[0]));
  map.junctions.push_back(junctionFromPoses({"detour", 3}, detour[3], {"trunk", 8}, world.trunk[8]));
  const RouteGraph graph(map);
  const auto straight_on = graph.shortestPath({"trunk", 0}, {"trunk", 9});
  ASSERT_TRUE(straight_on.isOk());
  EXPECT_EQ(straight_on->keyframes, refs("trunk", 0, 9));
  const auto via = graph.shortestPath({"trunk", 0}, {"detour", 2});
  ASSERT_TRUE(via.isOk());
  EXPECT_EQ(via->junctions_crossed, 1);
}

TEST(RouteGraph, UnknownPlacesAreNamed) {
  const RouteGraph graph(TWorld().map());
  const auto to = graph.shortestPath({"trunk", 0}, {"kitchen", 1});
  ASSERT_FALSE(to.isOk());
  EXPECT_EQ(to.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(to.status().message().find("destination kitchen:1"), std::string::npos);
  const auto from = graph.shortestPath({"trunk", 99}, {"trunk", 1});
  ASSERT_FALSE(from.isOk());
  EXPECT_NE(from.status().message().find("start trunk:99"), std::string::npos);
  const auto here = graph.shortestPath({"trunk", 4}, {"trunk", 4});
  ASSERT_TRUE(here.isOk());
  EXPECT_EQ(here->keyframes.size(), 1u);
  EXPECT_EQ(here->cost, 0.0);
}

TEST(PathRoute, PutsEveryRouteInTheFrameOfTheFirst) {
  const TWorld world;
  const RouteMap map = world.map();
  const auto path = RouteGraph(map).shortestPath({"trunk", 1}, {"hall", 2});
  ASSERT_TRUE(path.isOk());
  const auto composed = composePathRoute(map, *path);
  ASSERT_TRUE(composed.isOk()) << composed.status().toString();
  const Route& route = composed->route;
  ASSERT_EQ(route.keyframes.size(), path->keyframes.size());
  EXPECT_EQ(composed->sources, path->keyframes);
  // The trunk's odometry is the world frame: every keyframe lands on its world pose.
  auto world_pose = [&](const KeyframeRef& ref) {
    if (ref.route == "trunk") return world.trunk[static_cast<std::size_t>(ref.keyframe)];
    if (ref.route == "room_a") return world.room_a[static_cast<std::size_t>(ref.keyframe)];
    return world.hall[static_cast<std::size_t>(ref.keyframe)];
  };
  for (std::size_t i = 0; i < route.keyframes.size(); ++i) {
    const Pose2D truth = world_pose(composed->sources[i]);
    const Pose2D error = truth.inverse().compose(route.keyframes[i].pose);
    EXPECT_NEAR(std::hypot(error.x, error.y), 0.0, 1e-9) << toString(composed->sources[i]);
    EXPECT_NEAR(error.yaw, 0.0, 1e-9) << toString(composed->sources[i]);
    EXPECT_EQ(route.keyframes[i].index, static_cast<int>(i));
  }
  EXPECT_EQ(route.keyframes[3].image_file, "/maps/test/routes/room_a/keyframes/0.png");
  EXPECT_EQ(route.keyframes[9].features_file, "/maps/test/routes/hall/keyframes/1.features.yml");
  EXPECT_EQ(routeFilePath(route.directory, route.keyframes[9].lines_file), "/maps/test/routes/hall/keyframes/1.lines.yml");
  EXPECT_EQ(route.info.camera.width, 64);
}

TEST(PathRoute, ExperiencesFollowTheirKeyframe) {
  const TWorld world;
  RouteMap map = world.map();
  RouteExperience experience;
  experience.pose = map.routes[1].route.keyframes[2].pose.compose(Pose2D(0.1, 0.0, 0.0));
  experience.pose_covariance = Eigen::Vector3d(0.04, 0.01, 0.001).asDiagonal();
  experience.image_file = "keyframes/2.e1.png";
  experience.features_file = "keyframes/2.e1.features.yml";
  map.routes[1].route.keyframes[2].experiences.push_back(experience);
  const auto path = RouteGraph(map).shortestPath({"trunk", 3}, {"room_a", 3});
  ASSERT_TRUE(path.isOk());
  const auto composed = composePathRoute(map, *path);
  ASSERT_TRUE(composed.isOk());
  const RouteExperience& moved = composed->route.keyframes[3].experiences.at(0);
  const Pose2D truth = world.room_a[2].compose(Pose2D(0.1, 0.0, 0.0));
  EXPECT_NEAR(moved.pose.x, truth.x, 1e-9);
  EXPECT_NEAR(moved.pose.y, truth.y, 1e-9);
  EXPECT_EQ(moved.image_file, "/maps/test/routes/room_a/keyframes/2.e1.png");
  // room_a's x axis points along the world's y: the larger variance turns with it.
  const double turn = world.room_a_odometry.yaw;
  EXPECT_NEAR(moved.pose_covariance(0, 0), 0.04 * std::cos(turn) * std::cos(turn) + 0.01 * std::sin(turn) * std::sin(turn), 1e-12);
  EXPECT_NEAR(moved.pose_covariance(2, 2), 0.001, 1e-15);
}

TEST(PathRoute, RefusesAStepThatIsNoWay) {
  const RouteMap map = TWorld().map();
  NetworkPath jump;
  jump.keyframes = {{"trunk", 0}, {"trunk", 1}, {"room_b", 0}};
  const auto composed = composePathRoute(map, jump);
  ASSERT_FALSE(composed.isOk());
  EXPECT_NE(composed.status().message().find("path step 3: from trunk:1 to room_b:0"), std::string::npos)
      << composed.status().message();
  NetworkPath backwards;
  backwards.keyframes = {{"trunk", 2}, {"trunk", 1}};
  EXPECT_FALSE(composePathRoute(map, backwards).isOk());
  NetworkPath unknown;
  unknown.keyframes = {{"trunk", 2}, {"trunk", 30}};
  EXPECT_NE(composePathRoute(map, unknown).status().message().find("trunk:30 is not in the map"), std::string::npos);
  EXPECT_FALSE(composePathRoute(map, NetworkPath{}).isOk());
}

TEST(RouteFramesInMap, PlacesEveryJoinedRouteInTheFirstRoutesFrame) {
  const TWorld world;
  RouteMap map = world.map();
  map.routes.push_back(memoryRoute("island", straight(Pose2D(9.0, 9.0, 0.0), 3)));  // no junction
  const auto frames = routeFramesInMap(map);
  ASSERT_EQ(frames.size(), 4u);  // not the island
  EXPECT_EQ(frames.count("island"), 0u);
  // The trunk's odometry frame is the world's; the others' are their odometry frames in it.
  const std::map<std::string, Pose2D> truth{{"trunk", Pose2D()}, {"room_a", world.room_a_odometry},
                                            {"room_b", Pose2D()}, {"hall", world.hall_odometry}};
  for (const auto& [name, frame] : truth) {
    ASSERT_EQ(frames.count(name), 1u) << name;
    EXPECT_NEAR(frames.at(name).x, frame.x, 1e-9) << name;
    EXPECT_NEAR(frames.at(name).y, frame.y, 1e-9) << name;
    EXPECT_NEAR(wrapToPi(frames.at(name).yaw - frame.yaw), 0.0, 1e-9) << name;
  }
  // From another root, the same geometry: the trunk's frame in the hall's.
  const auto from_hall = routeFramesInMap(map, "hall");
  EXPECT_NEAR(from_hall.at("trunk").x, world.hall_odometry.inverse().x, 1e-9);
  EXPECT_NEAR(from_hall.at("trunk").y, world.hall_odometry.inverse().y, 1e-9);
  EXPECT_TRUE(routeFramesInMap(map, "nowhere").empty());
}

TEST(PlaceHintFromMapPose, TakesTheRouteNearestToThePoseInItsOwnFrame) {
  const TWorld world;
  const RouteMap map = world.map();
  // Beside room_a's third keyframe (world frame = the trunk's = the map frame).
  const Pose2D near_room_a = world.room_a[2].compose(Pose2D(0.0, 0.1, 0.05));
  const auto hint = placeHintFromMapPose(map, near_room_a);
  ASSERT_TRUE(hint.has_value());
  EXPECT_EQ(hint->route, "room_a");
  const Pose2D expected = world.room_a_odometry.inverse().compose(near_room_a);
  EXPECT_NEAR(hint->pose.x, expected.x, 1e-9);
  EXPECT_NEAR(hint->pose.y, expected.y, 1e-9);
  EXPECT_NEAR(wrapToPi(hint->pose.yaw - expected.yaw), 0.0, 1e-9);
  const auto on_trunk = placeHintFromMapPose(map, Pose2D(2.6, 0.0, 0.0));
  ASSERT_TRUE(on_trunk.has_value());
  EXPECT_EQ(on_trunk->route, "trunk");
  EXPECT_FALSE(placeHintFromMapPose(map, Pose2D(NAN, 0.0, 0.0)).has_value());
}
