#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include "homography_teach_repeat/network/map_navigator.h"
#include "homography_teach_repeat/network/map_place_index.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;
using namespace homography_teach_repeat::test_support;

namespace {

PlanarPose cameraAt(double s) { return PlanarPose(0.08 * s, s, 0.04 * s); }
PinholeCamera camera() { return PinholeCamera(syntheticCalibration()); }

// "first" on the synthetic wall (a keyframe every 0.25 m or more along its 1.1 m), "other" on
// another wall; no junction between them.
struct NavigatorMap : ::testing::Test {
  static void SetUpTestSuite() {
    directory = makeTemporaryDirectory("htr_navigator_test");
    std::filesystem::create_directories(directory + "/routes");
    teachSyntheticRoute(SyntheticWall(), FeatureType::kSift, 12, directory + "/routes/first");
    SyntheticWall other;
    other.texture = makeTexture(640, 480, 29);
    teachSyntheticRoute(other, FeatureType::kSift, 12, directory + "/routes/other");
    RouteMap map;
    map.directory = directory;
    EXPECT_TRUE(commitMapRoute(map, "first", "routes/first").isOk());
    EXPECT_TRUE(commitMapRoute(map, "other", "routes/other").isOk());
  }
  static void TearDownTestSuite() { std::filesystem::remove_all(directory); }

  static MapNavigator navigator() {
    const auto map = loadRouteMap(directory);
    EXPECT_TRUE(map.isOk()) << map.status().toString();
    auto index = buildMapPlaceIndex(*map);
    EXPECT_TRUE(index.isOk()) << index.status().toString();
    auto created = MapNavigator::create(*map, std::move(*index));
    EXPECT_TRUE(created.isOk()) << created.status().toString();
    return std::move(*created);
  }
  // One frame at arc length s, the odometry in a frame of its own.
  static NavigatorFrame frameAt(MapNavigator& navigator, double s, double stamp) {
    const Pose2D odometry_origin(3.0, 4.0, -2.0);
    const PlanarPose pose = cameraAt(s);
    EXPECT_TRUE(navigator.addOdometry(stamp, odometry_origin.compose(cameraAxesToRep103(pose))).isOk());
    return navigator.processFrame(stamp, SyntheticWall().imageAt(pose), camera());
  }
  static std::string directory;
};
std::string NavigatorMap::directory;

}  // namespace

