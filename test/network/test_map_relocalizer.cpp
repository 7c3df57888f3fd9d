#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "homography_teach_repeat/network/map_place_index.h"
#include "homography_teach_repeat/network/map_relocalizer.h"
#include "network/network_fixtures.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;
using namespace homography_teach_repeat::test_support;

namespace {

// The camera on teachSyntheticRoute's path at s [m] along it, `lateral` [m] to its right.
PlanarPose cameraAt(double s, double lateral = 0.0) { return PlanarPose(0.08 * s + lateral, s, 0.04 * s); }

SyntheticWall otherWall() {
  SyntheticWall wall;
  wall.texture = makeTexture(640, 480, 29);
  return wall;
}

// Routes taught on two walls: "first" and "twin" on the same wall (an aliased place: two corridors
// that look alike, or one corridor taught twice), "other" on a different one. Each route is taught
// with its own odometry frame (the true poses), so "first" and "twin" coincide in their frames.
struct MapOfWalls : ::testing::Test {
  static void SetUpTestSuite() {
    directory = makeTemporaryDirectory("htr_relocalizer_test");
    std::filesystem::create_directories(directory + "/routes");
    const SyntheticWall wall;
    teachSyntheticRoute(wall, FeatureType::kSift, 12, directory + "/routes/first");
    teachSyntheticRoute(wall, FeatureType::kSift, 12, directory + "/routes/twin");
    teachSyntheticRoute(otherWall(), FeatureType::kSift, 12, directory + "/routes/other");
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory); }

  static RouteMap load(const std::vector<std::string>& names) {
    RouteMap map;
    map.directory = directory;
    for (const std::string& name : names) EXPECT_TRUE(commitMapRoute(map, name, "routes/" + name).isOk());
    return map;
  }
  static MapRelocalizer relocalizer(const RouteMap& map, bool with_index = true) {
    std::optional<PlaceIndex> index;
    if (with_index) {
      auto built = buildMapPlaceIndex(map);
      EXPECT_TRUE(built.isOk()) << built.status().toString();
      index = std::move(*built);
    }
    auto created = MapRelocalizer::create(map, std::move(index), RepeatOptions());
    EXPECT_TRUE(created.isOk()) << created.status().toString();
    return std::move(*created);
  }
  // Frames along the taught path from s = 0.2 m on, 0.1 m apart, seeing `wall`; the odometry in a
  // frame of its own (the robot does not know where it was set down).
  static std::vector<Relocalization> drive(MapRelocalizer& relocalizer, const SyntheticWall& wall, int frames,
                                           double lateral = 0.0) {
    const Pose2D odometry_origin(5.0, -3.0, 1.0);
    std::vector<Relocalization> results;
    for (int f = 0; f < frames; ++f) {
      const PlanarPose camera = cameraAt(0.2 + 0.1 * f, lateral);
      const auto result = relocalizer.update(wall.imageAt(camera), odometry_origin.compose(cameraAxesToRep103(camera)));
      EXPECT_TRUE(result.isOk()) << result.status().toString();
      if (result) results.push_back(*result);
    }
    return results;
  }
  static std::string directory;
};
std::string MapOfWalls::directory;

TEST_F(MapOfWalls, FindsTheRouteAndPoseFromNoHintAndConfirmsAfterDriving) {
  const RouteMap map = load({"first", "other"});
  MapRelocalizer relocalizer = MapOfWalls::relocalizer(map);
  const auto results = drive(relocalizer, SyntheticWall(), 6, 0.03);
  ASSERT_EQ(results.size(), 6u);
  // Not before it has driven confirmation_distance (0.3 m: the fourth frame).
  for (int f = 0; f < 3; ++f) EXPECT_NE(results[f].state, RelocalizationState::kConfirmed) << results[f].reason;
  const Relocalization& last = results.back();
  ASSERT_EQ(last.state, RelocalizationState::kConfirmed) << last.reason;
  ASSERT_TRUE(last.place.has_value());
  EXPECT_EQ(last.place->keyframe.route, "first");
  const Pose2D truth = cameraAxesToRep103(cameraAt(0.7, 0.03));
  EXPECT_NEAR(last.place->base_pose.x, truth.x, 0.02);
  EXPECT_NEAR(last.place->base_pose.y, truth.y, 0.02);
  EXPECT_NEAR(last.place->base_pose.yaw, truth.yaw, 0.01);
  EXPECT_GE(last.place->support, 3);
  EXPECT_GT(last.timing.checks, 0);
}

TEST_F(MapOfWalls, TwoPlacesThatLookAlikeStayAmbiguous) {
  const RouteMap map = load({"first", "twin", "other"});
  MapRelocalizer relocalizer = MapOfWalls::relocalizer(map);
  const auto results = drive(relocalizer, SyntheticWall(), 6);
  ASSERT_EQ(results.size(), 6u);
  for (const Relocalization& r : results) EXPECT_NE(r.state, RelocalizationState::kConfirmed) << r.reason;
  EXPECT_EQ(results.back().state, RelocalizationState::kAmbiguous) << results.back().reason;
  bool saw_first = false, saw_twin = false;
  for (const PlaceHypothesis& h : results.back().hypotheses) {
    saw_first |= h.keyframe.route == "first";
    saw_twin |= h.keyframe.route == "twin";
  }
  EXPECT_TRUE(saw_first && saw_twin);
}

