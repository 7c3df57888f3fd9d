#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "homography_teach_repeat/network/map_place_index.h"
#include "homography_teach_repeat/network/map_teach.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;
using namespace homography_teach_repeat::test_support;

namespace {

PlanarPose cameraAt(double s, double lateral = 0.0) { return PlanarPose(0.08 * s + lateral, s, 0.04 * s); }

MapTeachOptions branchOptions(const std::string& name) {
  MapTeachOptions options;
  options.name = name;
  options.teach.features.type = FeatureType::kSift;
  options.teach.keyframes.distance = 0.25;
  options.teach.first_plane_distance = SyntheticWall().plane.distance;
  options.teach.planes_from_odometry = false;
  return options;
}

// A map holding "trunk", taught along the synthetic wall's path (its odometry frame is the truth's),
// with its place index.
struct MapWithTrunk : ::testing::Test {
  void SetUp() override {
    directory = makeTemporaryDirectory("htr_map_teach_test");
    std::filesystem::create_directories(directory + "/routes");
    teachSyntheticRoute(SyntheticWall(), FeatureType::kSift, 16, directory + "/routes/trunk");
    RouteMap map;
    map.directory = directory;
    ASSERT_TRUE(commitMapRoute(map, "trunk", "routes/trunk").isOk());
    auto index = buildMapPlaceIndex(map);
    ASSERT_TRUE(index.isOk()) << index.status().toString();
    ASSERT_TRUE(index->save(mapPlaceIndexPath(map)).isOk());
  }
  void TearDown() override { std::filesystem::remove_all(directory); }
  std::string directory;
};

}  // namespace

// A branch driven over the trunk's ground, 6 cm to the side, with odometry in a frame of its own:
// found on the trunk while teaching, junctions measured at the stretch's ends within 0.05 m and 1°
// of the truth, committed with the route, the index rebuilt.
TEST_F(MapWithTrunk, ABranchOverTaughtGroundGetsJunctionsFromTheImages) {
  const auto map = loadRouteMap(directory);
  ASSERT_TRUE(map.isOk());
  auto index = loadMapPlaceIndex(*map);
  ASSERT_TRUE(index.isOk()) << index.status().toString();
  auto teach = MapTeach::start(*map, std::move(*index), branchOptions("branch"), syntheticCalibration(), Pose2D());
  ASSERT_TRUE(teach.isOk()) << teach.status().toString();
  EXPECT_TRUE(teach->locating());
  const Pose2D odometry_origin(-4.0, 2.0, 0.6);
  std::vector<Pose2D> truth_of_keyframe;
  bool seen_on_map = false;
  for (int step = 0; step < 16; ++step) {
    const PlanarPose camera = cameraAt(0.1 * step, 0.06);
    const Pose2D truth = cameraAxesToRep103(camera);
    const auto stored = teach->offer(SyntheticWall().imageAt(camera), odometry_origin.compose(truth), 20.0 + step);
    ASSERT_TRUE(stored.isOk()) << stored.status().toString();
    if (*stored) truth_of_keyframe.push_back(truth);
    seen_on_map |= teach->onMap().has_value();
  }
  EXPECT_TRUE(seen_on_map);
  ASSERT_FALSE(teach->contacts().empty());
  const auto report = teach->finish();
  ASSERT_TRUE(report.isOk()) << report.status().toString();
  EXPECT_TRUE(report->problems.empty()) << report->problems.front();
  EXPECT_TRUE(report->index_rebuilt);
  ASSERT_GE(report->junctions.size(), 1u);

  const auto after = loadRouteMap(directory);
  ASSERT_TRUE(after.isOk()) << after.status().toString();
  ASSERT_NE(after->find("branch"), nullptr);
  EXPECT_EQ(after->junctions.size(), report->junctions.size());
  EXPECT_TRUE(loadMapPlaceIndex(*after).isOk());  // rebuilt: not stale
  for (const Junction& j : after->junctions) {
    ASSERT_EQ(j.from.route, "trunk");
    ASSERT_EQ(j.to.route, "branch");
    const Pose2D& trunk_pose = after->find("trunk")->route.keyframes.at(static_cast<std::size_t>(
        after->keyframePosition(j.from))).pose;  // trunk's frame is the truth's
    const Pose2D truth = trunk_pose.inverse().compose(truth_of_keyframe.at(static_cast<std::size_t>(j.to.keyframe)));
    EXPECT_NEAR(j.to_in_from.x, truth.x, 0.05) << toString(j.from) << " -> " << toString(j.to);
    EXPECT_NEAR(j.to_in_from.y, truth.y, 0.05);
    EXPECT_NEAR(wrapToPi(j.to_in_from.yaw - truth.yaw), 0.0, M_PI / 180.0);
    EXPECT_GT(j.inliers, 40);
  }
}

