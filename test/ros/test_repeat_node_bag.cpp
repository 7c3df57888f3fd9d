// repeat_node on a bag played back with `rosbag play`: every ground-truth stamp gets a pose
// within 3 cm / 0.3 deg of the truth.
#include <gtest/gtest.h>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <map>

#include "node_test_helpers.h"

TEST(RepeatNode, PlaysBackARecordedRun) {
  ros::NodeHandle nh;
  std::map<double, geometry_msgs::Pose> truths, poses;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "ground_truth", 20, [&](const auto& m) { truths[m->header.stamp.toSec()] = m->pose.pose; });
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 20, [&](const auto& m) { poses[m->header.stamp.toSec()] = m->pose.pose; });
  const std::size_t frames = 10;
  homography_teach_repeat::test_support::spinUntil(
      [&] { return truths.size() == frames && poses.size() == frames; }, 60.0);
  ASSERT_EQ(truths.size(), frames) << "the bag was not played completely";
  // The node drops frames rather than queueing them (queue 1): at half speed it keeps up.
  EXPECT_GE(poses.size(), frames - 1);
  for (const auto& [stamp, pose] : poses) {
    ASSERT_EQ(truths.count(stamp), 1u) << "pose at a stamp without an image: " << stamp;
    const geometry_msgs::Pose& truth = truths[stamp];
    EXPECT_NEAR(pose.position.x, truth.position.x, 0.03) << stamp;
    EXPECT_NEAR(pose.position.y, truth.position.y, 0.03) << stamp;
    const double yaw = 2.0 * std::atan2(pose.orientation.z, pose.orientation.w);
    const double truth_yaw = 2.0 * std::atan2(truth.orientation.z, truth.orientation.w);
    EXPECT_NEAR(std::remainder(yaw - truth_yaw, 2.0 * M_PI), 0.0, 0.3 * M_PI / 180.0) << stamp;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_repeat_node_bag");
  return RUN_ALL_TESTS();
}
