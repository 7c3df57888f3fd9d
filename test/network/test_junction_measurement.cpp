#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "homography_teach_repeat/network/junction_measurement.h"
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
  // A keyframe whose features file is corrupt is named.
  RouteMap broken = map;
  const auto& keyframe = broken.find("branch")->route.keyframes.at(0);
  std::ofstream(routeFilePath(broken.find("branch")->route.directory, keyframe.features_file)) << "garbage";
  const auto corrupt = measureJunction(broken, {"trunk", 0}, {"branch", 0}, RepeatOptions());
  ASSERT_FALSE(corrupt.isOk());
  EXPECT_NE(corrupt.status().message().find("branch:0"), std::string::npos) << corrupt.status().message();
}