TEST_F(NavigatorMap, RelocalizesThenFollowsTheWayToTheDestination) {
  MapNavigator nav = navigator();
  const KeyframeRef last{"first", nav.map().find("first")->route.keyframes.back().index};
  EXPECT_EQ(nav.mode(), NavigatorMode::kRelocalizing);
  // No place yet: no way can be planned.
  const auto early = nav.setDestination(last);
  EXPECT_EQ(early.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(early.status().message().find("not known yet"), std::string::npos) << early.status().message();

  double stamp = 10.0;
  double s = 0.2;
  for (; s < 0.75 && nav.mode() != NavigatorMode::kPlaced; s += 0.1, stamp += 0.1) {
    const NavigatorFrame frame = frameAt(nav, s, stamp);
    ASSERT_TRUE(frame.status.isOk()) << frame.status.toString();
    ASSERT_TRUE(frame.relocalization.has_value());
    EXPECT_FALSE(frame.repeat.has_value());
  }
  ASSERT_EQ(nav.mode(), NavigatorMode::kPlaced);
  ASSERT_TRUE(nav.place().has_value());
  EXPECT_EQ(nav.place()->route, "first");

  // Unknown and unreachable destinations are refused with the reason.
  EXPECT_EQ(nav.setDestination({"nowhere", 0}).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(nav.setDestination({"first", 99}).status().code(), StatusCode::kInvalidInput);
  const auto unreachable = nav.setDestination({"other", 2});
  EXPECT_EQ(unreachable.status().code(), StatusCode::kNoConsensus);
  EXPECT_NE(unreachable.status().message().find("not reachable"), std::string::npos);
  EXPECT_EQ(nav.mode(), NavigatorMode::kPlaced);

  const auto way = nav.setDestination(last);
  ASSERT_TRUE(way.isOk()) << way.status().toString();
  EXPECT_EQ(way->keyframes.front(), *nav.place());
  EXPECT_EQ(way->keyframes.back(), last);
  ASSERT_EQ(nav.mode(), NavigatorMode::kFollowing);
  ASSERT_TRUE(nav.way().has_value());

  // The way in the map frame ("first" is the map's first route: its frame is the map frame).
  const std::vector<Pose2D> way_poses = nav.wayInMap();
  ASSERT_EQ(way_poses.size(), nav.way()->route.keyframes.size());
  EXPECT_NEAR(way_poses.back().x, nav.map().find("first")->route.keyframes.back().pose.x, 1e-12);
  EXPECT_EQ(nav.routeFrames().count("other"), 0U);  // no junction joins it

  // Along the way: the repeat's poses, in the map frame ("first"'s, the truth's).
  int poses = 0;
  for (; s < 1.1; s += 0.1, stamp += 0.1) {
    const NavigatorFrame frame = frameAt(nav, s, stamp);
    ASSERT_TRUE(frame.repeat.has_value());
    if (!frame.repeat->pose) continue;
    ++poses;
    const Pose2D truth = cameraAxesToRep103(cameraAt(s));
    EXPECT_NEAR(frame.repeat->pose->x, truth.x, 0.03) << s;
    EXPECT_NEAR(frame.repeat->pose->y, truth.y, 0.03) << s;
  }
  EXPECT_GE(poses, 2);
  ASSERT_TRUE(nav.place().has_value());
  EXPECT_EQ(nav.place()->route, "first");

  // Carried elsewhere: back to relocalizing, the way forgotten.
  ASSERT_TRUE(nav.relocalize().isOk());
  EXPECT_EQ(nav.mode(), NavigatorMode::kRelocalizing);
  EXPECT_FALSE(nav.way().has_value());
  EXPECT_FALSE(nav.place().has_value());
  EXPECT_EQ(nav.relocalize(PlaceHint{"nowhere", Pose2D()}).code(), StatusCode::kInvalidInput);
}

TEST_F(NavigatorMap, BadFramesAreRefusedWithTheReason) {
  MapNavigator nav = navigator();
  // No odometry for the image.
  NavigatorFrame frame = nav.processFrame(5.0, SyntheticWall().imageAt(cameraAt(0.2)), camera());
  EXPECT_FALSE(frame.status.isOk());
  EXPECT_NE(frame.status.message().find("odometry"), std::string::npos) << frame.status.message();
  ASSERT_TRUE(nav.addOdometry(5.0, Pose2D()).isOk());
  // Another camera size, a failed conversion.
  frame = nav.processFrame(5.0, cv::Mat(240, 320, CV_8UC1, cv::Scalar(0)), camera());
  EXPECT_EQ(frame.status.code(), StatusCode::kInvalidInput);
  frame = nav.processFrame(5.0, Expected<cv::Mat>(Status(StatusCode::kInvalidInput, "corrupt JPEG")), camera());
  EXPECT_NE(frame.status.message().find("corrupt JPEG"), std::string::npos);
  EXPECT_EQ(nav.mode(), NavigatorMode::kRelocalizing);
  EXPECT_EQ(nav.addOdometry(6.0, Pose2D(NAN, 0.0, 0.0)).code(), StatusCode::kInvalidInput);
}

TEST(ExpressRepeatResultIn, MovesPoseAndAlignmentAndRotatesTheCovariance) {
  RepeatFrameResult result;
  result.pose = Pose2D(1.0, 0.0, 0.1);
  result.map_to_odom = Pose2D(0.5, 0.5, -0.2);
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  covariance(0, 0) = 0.04;  // 0.2 m along the route frame's x
  covariance(1, 1) = 0.0001;
  covariance(2, 2) = 0.001;
  result.covariance = covariance;
  const Pose2D frame(2.0, 3.0, M_PI / 2.0);
  expressRepeatResultIn(frame, &result);
  EXPECT_NEAR(result.pose->x, 2.0, 1e-12);
  EXPECT_NEAR(result.pose->y, 4.0, 1e-12);
  EXPECT_NEAR(result.pose->yaw, M_PI / 2.0 + 0.1, 1e-12);
  EXPECT_NEAR(result.map_to_odom->x, 1.5, 1e-12);
  EXPECT_NEAR(result.map_to_odom->y, 3.5, 1e-12);
  // The route frame's x is the map frame's y.
  EXPECT_NEAR((*result.covariance)(1, 1), 0.04, 1e-12);
  EXPECT_NEAR((*result.covariance)(0, 0), 0.0001, 1e-12);
  EXPECT_NEAR((*result.covariance)(2, 2), 0.001, 1e-12);
  RepeatFrameResult empty;
  expressRepeatResultIn(frame, &empty);
  EXPECT_FALSE(empty.pose.has_value());
  EXPECT_FALSE(empty.covariance.has_value());
}
