#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "homography_teach_repeat/network/junction_measurement.h"
#include "homography_teach_repeat/network/map_audit.h"
#include "homography_teach_repeat/network/map_place_index.h"
#include "homography_teach_repeat/network/route_map_command.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;
using namespace homography_teach_repeat::test_support;

namespace {

// The trunk as teachSyntheticRoute teaches it; the branch 5 cm to the right of it and turned 2°
// (both taught with the true poses as odometry, so their frames are one).
std::string teachBranch(const SyntheticWall& wall, const std::string& directory) {
  TeachOptions options;
  options.route_directory = directory;
  options.overwrite = true;
  options.features.type = FeatureType::kSift;
  options.keyframes.distance = 0.25;
  options.first_plane_distance = wall.plane.distance;
  options.planes_from_odometry = false;
  auto session = TeachSession::start(options, syntheticCalibration(), Pose2D(0.0, 0.0, 0.0));
  if (!session) throw std::runtime_error(session.status().toString());
  for (int step = 0; step < 8; ++step) {
    const double s = 0.1 * step;
    const PlanarPose camera_pose(0.08 * s + 0.05, s, 0.04 * s + 0.035);
    const auto offered = session->offer(wall.imageAt(camera_pose), cameraAxesToRep103(camera_pose), 10.0 + step);
    if (!offered) throw std::runtime_error(offered.status().toString());
  }
  if (!session->finish()) throw std::runtime_error("teach failed");
  return directory;
}

struct TwoRouteMap : ::testing::Test {
  static void SetUpTestSuite() {
    directory = makeTemporaryDirectory("htr_junction_test");
    std::filesystem::create_directories(directory + "/routes");
    const SyntheticWall wall;
    teachSyntheticRoute(wall, FeatureType::kSift, 8, directory + "/routes/trunk");
    teachBranch(wall, directory + "/routes/branch");
    SyntheticWall elsewhere;  // another wall: nothing in common with the trunk's
    elsewhere.texture = makeTexture(640, 480, 29);
    teachSyntheticRoute(elsewhere, FeatureType::kSift, 8, directory + "/routes/elsewhere");
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory); }
  static RouteMap load() {
    RouteMap map;
    map.directory = directory;
    EXPECT_TRUE(commitMapRoute(map, "trunk", "routes/trunk").isOk());
    EXPECT_TRUE(commitMapRoute(map, "branch", "routes/branch").isOk());
    return map;
  }
  static std::string directory;
};
std::string TwoRouteMap::directory;

}  // namespace

TEST_F(TwoRouteMap, MeasuresTheRelativePoseFromTheImages) {
  const RouteMap map = load();
  const Pose2D& trunk = map.find("trunk")->route.keyframes.at(1).pose;
  const Pose2D& branch = map.find("branch")->route.keyframes.at(1).pose;
  const Pose2D truth = trunk.inverse().compose(branch);
  const auto junction = measureJunction(map, {"trunk", 1}, {"branch", 1}, RepeatOptions());
  ASSERT_TRUE(junction.isOk()) << junction.status().toString();
  EXPECT_EQ(junction->from, (KeyframeRef{"trunk", 1}));
  EXPECT_EQ(junction->to, (KeyframeRef{"branch", 1}));
  EXPECT_NEAR(junction->to_in_from.x, truth.x, 0.01);
  EXPECT_NEAR(junction->to_in_from.y, truth.y, 0.01);
  EXPECT_NEAR(junction->to_in_from.yaw, truth.yaw, 0.2 * M_PI / 180.0);
  EXPECT_GT(junction->inliers, 50);
  // An honest covariance: positive, and the error within 4 sigma on each axis.
  for (int axis = 0; axis < 3; ++axis) EXPECT_GT(junction->covariance(axis, axis), 0.0);
  const double errors[] = {junction->to_in_from.x - truth.x, junction->to_in_from.y - truth.y,
                           junction->to_in_from.yaw - truth.yaw};
  for (int axis = 0; axis < 3; ++axis) {
    EXPECT_LT(std::abs(errors[axis]), 4.0 * std::sqrt(junction->covariance(axis, axis)) + 1e-4) << "axis " << axis;
  }
  // Stored and loaded with the map.
  RouteMap editable = map;
  ASSERT_TRUE(addJunction(editable, *junction).isOk());
  EXPECT_EQ(loadRouteMap(directory)->junctions.at(0).inliers, junction->inliers);
}

