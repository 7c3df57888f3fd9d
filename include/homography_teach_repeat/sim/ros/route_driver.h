// route_driver: drives a scripted route for the teach phase of the simulator (what a person with a
// joystick does on the robot): waypoints in the odometry frame, followed with WaypointDriver
// (core) from `odom`; at the end it stops, optionally calls a std_srvs/Trigger service (e.g.
// /teach_node/finish) and reports done.
//
// Subscribes: odom (nav_msgs/Odometry)
// Publishes:  cmd_vel (geometry_msgs/Twist, at control_rate), ~done (std_msgs/Bool, latched)
// Parameters: waypoints (list of [x, y] in the odom frame, required), linear_speed [m/s],
//             angular_speed [rad/s], heading_gain [1/s], position_tolerance [m],
//             turn_in_place_angle [rad], control_rate [Hz], finish_service (string, "" = none),
//             ready_service (string, default finish_service: drive only once this service exists,
//             e.g. /teach_node/finish when a test calls it itself: the teach node is ready, its map
//             and place index loaded), start_delay [s] (wait before driving, counted from when
//             ready_service exists),
//             final_yaw [rad] (optional: turn in place to it after the last waypoint),
//             exit_when_done (bool: shut down after the last waypoint, for scripts)
#pragma once

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>

#include <optional>
#include <string>

#include "homography_teach_repeat/sim/waypoint_driver.h"

namespace homography_teach_repeat {

class RouteDriver {
 public:
  // Throws std::runtime_error naming the bad parameter.
  RouteDriver(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);

 private:
  void onOdometry(const nav_msgs::OdometryConstPtr& odometry);
  void onTimer(const ros::TimerEvent& event);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  std::optional<WaypointDriver> driver_;
  std::optional<Pose2D> pose_;
  std::string finish_service_;
  std::string ready_service_;  // "" = start without waiting for a service
  double start_delay_ = 0.0;  // [s]
  ros::Time start_after_;
  bool recorder_ready_ = false;  // ready_service exists (always true without one)
  bool done_ = false;
  bool exit_when_done_ = false;
  ros::Subscriber odometry_subscriber_;
  ros::Publisher command_publisher_;
  ros::Publisher done_publisher_;
  ros::Timer timer_;
};

}  // namespace homography_teach_repeat