// A branch that reaches taught ground just before it ends (two keyframes there: its place is still
// tentative, confirmed after three): the junction is measured at its last keyframe at finish, within
// 0.05 m and 1° of the truth, as the network demo's south branch needs where it rejoins the trunk.
TEST_F(MapWithTrunk, ABranchThatEndsOnTaughtGroundGetsItsJunctionAtTheEnd) {
  const auto map = loadRouteMap(directory);
  auto index = loadMapPlaceIndex(*map);
  ASSERT_TRUE(index.isOk()) << index.status().toString();
  auto teach = MapTeach::start(*map, std::move(*index), branchOptions("short"), syntheticCalibration(), Pose2D());
  ASSERT_TRUE(teach.isOk()) << teach.status().toString();
  const Pose2D odometry_origin(1.0, -3.0, -0.4);
  std::vector<Pose2D> truth_of_keyframe;
  for (int step = 0; step < 4; ++step) {
    const PlanarPose camera = cameraAt(0.4 + 0.1 * step, 0.03);
    const Pose2D truth = cameraAxesToRep103(camera);
    const auto stored = teach->offer(SyntheticWall().imageAt(camera), odometry_origin.compose(truth), 5.0 + step);
    ASSERT_TRUE(stored.isOk()) << stored.status().toString();
    if (*stored) truth_of_keyframe.push_back(truth);
  }
  ASSERT_EQ(truth_of_keyframe.size(), 2u);
  ASSERT_TRUE(teach->lastLocation().has_value());
  EXPECT_EQ(teach->lastLocation()->state, RelocalizationState::kTentative) << teach->lastLocation()->reason;
  EXPECT_TRUE(teach->contacts().empty());
  const auto report = teach->finish();
  ASSERT_TRUE(report.isOk()) << report.status().toString();
  EXPECT_TRUE(report->problems.empty()) << report->problems.front();
  ASSERT_EQ(report->junctions.size(), 1u);
  const Junction& j = report->junctions.front();
  EXPECT_EQ(j.to.keyframe, 1);  // the last
  const auto after = loadRouteMap(directory);
  ASSERT_TRUE(after.isOk());
  const auto trunk_pose = after->keyframePose(j.from);
  ASSERT_TRUE(trunk_pose.has_value());
  const Pose2D truth = trunk_pose->inverse().compose(truth_of_keyframe.back());
  EXPECT_NEAR(j.to_in_from.x, truth.x, 0.05);
  EXPECT_NEAR(j.to_in_from.y, truth.y, 0.05);
  EXPECT_NEAR(wrapToPi(j.to_in_from.yaw - truth.yaw), 0.0, M_PI / 180.0);
}

