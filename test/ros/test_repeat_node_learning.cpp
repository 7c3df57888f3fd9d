// repeat_node learns (test/launch/repeat_node_learning.test): images of the synthetic wall along the
// taught path with odometry, then ~save_experiences; the route then lists the learned views, each
// near its keyframe with a covariance, and a second call adds nothing new (the candidates went).
#include <gtest/gtest.h>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>

#include <cmath>

#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"
#include "support/synthetic_route.h"
#include "synthetic_camera.h"

using namespace homography_teach_repeat;

TEST(RepeatNodeLearning, SavesTheViewsItLearnedIntoTheRoute) {
  ros::NodeHandle nh, private_nh("~");
  const std::string directory = private_nh.param<std::string>("route_directory", "");
  test_support::TestCamera camera(nh, "camera/image_raw", 2);
  ros::Publisher odometry = nh.advertise<nav_msgs::Odometry>("odom", 20);
  int poses = 0;
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 20, [&](const auto&) { ++poses; });
  ASSERT_TRUE(test_support::spinUntil([&] { return camera.getNumSubscribers() > 0 && pose_sub.getNumPublishers() > 0; },
                                      30.0));
  ASSERT_TRUE(ros::service::waitForService("repeat_node/save_experiences", ros::Duration(10.0)));
  const test_support::SyntheticWall wall;
  const auto taught = loadRoute(directory);
  ASSERT_TRUE(taught.isOk()) << taught.status().toString();
  // Along the taught path (the teach run's camera poses, 2 cm beside them), odometry with each image.
  int published = 0;
  for (int step = 0; step < 14; ++step) {
    const double s = 0.1 * step + 0.02;
    const PlanarPose camera_pose(0.08 * s + 0.02, s, 0.04 * s);
    const Pose2D base = cameraAxesToRep103(camera_pose);
    const double stamp = 100.0 + 0.5 * step;
    for (const double t : {stamp - 0.25, stamp, stamp + 0.25}) {
      nav_msgs::Odometry odom;
      odom.header.stamp = ros::Time(t);
      odom.header.frame_id = "odom";
      odom.pose.pose.position.x = base.x;
      odom.pose.pose.position.y = base.y;
      odom.pose.pose.orientation.z = std::sin(0.5 * base.yaw);
      odom.pose.pose.orientation.w = std::cos(0.5 * base.yaw);
      odom.pose.covariance[0] = odom.pose.covariance[7] = 1e-6;
      odom.pose.covariance[35] = 1e-8;
      odometry.publish(odom);
    }
    ros::WallDuration(0.1).sleep();
    auto image = test_support::makeImage(wall.imageAt(camera_pose), "mono8");
    image->header.stamp = ros::Time(stamp);
    image->header.frame_id = "camera_optical_frame";
    sensor_msgs::CameraInfo info = test_support::syntheticCameraInfo();
    info.header = image->header;
    camera.publish(*image, info);
    ++published;
    ASSERT_TRUE(test_support::spinUntil([&] { return poses == published; }, 30.0)) << "no pose for image " << step;
  }
  std_srvs::Trigger save;
  ASSERT_TRUE(ros::service::call("repeat_node/save_experiences", save));
  EXPECT_TRUE(save.response.success) << save.response.message;
  std::cout << "save_experiences: " << save.response.message << "\n";
  const auto learned = loadRoute(directory);
  ASSERT_TRUE(learned.isOk()) << learned.status().toString();
  EXPECT_EQ(learned->loaded_format_version, kRouteFormatVersion);
  int experiences = 0;
  int measured_pairs = 0;  // learned at consecutive keyframes: measured as the teach run's pairs
  for (std::size_t k = 0; k < learned->keyframes.size(); ++k) {
    for (const auto& e : learned->keyframes[k].experiences) {
      ++experiences;
      if (e.match_residual) ++measured_pairs;
      EXPECT_LT(std::hypot(e.pose.x - learned->keyframes[k].pose.x, e.pose.y - learned->keyframes[k].pose.y), 0.2);
      EXPECT_GT(e.pose_covariance(0, 0), 0.0);
      EXPECT_TRUE(loadExperienceFeatures(*learned, k, 0).isOk());
    }
  }
  EXPECT_GE(experiences, 3);
  EXPECT_GE(measured_pairs, 1);
  EXPECT_TRUE(routeMatchResidual(*learned).has_value());
  std_srvs::Trigger again;
  ASSERT_TRUE(ros::service::call("repeat_node/save_experiences", again));
  EXPECT_NE(again.response.message.find("added 0 learned view"), std::string::npos) << again.response.message;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_repeat_node_learning");
  return RUN_ALL_TESTS();
}
