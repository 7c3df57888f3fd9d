// Bad input to teach_node: reported, survived, then recording works.
#include <gtest/gtest.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cmath>

#include "support/synthetic_route.h"
#include "homography_teach_repeat/TeachStatus.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

TEST(TeachNode, BadInputIsReportedAndSurvived) {
  ros::NodeHandle nh;
  tf2_ros::StaticTransformBroadcaster static_tf;
  static_tf.sendTransform(test_support::levelCameraMount(0.0));

  test_support::TestCamera camera(nh, "camera/image_raw", 5);
  ros::Publisher odom_pub = nh.advertise<nav_msgs::Odometry>("odom", 20);
  TeachStatus status;
  ros::Subscriber status_sub = nh.subscribe<TeachStatus>(
      "teach_node/status", 5, [&](const auto& m) { status = *m; });
  std::string diagnostics;
  ros::Subscriber diag_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>(
      "/diagnostics", 5, [&](const auto& m) {
        for (const auto& s : m->status) {
          diagnostics += s.message + "\n";
          for (const auto& v : s.values) diagnostics += v.key + ": " + v.value + "\n";
        }
      });
  ASSERT_TRUE(test_support::spinUntil(
      [&] { return camera.getNumSubscribers() > 0 && odom_pub.getNumSubscribers() > 0 && !status.state.empty(); },
      30.0));

  auto odometry = [&](const ros::Time& stamp, double x) {
    nav_msgs::Odometry o;
    o.header.stamp = stamp;
    o.pose.pose.position.x = x;
    o.pose.pose.orientation.w = 1.0;
    odom_pub.publish(o);
  };
  const test_support::SyntheticWall wall;
  const CameraCalibration c = test_support::syntheticCalibration();
  auto publishImage = [&](const ros::Time& stamp, double focal) {
    auto image = test_support::makeImage(wall.imageAt(PlanarPose()), "mono8");
    image->header.stamp = stamp;
    image->header.frame_id = "camera_optical_frame";
    sensor_msgs::CameraInfo info = test_support::makeCameraInfo(c.width, c.height, focal);
    info.header = image->header;
    camera.publish(*image, info);
  };

  // Zero focal length: the route cannot start; the latched status says so.
  ros::Time t = ros::Time::now();
  odometry(t - ros::Duration(0.05), 0.0);
  odometry(t + ros::Duration(0.05), 0.0);
  publishImage(t, 0.0);
  ASSERT_TRUE(test_support::spinUntil([&] { return status.state == "error"; }, 20.0)) << status.message;
  EXPECT_NE(status.message.find("fx"), std::string::npos) << status.message;

  // NaN odometry: rejected, reported in the diagnostics.
  nav_msgs::Odometry nan_odom;
  nan_odom.header.stamp = ros::Time::now();
  nan_odom.pose.pose.position.x = std::nan("");
  nan_odom.pose.pose.orientation.w = 1.0;
  odom_pub.publish(nan_odom);
  ASSERT_TRUE(test_support::spinUntil(
      [&] { return diagnostics.find("odometry rejected") != std::string::npos; }, 10.0))
      << diagnostics;

  // Good input: a keyframe is stored.
  t = ros::Time::now();
  odometry(t - ros::Duration(0.05), 0.0);
  odometry(t + ros::Duration(0.05), 0.0);
  ros::WallDuration(0.2).sleep();
  ros::spinOnce();
  publishImage(t, c.fx);
  ASSERT_TRUE(test_support::spinUntil([&] { return status.keyframes >= 1; }, 20.0))
      << status.state << ": " << status.message;
  EXPECT_EQ(status.state, "teaching");

  // A keyframe with nothing in view (a uniform image 2 m on) is stored, and said to be weak at once.
  t = ros::Time::now();
  odometry(t - ros::Duration(0.05), 2.0);
  odometry(t + ros::Duration(0.05), 2.0);
  ros::WallDuration(0.2).sleep();
  ros::spinOnce();
  auto blank = test_support::makeImage(cv::Mat(c.height, c.width, CV_8UC1, cv::Scalar(120)), "mono8");
  blank->header.stamp = t;
  blank->header.frame_id = "camera_optical_frame";
  sensor_msgs::CameraInfo info = test_support::makeCameraInfo(c.width, c.height, c.fx);
  info.header = blank->header;
  camera.publish(*blank, info);
  ASSERT_TRUE(test_support::spinUntil([&] { return status.keyframes >= 2; }, 20.0))
      << status.state << ": " << status.message;
  EXPECT_NE(status.message.find("keyframe 1 at (2.00, 0.00) is weak"), std::string::npos) << status.message;
  EXPECT_NE(status.message.find("min_plane_features"), std::string::npos) << status.message;
  EXPECT_NE(status.message.find("min_lines"), std::string::npos) << status.message;
  ASSERT_TRUE(test_support::spinUntil(
      [&] { return diagnostics.find("is weak") != std::string::npos; }, 10.0))
      << diagnostics;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_teach_node_bad_input");
  return RUN_ALL_TESTS();
}
