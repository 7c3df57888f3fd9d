// The safety stops of controller_node.
#include <gtest/gtest.h>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Twist.h>
#include <ros/ros.h>

#include <cmath>

#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

TEST(ControllerNode, SafetyStops) {
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  double pose_timeout = 0.5;
  private_nh.getParam("pose_timeout", pose_timeout);
  ros::Publisher pose_pub = nh.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 5);
  ros::Publisher heading_pub = nh.advertise<HeadingCorrectionStamped>("heading_correction", 5);
  geometry_msgs::Twist last;
  ros::Time last_time;
  int commands = 0;
  ros::Subscriber cmd_sub = nh.subscribe<geometry_msgs::Twist>("cmd_vel", 10, [&](const auto& m) {
    last = *m;
    last_time = ros::Time::now();
    ++commands;
  });
  ASSERT_TRUE(test_support::spinUntil(
      [&] { return pose_pub.getNumSubscribers() > 0 && heading_pub.getNumSubscribers() > 0 && commands > 0; },
      30.0));
  // Without a pose: zero.
  EXPECT_EQ(last.linear.x, 0.0);

  auto publishPose = [&](double x, double yaw) {
    geometry_msgs::PoseWithCovarianceStamped pose;
    pose.header.stamp = ros::Time::now();
    pose.header.frame_id = "map";
    pose.pose.pose.position.x = x;
    pose.pose.pose.orientation.z = std::sin(yaw / 2);
    pose.pose.pose.orientation.w = std::cos(yaw / 2);
    pose_pub.publish(pose);
  };
  // Fresh poses at the route start: the robot drives towards the next keyframe.
  ASSERT_TRUE(test_support::spinUntil([&] { return last.linear.x > 0.05; }, 10.0,
                                      [&] { publishPose(0.0, 0.0); }, 0.05))
      << "no motion with fresh poses";
  // Poses stop: zero within pose_timeout + 0.2 s of the last pose.
  publishPose(0.0, 0.0);
  const ros::WallTime stopped_publishing = ros::WallTime::now();
  ASSERT_TRUE(test_support::spinUntil([&] { return last.linear.x == 0.0 && last.angular.z == 0.0; },
                                      pose_timeout + 1.0));
  EXPECT_LT((ros::WallTime::now() - stopped_publishing).toSec(), pose_timeout + 0.2);

  // Lost tracking reported by repeat_node: zero although poses are fresh.
  ASSERT_TRUE(test_support::spinUntil([&] { return last.linear.x > 0.05; }, 10.0,
                                      [&] { publishPose(0.0, 0.0); }, 0.05));
  HeadingCorrectionStamped lost;
  lost.ok = false;
  lost.status = "NO_CONSENSUS: test";
  heading_pub.publish(lost);
  ASSERT_TRUE(test_support::spinUntil([&] { return last.linear.x == 0.0; }, 1.0));

  // A NaN pose: zero.
  ASSERT_TRUE(test_support::spinUntil([&] { return last.linear.x > 0.05; }, 10.0,
                                      [&] { publishPose(0.0, 0.0); }, 0.05));
  geometry_msgs::PoseWithCovarianceStamped nan_pose;
  nan_pose.header.stamp = ros::Time::now();
  nan_pose.pose.pose.position.x = std::nan("");
  nan_pose.pose.pose.orientation.w = 1.0;
  pose_pub.publish(nan_pose);
  ASSERT_TRUE(test_support::spinUntil([&] { return last.linear.x == 0.0; }, 1.0));
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_controller_node_safety");
  return RUN_ALL_TESTS();
}