TEST_F(MapOfWalls, OnePlaceSeenFromTwoJoinedRoutesIsConfirmed) {
  RouteMap map = load({"first", "twin"});
  // The two routes meet: a junction says twin's keyframe 2 is first's keyframe 2 (their frames coincide).
  Junction junction;
  junction.from = {"first", 2};
  junction.to = {"twin", 2};
  junction.covariance = Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal();
  junction.inliers = 200;
  ASSERT_TRUE(addJunction(map, junction).isOk());
  MapRelocalizer relocalizer = MapOfWalls::relocalizer(map);
  const auto results = drive(relocalizer, SyntheticWall(), 6);
  ASSERT_EQ(results.back().state, RelocalizationState::kConfirmed) << results.back().reason;
  const Pose2D truth = cameraAxesToRep103(cameraAt(0.7));
  EXPECT_NEAR(results.back().place->base_pose.x, truth.x, 0.02);
  EXPECT_NEAR(results.back().place->base_pose.y, truth.y, 0.02);
}

TEST_F(MapOfWalls, AHintReplacesTheIndex) {
  const RouteMap map = load({"first", "other"});
  MapRelocalizer relocalizer = MapOfWalls::relocalizer(map, false);
  // Without an index, a search needs a hint.
  const auto refused = relocalizer.update(SyntheticWall().imageAt(cameraAt(0.2)), Pose2D());
  EXPECT_EQ(refused.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(refused.status().message().find("route_map index"), std::string::npos) << refused.status().message();
  EXPECT_EQ(relocalizer.setHint({"nowhere", Pose2D()}).code(), StatusCode::kInvalidInput);
  // A rough hint (half a metre and 10 degrees off) near the first frame.
  const Pose2D truth = cameraAxesToRep103(cameraAt(0.2));
  ASSERT_TRUE(relocalizer.setHint({"first", truth.compose(Pose2D(0.4, -0.3, 0.17))}).isOk());
  const auto results = drive(relocalizer, SyntheticWall(), 6);
  ASSERT_EQ(results.back().state, RelocalizationState::kConfirmed) << results.back().reason;
  EXPECT_EQ(results.back().place->keyframe.route, "first");
}

TEST_F(MapOfWalls, NothingThatFitsIsSearchingNeverAPlace) {
  const RouteMap map = load({"other"});
  MapRelocalizer relocalizer = MapOfWalls::relocalizer(map);
  // The first wall is not in this map.
  const auto results = drive(relocalizer, SyntheticWall(), 5);
  for (const Relocalization& r : results) {
    EXPECT_EQ(r.state, RelocalizationState::kSearching) << r.reason;
    EXPECT_FALSE(r.place.has_value());
  }
}

TEST_F(MapOfWalls, BadInputIsRefusedAndACorruptKeyframeIsNamed) {
  const std::string copy = makeTemporaryDirectory("htr_relocalizer_corrupt");
  std::filesystem::create_directories(copy + "/routes");
  std::filesystem::copy(directory + "/routes/first", copy + "/routes/first", std::filesystem::copy_options::recursive);
  RouteMap map;
  map.directory = copy;
  ASSERT_TRUE(commitMapRoute(map, "first", "routes/first").isOk());
  MapRelocalizer relocalizer = MapOfWalls::relocalizer(map);
  EXPECT_EQ(relocalizer.update(cv::Mat(), Pose2D()).status().code(), StatusCode::kInvalidInput);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(relocalizer.update(SyntheticWall().imageAt(cameraAt(0.2)), Pose2D(nan, 0.0, 0.0)).status().code(),
            StatusCode::kInvalidInput);
  // Every keyframe's features file is now garbage: the frames say so and find no place.
  for (const RouteKeyframe& k : map.routes.front().route.keyframes) {
    std::ofstream(copy + "/routes/first/" + k.features_file) << "%YAML:1.0\n---\nfeature_type: [\n";
  }
  const auto result = relocalizer.update(SyntheticWall().imageAt(cameraAt(0.2)), Pose2D());
  ASSERT_TRUE(result.isOk()) << result.status().toString();
  EXPECT_EQ(result->state, RelocalizationState::kSearching);
  ASSERT_FALSE(result->problems.empty());
  EXPECT_NE(result->problems.front().find("features"), std::string::npos) << result->problems.front();
  std::filesystem::remove_all(copy);
}

TEST_F(MapOfWalls, RefusesAMapWithoutPlanesAndAnIndexOfAnotherMap) {
  const std::string dir = network_test::temporaryDirectory();
  network_test::writeTinyRoute(dir, network_test::straight(Pose2D(), 3));  // no planes
  const auto map = loadRouteMap(dir);
  ASSERT_TRUE(map.isOk()) << map.status().toString();
  const auto refused = MapRelocalizer::create(*map, std::nullopt, RepeatOptions());
  EXPECT_EQ(refused.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(refused.status().message().find("plane"), std::string::npos) << refused.status().message();

  const std::string taught = directory + "/routes/first";
  RouteMap walls;
  walls.directory = directory;
  walls.routes.push_back(MapRoute{"first", "routes/first", *loadRoute(taught)});
  cv::Mat descriptors(40, 32, CV_8U);
  cv::randu(descriptors, 0, 256);
  auto other = PlaceIndex::build({descriptors.rowRange(0, 20), descriptors.rowRange(20, 40)});
  ASSERT_TRUE(other.isOk()) << other.status().toString();
  const auto stale = MapRelocalizer::create(walls, std::move(*other), RepeatOptions());
  EXPECT_EQ(stale.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(stale.status().message().find("route_map index"), std::string::npos) << stale.status().message();
}

TEST(RelocalizationOptions, RefusesNonsenseNamingTheField) {
  RelocalizationOptions options;
  options.checks_per_frame = 0;
  try {
    options.validate();
    FAIL() << "accepted checks_per_frame 0";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("checks_per_frame"), std::string::npos);
  }
  options = RelocalizationOptions();
  options.gate_yaw = std::numeric_limits<double>::quiet_NaN();
  EXPECT_THROW(options.validate(), std::invalid_argument);
}

}  // namespace
