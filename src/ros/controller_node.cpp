#include "homography_teach_repeat/ros/controller_node.h"

#include <geometry_msgs/Twist.h>
#include <std_msgs/String.h>

#include <cmath>
#include <stdexcept>

#include "homography_teach_repeat/route.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {
namespace {

RouteFollowerOptions readFollowerOptions(const ros::NodeHandle& nh) {
  RouteFollowerOptions o;
  PotentialFieldParameters& p = o.controller;
  try {
    p.viscous_friction = readParameter(nh, "viscous_friction", p.viscous_friction);
    p.inertia_ratio = readParameter(nh, "inertia_ratio", p.inertia_ratio);
    p.lever = readParameter(nh, "lever", p.lever);
    p.attractive_gain = readParameter(nh, "attractive_gain", p.attractive_gain);
    p.attraction_saturation = readParameter(nh, "attraction_saturation", p.attraction_saturation);
    p.repulsive_gain = readParameter(nh, "repulsive_gain", p.repulsive_gain);
    p.repulsive_range = readParameter(nh, "repulsive_range", p.repulsive_range);
    p.max_linear_velocity = readParameter(nh, "max_linear_velocity", p.max_linear_velocity);
    p.max_angular_velocity = readParameter(nh, "max_angular_velocity", p.max_angular_velocity);
    p.max_linear_acceleration = readParameter(nh, "max_linear_acceleration", p.max_linear_acceleration);
    p.max_angular_acceleration =
        readParameter(nh, "max_angular_acceleration", p.max_angular_acceleration);
    p.allow_reverse = readParameter(nh, "allow_reverse", p.allow_reverse);
    p.goal_tolerance = readParameter(nh, "goal_tolerance", p.goal_tolerance);
    p.goal_heading_tolerance = readParameter(nh, "goal_heading_tolerance", p.goal_heading_tolerance);
    o.pose_timeout = readParameter(nh, "pose_timeout", o.pose_timeout);
    o.start_index = readParameter(nh, "start_index", o.start_index);
    o.end_index = readParameter(nh, "end_index", o.end_index);
    o.laps = readParameter(nh, "laps", o.laps);
    o.require_goal_heading = readParameter(nh, "require_goal_heading", o.require_goal_heading);
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("invalid parameter in " + nh.getNamespace() + ": " + e.what());
  }
  return o;
}

}  // namespace

ControllerNode::ControllerNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh), diagnostics_(nh, private_nh) {
  const std::string directory = readRequiredParameter<std::string>(private_nh, "route_directory");
  const double rate = readParameter(private_nh, "control_rate", 20.0);
  scan_timeout_ = readParameter(private_nh, "scan_timeout", 0.5);
  if (!(rate > 0.0) || !std::isfinite(rate)) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("control_rate") + "' must be > 0 Hz");
  }
  control_period_ = 1.0 / rate;
  const RouteFollowerOptions options = readFollowerOptions(private_nh);
  const auto route = loadRoute(directory);
  if (!route) throw std::runtime_error(route.status().message());
  std::vector<Pose2D> goals;
  for (const auto& k : route->keyframes) goals.push_back(k.pose);
  try {
    follower_.emplace(goals, options);
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string("route '") + directory + "': " + e.what());
  }
  command_publisher_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 1);
  state_publisher_ = private_nh_.advertise<std_msgs::String>("state", 1, /*latch=*/true);
  pose_subscriber_ = nh_.subscribe("pose", 5, &ControllerNode::onPose, this);
  heading_subscriber_ = nh_.subscribe("heading_correction", 5, &ControllerNode::onHeading, this);
  scan_subscriber_ = nh_.subscribe("scan", 1, &ControllerNode::onScan, this);
  diagnostics_.setHardwareID("controller_node");
  diagnostics_.add("controller", this, &ControllerNode::produceDiagnostics);
  timer_ = nh_.createTimer(ros::Duration(control_period_), &ControllerNode::onTimer, this);
  ROS_INFO("controller_node: following '%s' (%zu keyframes, %d lap(s)) at %.0f Hz",
           directory.c_str(), goals.size(), options.laps, rate);
}

ControllerNode::~ControllerNode() {
  command_publisher_.publish(geometry_msgs::Twist());
}

void ControllerNode::onPose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& pose) {
  const auto planar = ros_conversions::toPose2D(pose->pose.pose);
  std::lock_guard<std::mutex> lock(mutex_);
  if (!planar) {
    follower_->setFix(Pose2D(NAN, NAN, NAN), pose->header.stamp.toSec());
    ROS_WARN_THROTTLE(2.0, "controller_node: pose rejected (%s): stopping",
                      planar.status().message().c_str());
    return;
  }
  follower_->setFix(*planar, pose->header.stamp.toSec());
}

void ControllerNode::onHeading(const HeadingCorrectionStampedConstPtr& heading) {
  if (heading->ok) return;
  std::lock_guard<std::mutex> lock(mutex_);
  follower_->setLost(heading->status);
}

void ControllerNode::onScan(const sensor_msgs::LaserScanConstPtr& scan) {
  std::vector<Eigen::Vector2d> points;
  for (std::size_t i = 0; i < scan->ranges.size(); ++i) {
    const float r = scan->ranges[i];
    if (!std::isfinite(r) || r < scan->range_min || r > scan->range_max) continue;
    const double angle = scan->angle_min + static_cast<double>(i) * scan->angle_increment;
    points.emplace_back(r * std::cos(angle), r * std::sin(angle));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  obstacles_ = std::move(points);
  obstacles_stamp_ = scan->header.stamp;
}

void ControllerNode::onTimer(const ros::TimerEvent&) {
  std::lock_guard<std::mutex> lock(mutex_);
  const ros::Time now = ros::Time::now();
  static const std::vector<Eigen::Vector2d> kNoObstacles;
  const bool fresh_scan = (now - obstacles_stamp_).toSec() <= scan_timeout_;
  const FollowOutput out = follower_->update(now.toSec(), control_period_,
                                             fresh_scan ? obstacles_ : kNoObstacles);
  geometry_msgs::Twist command;
  command.linear.x = out.command.linear;
  command.angular.z = out.command.angular;
  command_publisher_.publish(command);
  if (out.state != last_output_.state || out.reason != last_output_.reason) {
    std_msgs::String state;
    state.data = toString(out.state) + (out.reason.empty() ? "" : ": " + out.reason);
    state_publisher_.publish(state);
    if (out.state == FollowState::kStopped) {
      ROS_WARN("controller_node: stopped: %s", out.reason.c_str());
    } else {
      ROS_INFO("controller_node: %s", state.data.c_str());
    }
  }
  last_output_ = out;
  diagnostics_.update();
}

void ControllerNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const FollowOutput& out = last_output_;
  const unsigned char level = out.state == FollowState::kStopped ? diagnostic_msgs::DiagnosticStatus::WARN
                                                                  : diagnostic_msgs::DiagnosticStatus::OK;
  stat.summary(level, toString(out.state) + (out.reason.empty() ? "" : ": " + out.reason));
  stat.add("goal keyframe", out.goal_index);
  stat.add("lap", out.lap);
  stat.add("distance to goal [m]", out.distance_to_goal);
  stat.add("progress", out.progress);
  stat.add("linear velocity [m/s]", out.command.linear);
  stat.add("angular velocity [rad/s]", out.command.angular);
}

}  // namespace homography_teach_repeat
