// The camera stops, end to end (issue 7): planar_world_sim renders the camera on sim_camera/*, this
// test relays it to camera/* for repeat_node while the robot repeats the closed-loop route with
// controller_node, then stops relaying. Expected, in simulated time: no pose after the last image,
// cmd_vel zero within carried_pose_timeout + 0.2 s of the last image (controller_node carries the
// last pose on odometry that long) and zero from then on, the robot
// standing still, and repeat_node's diagnostics reporting the stopped camera.
#include <gtest/gtest.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <cmath>
#include <string>
#include <vector>

#include "node_test_helpers.h"

using namespace homography_teach_repeat;

namespace {

struct Command {
  double time;  // ROS (simulated) time of arrival
  double linear, angular;
};

}  // namespace

TEST(CameraStops, ControllerCommandsZeroWithinTheCarriedPoseTimeout) {
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  const double carried_pose_timeout = private_nh.param("carried_pose_timeout", 1.0);
  bool relaying = true;
  double last_relayed_stamp = -1.0;
  ros::Publisher image_pub = nh.advertise<sensor_msgs::Image>("camera/image_raw", 2);
  ros::Publisher info_pub = nh.advertise<sensor_msgs::CameraInfo>("camera/camera_info", 2);
  ros::Subscriber image_sub = nh.subscribe<sensor_msgs::Image>("sim_camera/image_raw", 2, [&](const auto& m) {
    if (!relaying) return;
    image_pub.publish(m);
    last_relayed_stamp = std::max(last_relayed_stamp, m->header.stamp.toSec());
  });
  ros::Subscriber info_sub = nh.subscribe<sensor_msgs::CameraInfo>("sim_camera/camera_info", 2, [&](const auto& m) {
    if (relaying) info_pub.publish(m);
  });
  std::vector<Command> commands;
  ros::Subscriber command_sub = nh.subscribe<geometry_msgs::Twist>("cmd_vel", 50, [&](const auto& m) {
    commands.push_back({ros::Time::now().toSec(), m->linear.x, m->angular.z});
  });
  std::vector<double> pose_stamps;
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 20, [&](const auto& m) { pose_stamps.push_back(m->header.stamp.toSec()); });
  nav_msgs::Odometry truth;
  ros::Subscriber truth_sub = nh.subscribe<nav_msgs::Odometry>("ground_truth", 5, [&](const auto& m) { truth = *m; });
  std::string repeat_diagnostics;
  ros::Subscriber diagnostics_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>("/diagnostics", 20, [&](const auto& m) {
    for (const auto& s : m->status) {
      if (s.name.find("repeat_node") != std::string::npos && s.level == diagnostic_msgs::DiagnosticStatus::ERROR) {
        repeat_diagnostics = s.message;
      }
    }
  });

  // Driving on visual poses first: 3 s of simulated time with poses and moving commands.
  auto moving = [&] {
    int n = 0;
    for (const auto& c : commands) n += std::abs(c.linear) > 0.02 ? 1 : 0;
    return n;
  };
  ASSERT_TRUE(test_support::spinUntil([&] { return pose_stamps.size() >= 20 && moving() >= 30; }, 240.0))
      << pose_stamps.size() << " poses, " << moving() << " moving commands";

  relaying = false;
  ros::spinOnce();
  const double camera_stopped = last_relayed_stamp;
  const std::size_t commands_before = commands.size();
  ASSERT_GT(camera_stopped, 0.0);
  const double deadline = camera_stopped + carried_pose_timeout + 0.2;
  // Three seconds of simulated time after the last image (or 120 s of wall time).
  ASSERT_TRUE(test_support::spinUntil([&] { return ros::Time::now().toSec() > camera_stopped + 3.0; }, 120.0));
  ASSERT_TRUE(test_support::spinUntil([&] { return !repeat_diagnostics.empty(); }, 10.0))
      << "no ERROR diagnostic from repeat_node";
  EXPECT_NE(repeat_diagnostics.find("camera stopped"), std::string::npos) << repeat_diagnostics;

  for (const double stamp : pose_stamps) EXPECT_LE(stamp, camera_stopped + 1e-6) << "a pose without an image";
  double first_zero = -1.0;
  int after_deadline = 0;
  for (std::size_t i = commands_before; i < commands.size(); ++i) {
    const Command& c = commands[i];
    const bool zero = c.linear == 0.0 && c.angular == 0.0;
    if (zero && first_zero < 0.0) first_zero = c.time;
    if (c.time > deadline) {
      ++after_deadline;
      EXPECT_TRUE(zero) << "cmd_vel (" << c.linear << ", " << c.angular << ") " << c.time - camera_stopped
                        << " s after the last image";
    }
  }
  ASSERT_GE(first_zero, 0.0) << "no zero command after the camera stopped";
  std::printf("last image at %.3f s; first zero cmd_vel %.3f s later (carried_pose_timeout %.2f s); %d commands after "
              "the deadline, all checked zero\n",
              camera_stopped, first_zero - camera_stopped, carried_pose_timeout, after_deadline);
  EXPECT_LE(first_zero, deadline);
  EXPECT_GT(after_deadline, 10);
  // The simulated robot has stopped.
  EXPECT_LT(std::abs(truth.twist.twist.linear.x), 1e-3);
  EXPECT_LT(std::abs(truth.twist.twist.angular.z), 1e-3);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_camera_stops");
  return RUN_ALL_TESTS();
}
