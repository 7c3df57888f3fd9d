// The nodes loaded as nodelets into one manager serve the same interface as the executables.
#include <gtest/gtest.h>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>
#include <std_msgs/String.h>
#include <visualization_msgs/MarkerArray.h>

#include "homography_teach_repeat/TeachStatus.h"
#include "node_test_helpers.h"
#include "synthetic_camera.h"

using namespace homography_teach_repeat;

TEST(Nodelets, LoadAndServeTheirInterfaces) {
  ros::NodeHandle nh;
  std::size_t markers = 0;
  std::string controller_state;
  std::string teach_state;
  int poses = 0;
  ros::Subscriber marker_sub = nh.subscribe<visualization_msgs::MarkerArray>(
      "repeat_node/route_markers", 1, [&](const auto& m) { markers = m->markers.size(); });
  ros::Subscriber state_sub = nh.subscribe<std_msgs::String>(
      "controller_node/state", 1, [&](const auto& m) { controller_state = m->data; });
  ros::Subscriber teach_sub = nh.subscribe<TeachStatus>(
      "teach_node/status", 1, [&](const auto& m) { teach_state = m->state; });
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 5, [&](const auto&) { ++poses; });
  test_support::TestCamera camera(nh, "camera/image_raw", 2);
  ASSERT_TRUE(test_support::spinUntil(
      [&] { return markers > 0 && !controller_state.empty() && !teach_state.empty(); }, 60.0))
      << "markers " << markers << ", controller '" << controller_state << "', teach '" << teach_state << "'";
  EXPECT_EQ(markers, 12u);  // 6 keyframes + 6 planes of the fixture route
  EXPECT_EQ(controller_state.rfind("waiting", 0), 0u) << controller_state;
  EXPECT_EQ(teach_state, "waiting");

  // The repeat nodelet localizes an image of the synthetic wall (one connection per process).
  ASSERT_TRUE(test_support::spinUntil([&] { return camera.getNumSubscribers() > 0 && pose_sub.getNumPublishers() > 0; }, 30.0));
  const test_support::SyntheticWall wall;
  auto image = test_support::makeImage(wall.imageAt(PlanarPose(0.02, 0.1, 0.0)), "mono8");
  image->header.stamp = ros::Time(50.0);
  sensor_msgs::CameraInfo info = test_support::syntheticCameraInfo();
  info.header = image->header;
  camera.publish(*image, info);
  EXPECT_TRUE(test_support::spinUntil([&] { return poses > 0; }, 30.0));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_nodelets");
  return RUN_ALL_TESTS();
}
