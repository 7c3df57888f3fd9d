// repeat_node on a bag played back with `rosbag play`: every ground-truth stamp gets a pose
// within 3 cm / 0.3 deg of the truth. With ~corrupt_frames N (the compressed bag of
// repeat_node_compressed_bag.test), N frames cannot be decoded: they get no pose, and repeat_node's
// diagnostics count them and name the reason.
#include <gtest/gtest.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <cmath>
#include <map>
#include <string>

#include "node_test_helpers.h"

TEST(RepeatNode, PlaysBackARecordedRun) {
  ros::NodeHandle nh;
  const int corrupt_frames = ros::NodeHandle("~").param("corrupt_frames", 0);
  std::map<double, geometry_msgs::Pose> truths, poses;
  std::string dropped_count, dropped_reason;
  ros::Subscriber diagnostics_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>("/diagnostics", 20, [&](const auto& m) {
    for (const auto& status : m->status) {
      if (status.name.find("repeat_node") == std::string::npos) continue;
      for (const auto& value : status.values) {
        if (value.key == "undecodable images dropped") dropped_count = value.value;
      }
      if (status.message.find("dropped") != std::string::npos) dropped_reason = status.message;
    }
  });
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>(
      "ground_truth", 20, [&](const auto& m) { truths[m->header.stamp.toSec()] = m->pose.pose; });
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 20, [&](const auto& m) { poses[m->header.stamp.toSec()] = m->pose.pose; });
  const std::size_t frames = 10;
  const std::size_t expected_poses = frames - static_cast<std::size_t>(corrupt_frames);
  homography_teach_repeat::test_support::spinUntil(
      [&] {
        return truths.size() == frames && poses.size() == expected_poses &&
               (corrupt_frames == 0 || (!dropped_count.empty() && !dropped_reason.empty()));
      },
      60.0);
  ASSERT_EQ(truths.size(), frames) << "the bag was not played completely";
  // The node drops frames rather than queueing them (queue 1): at half speed it keeps up.
  EXPECT_GE(poses.size(), expected_poses - 1);
  EXPECT_LE(poses.size(), expected_poses);
  if (corrupt_frames > 0) {
    EXPECT_EQ(dropped_count, std::to_string(corrupt_frames)) << "diagnostics: undecodable images dropped";
    EXPECT_NE(dropped_reason.find("truncated JPEG"), std::string::npos) << dropped_reason;
  }
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