// The same wall seen from 0.7 m to the side of the trunk: the robot is located (confirmed), but it
// is not on taught ground (contact_distance 0.5 m): no contact, no junction.
TEST_F(MapWithTrunk, AWallSeenFromBesideIsNoContact) {
  const auto map = loadRouteMap(directory);
  auto index = loadMapPlaceIndex(*map);
  ASSERT_TRUE(index.isOk()) << index.status().toString();
  MapTeachOptions options = branchOptions("beside");
  options.relocalization.max_place_distance = 1.0;  // located from 0.7 m beside the trunk's keyframes
  auto teach = MapTeach::start(*map, std::move(*index), options, syntheticCalibration(), Pose2D());
  ASSERT_TRUE(teach.isOk()) << teach.status().toString();
  bool confirmed = false;
  bool seen_on_map = false;
  for (int step = 0; step < 16; ++step) {
    const PlanarPose camera = cameraAt(0.1 * step, 0.7);
    ASSERT_TRUE(teach->offer(SyntheticWall().imageAt(camera), cameraAxesToRep103(camera), 1.0 + step).isOk());
    confirmed |= teach->lastLocation() && teach->lastLocation()->state == RelocalizationState::kConfirmed;
    seen_on_map |= teach->onMap().has_value();
  }
  EXPECT_TRUE(confirmed);
  EXPECT_FALSE(seen_on_map);
  EXPECT_TRUE(teach->contacts().empty());
}

// Without a place index nothing is located, and the route is still committed (index built at finish).
TEST_F(MapWithTrunk, WithoutAnIndexTheRouteIsCommittedWithoutJunctions) {
  const auto map = loadRouteMap(directory);
  auto teach = MapTeach::start(*map, std::nullopt, branchOptions("side"), syntheticCalibration(), Pose2D());
  ASSERT_TRUE(teach.isOk()) << teach.status().toString();
  EXPECT_FALSE(teach->locating());
  for (int step = 0; step < 8; ++step) {
    const PlanarPose camera = cameraAt(0.1 * step);
    ASSERT_TRUE(teach->offer(SyntheticWall().imageAt(camera), cameraAxesToRep103(camera), 1.0 + step).isOk());
  }
  const auto report = teach->finish();
  ASSERT_TRUE(report.isOk()) << report.status().toString();
  EXPECT_TRUE(report->junctions.empty());
  const auto after = loadRouteMap(directory);
  ASSERT_TRUE(after.isOk());
  EXPECT_EQ(after->routes.size(), 2u);
  EXPECT_EQ(after->find("side")->directory, "routes/side");
  EXPECT_TRUE(listRouteMapOrphans(*after).empty());
}

TEST_F(MapWithTrunk, ABadNameIsRefusedBeforeAnythingIsWritten) {
  const auto map = loadRouteMap(directory);
  const auto refused = MapTeach::start(*map, std::nullopt, branchOptions("no good"), syntheticCalibration(), Pose2D());
  EXPECT_EQ(refused.status().code(), StatusCode::kInvalidInput);
  EXPECT_TRUE(listRouteMapOrphans(*loadRouteMap(directory)).empty());
}

// The first route of a new map: an empty folder (no routes/ yet) becomes a map of one route.
TEST(MapTeachNewMap, TheFirstRouteMakesTheMap) {
  const std::string directory = makeTemporaryDirectory("htr_map_teach_new");
  RouteMap empty;
  empty.directory = directory + "/building";  // not even the folder exists
  std::filesystem::create_directories(empty.directory);
  MapTeachOptions options = branchOptions("first");
  auto teach = MapTeach::start(empty, std::nullopt, options, syntheticCalibration(), Pose2D());
  ASSERT_TRUE(teach.isOk()) << teach.status().toString();
  EXPECT_FALSE(teach->locating());
  for (int step = 0; step < 6; ++step) {
    const PlanarPose camera = cameraAt(0.1 * step);
    ASSERT_TRUE(teach->offer(SyntheticWall().imageAt(camera), cameraAxesToRep103(camera), 1.0 + step).isOk());
  }
  const auto report = teach->finish();
  ASSERT_TRUE(report.isOk()) << report.status().toString();
  const auto map = loadRouteMap(empty.directory);
  ASSERT_TRUE(map.isOk()) << map.status().toString();
  ASSERT_EQ(map->routes.size(), 1u);
  EXPECT_EQ(map->routes.front().name, "first");
  std::filesystem::remove_all(directory);
}