TEST_F(TwoRouteMap, NamesWhatIsMissing) {
  const RouteMap map = load();
  const auto unknown = measureJunction(map, {"trunk", 1}, {"kitchen", 0}, RepeatOptions());
  ASSERT_FALSE(unknown.isOk());
  EXPECT_EQ(unknown.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(unknown.status().message().find("kitchen:0"), std::string::npos);
  EXPECT_FALSE(measureJunction(map, {"trunk", 99}, {"branch", 0}, RepeatOptions()).isOk());
  // A keyframe whose features file is corrupt is named (the file restored after: the suite shares it).
  const auto& keyframe = map.find("branch")->route.keyframes.at(0);
  const std::string path = routeFilePath(map.find("branch")->route.directory, keyframe.features_file);
  const std::string saved = path + ".saved";
  std::filesystem::copy_file(path, saved, std::filesystem::copy_options::overwrite_existing);
  std::ofstream(path) << "garbage";
  const auto corrupt = measureJunction(map, {"trunk", 0}, {"branch", 0}, RepeatOptions());
  std::filesystem::rename(saved, path);
  ASSERT_FALSE(corrupt.isOk());
  EXPECT_NE(corrupt.status().message().find("branch:0"), std::string::npos) << corrupt.status().message();
}

namespace {

int runCommand(const std::vector<std::string>& args, std::string* out, std::string* err) {
  std::ostringstream o;
  std::ostringstream e;
  const int status = runRouteMapCommand(args, o, e);
  *out = o.str();
  *err = e.str();
  return status;
}

}  // namespace

TEST_F(TwoRouteMap, TheToolMeasuresJunctionsIndexesAndLocates) {
  RouteMap map = load();
  std::string out;
  std::string err;
  ASSERT_EQ(runCommand({"junction", directory, "trunk:1", "branch:1"}, &out, &err), 0) << err;
  EXPECT_NE(out.find("junction trunk:1 -> branch:1"), std::string::npos) << out;
  EXPECT_EQ(loadRouteMap(directory)->junctions.size(), 1u);
  EXPECT_EQ(runCommand({"junction", directory, "trunk:1", "nowhere:1"}, &out, &err), 2);

  EXPECT_EQ(runCommand({"locate", directory, "/nonexistent.png"}, &out, &err), 2);
  EXPECT_NE(err.find("place_index.yml"), std::string::npos) << err;  // not built yet
  ASSERT_EQ(runCommand({"index", directory}, &out, &err), 0) << err;
  const auto index = loadMapPlaceIndex(*loadRouteMap(directory));
  ASSERT_TRUE(index.isOk()) << index.status().toString();
  EXPECT_EQ(index->labels().front(), "trunk:0");

  // A stored keyframe image proposes its own keyframe (or its twin on the other route) first.
  const Route& trunk = map.find("trunk")->route;
  const std::string image = routeFilePath(trunk.directory, trunk.keyframes.at(2).image_file);
  ASSERT_EQ(runCommand({"locate", directory, image, "--json"}, &out, &err), 0) << err;
  const auto doc = nlohmann::json::parse(out);
  ASSERT_FALSE(doc["candidates"].empty());
  const std::string first = doc["candidates"][0]["keyframe"];
  EXPECT_TRUE(first == "trunk:2" || first == "branch:2") << out;
  // Its geometry fits: the keyframe's own pose (or its twin's, 5 cm away), from the image.
  ASSERT_FALSE(doc["places"].empty()) << out;
  const Pose2D& taught = trunk.keyframes.at(2).pose;
  EXPECT_NEAR(doc["places"][0]["x"].get<double>(), taught.x, 0.08) << out;
  EXPECT_NEAR(doc["places"][0]["y"].get<double>(), taught.y, 0.08) << out;
  EXPECT_GT(doc["places"][0]["inliers"].get<int>(), 50) << out;
  EXPECT_EQ(runCommand({"locate", directory, "/nonexistent.png"}, &out, &err), 2);
  EXPECT_NE(err.find("cannot read the image"), std::string::npos) << err;

  // After an edit the index is stale, and says so.
  ASSERT_EQ(runCommand({"rename", directory, "branch", "side"}, &out, &err), 0) << err;
  EXPECT_EQ(runCommand({"locate", directory, image}, &out, &err), 2);
  EXPECT_NE(err.find("stale place index"), std::string::npos) << err;
  ASSERT_EQ(runCommand({"rename", directory, "side", "branch"}, &out, &err), 0) << err;
  ASSERT_EQ(runCommand({"remove-junctions", directory, "trunk"}, &out, &err), 0) << err;
}

TEST_F(TwoRouteMap, TheAuditNamesJunctionsTooWeakToCrossAndRoutesNoWayReaches) {
  RouteMap map = load();
  ASSERT_TRUE(commitMapRoute(map, "elsewhere", "routes/elsewhere").isOk());
  const auto measured = measureJunction(map, {"trunk", 1}, {"branch", 1}, RepeatOptions());
  ASSERT_TRUE(measured.isOk()) << measured.status().toString();
  ASSERT_TRUE(addJunction(map, *measured).isOk());
  Junction shifted = *measured;  // the same two views, stored 0.3 m off
  shifted.from = {"trunk", 2};
  shifted.to = {"branch", 2};
  shifted.to_in_from = shifted.to_in_from.compose(Pose2D(0.3, 0.0, 0.0));
  ASSERT_TRUE(addJunction(map, shifted).isOk());
  Junction blind = *measured;  // views of two different walls
  blind.from = {"trunk", 0};
  blind.to = {"elsewhere", 0};
  ASSERT_TRUE(addJunction(map, blind).isOk());

  auto audit = auditMap(map, RepeatOptions());
  ASSERT_TRUE(audit.isOk()) << audit.status().toString();
  ASSERT_EQ(audit->junctions.size(), 3u);
  EXPECT_TRUE(audit->junctions[0].weaknesses.empty()) << audit->junctions[0].weaknesses.front();
  EXPECT_LT(audit->junctions[0].disagreement_m, 0.01);
  ASSERT_EQ(audit->junctions[1].weaknesses.size(), 1u);
  EXPECT_NE(audit->junctions[1].weaknesses[0].find("from the stored pose"), std::string::npos);
  EXPECT_NEAR(audit->junctions[1].disagreement_m, 0.3, 0.02);
  EXPECT_FALSE(audit->junctions[2].measured);
  EXPECT_FALSE(audit->junctions[2].weaknesses.empty());
  EXPECT_EQ(audit->weak_junctions, 2);
  EXPECT_EQ(audit->groups.size(), 1u);

  // Without the blind junction, "elsewhere" is joined to nothing: no way reaches it.
  ASSERT_TRUE(removeJunctions(map, {"elsewhere", -1}).isOk());
  audit = auditMap(map, RepeatOptions());
  ASSERT_TRUE(audit.isOk());
  EXPECT_EQ(audit->groups.size(), 2u);
  ASSERT_FALSE(audit->notes.empty());
  EXPECT_NE(audit->notes.front().find("no way leads"), std::string::npos) << audit->notes.front();
}

