#include "homography_teach_repeat/sim/ros/route_driver.h"

#include <geometry_msgs/Twist.h>
#include <std_msgs/Bool.h>
#include <std_srvs/Trigger.h>

#include <stdexcept>
#include <vector>

#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {

RouteDriver::RouteDriver(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh) {
  XmlRpc::XmlRpcValue list;
  if (!private_nh.getParam("waypoints", list) || list.getType() != XmlRpc::XmlRpcValue::TypeArray ||
      list.size() == 0) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("waypoints") +
                             "' must be a non-empty list of [x, y]");
  }
  std::vector<Eigen::Vector2d> waypoints;
  for (int i = 0; i < list.size(); ++i) {
    XmlRpc::XmlRpcValue& point = list[i];
    auto number = [&](XmlRpc::XmlRpcValue& v) {
      if (v.getType() == XmlRpc::XmlRpcValue::TypeDouble) return static_cast<double>(v);
      if (v.getType() == XmlRpc::XmlRpcValue::TypeInt) return static_cast<double>(static_cast<int>(v));
      throw std::runtime_error("parameter '" + private_nh.resolveName("waypoints") + "'[" + std::to_string(i) +
                               "]: coordinates must be numbers");
    };
    if (point.getType() != XmlRpc::XmlRpcValue::TypeArray || point.size() != 2) {
      throw std::runtime_error("parameter '" + private_nh.resolveName("waypoints") + "'[" + std::to_string(i) +
                               "] must be [x, y]");
    }
    waypoints.emplace_back(number(point[0]), number(point[1]));
  }
  WaypointDriverOptions options;
  options.linear_speed = readParameter(private_nh, "linear_speed", options.linear_speed);
  options.angular_speed = readParameter(private_nh, "angular_speed", options.angular_speed);
  options.heading_gain = readParameter(private_nh, "heading_gain", options.heading_gain);
  options.position_tolerance = readParameter(private_nh, "position_tolerance", options.position_tolerance);
  options.turn_in_place_angle = readParameter(private_nh, "turn_in_place_angle", options.turn_in_place_angle);
  // Optional: after the last waypoint turn in place to this yaw [rad] (a loop's start heading).
  double final_yaw = 0.0;
  if (private_nh.hasParam("final_yaw")) {
    options.turn_to_final_yaw = true;
    options.final_yaw = readParameter(private_nh, "final_yaw", final_yaw);
  }
  const double rate = readParameter(private_nh, "control_rate", 20.0);
  start_delay_ = std::max(0.0, readParameter(private_nh, "start_delay", 0.0));
  finish_service_ = readParameter<std::string>(private_nh, "finish_service", "");
  ready_service_ = readParameter<std::string>(private_nh, "ready_service", finish_service_);
  exit_when_done_ = readParameter(private_nh, "exit_when_done", false);
  if (!(rate > 0.0)) throw std::runtime_error("parameter '" + private_nh.resolveName("control_rate") + "' must be > 0");
  readParameters(private_nh, [&] {
    driver_.emplace(waypoints, options);
  });
  start_after_ = ros::Time::now() + ros::Duration(start_delay_);
  command_publisher_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 1);
  done_publisher_ = private_nh_.advertise<std_msgs::Bool>("done", 1, /*latch=*/true);
  std_msgs::Bool done;
  done.data = false;
  done_publisher_.publish(done);
  odometry_subscriber_ = nh_.subscribe("odom", 10, &RouteDriver::onOdometry, this);
  timer_ = nh_.createTimer(ros::Duration(1.0 / rate), &RouteDriver::onTimer, this);
  ROS_INFO("route_driver: %zu waypoints at %.2f m/s", waypoints.size(), options.linear_speed);
}

void RouteDriver::onOdometry(const nav_msgs::OdometryConstPtr& odometry) {
  const auto pose = ros_conversions::toPose2D(odometry->pose.pose);
  if (pose) pose_ = *pose;
}

void RouteDriver::onTimer(const ros::TimerEvent&) {
  if (done_) return;
  if (!ready_service_.empty() && !recorder_ready_) {
    // The node that records (teach_node) is ready once it offers ready_service (its finish service):
    // it may first load a map and build its place index, and a drive begun before would go unrecorded.
    if (!ros::service::exists(ready_service_, false)) {
      ROS_INFO_THROTTLE(5.0, "route_driver: waiting for '%s' before driving", ready_service_.c_str());
      return;
    }
    recorder_ready_ = true;
    start_after_ = ros::Time::now() + ros::Duration(start_delay_);
  }
  if (start_after_.isZero()) start_after_ = ros::Time::now();  // sim time had not started
  if (!pose_ || ros::Time::now() < start_after_) return;
  const VelocityCommand c = driver_->update(*pose_);
  geometry_msgs::Twist command;
  command.linear.x = c.linear;
  command.angular.z = c.angular;
  command_publisher_.publish(command);
  if (!driver_->finished()) return;
  done_ = true;
  ROS_INFO("route_driver: last waypoint reached");
  if (!finish_service_.empty()) {
    std_srvs::Trigger trigger;
    if (ros::service::waitForService(finish_service_, ros::Duration(10.0)) &&
        ros::service::call(finish_service_, trigger)) {
      ROS_INFO("route_driver: %s: %s", finish_service_.c_str(), trigger.response.message.c_str());
    } else {
      ROS_ERROR("route_driver: calling '%s' failed", finish_service_.c_str());
    }
  }
  std_msgs::Bool done;
  done.data = true;
  done_publisher_.publish(done);
  if (exit_when_done_) {
    ROS_INFO("route_driver: done, exiting (exit_when_done)");
    ros::shutdown();
  }
}

}  // namespace homography_teach_repeat
