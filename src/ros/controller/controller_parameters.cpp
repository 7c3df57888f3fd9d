#include "homography_teach_repeat/ros/controller_parameters.h"

#include <cmath>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/ros/controller_node.h"
#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {

RouteFollowerOptions readRouteFollowerOptions(const ros::NodeHandle& nh) {
  RouteFollowerOptions o;
  PotentialFieldParameters& p = o.controller;
  readParameters(nh, [&] {
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
    o.odometry_timeout = readParameter(nh, "odometry_timeout", o.odometry_timeout);
    o.carried_pose_timeout = readParameter(nh, "carried_pose_timeout", o.carried_pose_timeout);
    o.start_index = readParameter(nh, "start_index", o.start_index);
    o.end_index = readParameter(nh, "end_index", o.end_index);
    o.laps = readParameter(nh, "laps", o.laps);
    o.require_goal_heading = readParameter(nh, "require_goal_heading", o.require_goal_heading);
    o.return_to_start = readParameter(nh, "return_to_start", o.return_to_start);
    o.closed_route_gap = readParameter(nh, "closed_route_gap", o.closed_route_gap);
    o.corner_radius = readParameter(nh, "corner_radius", o.corner_radius);
    o.corner_tolerance = readParameter(nh, "corner_tolerance", o.corner_tolerance);
    o.turn_in_place_angle = readParameter(nh, "turn_in_place_angle", o.turn_in_place_angle);
    o.turn_in_place_exit_angle = readParameter(nh, "turn_in_place_exit_angle", o.turn_in_place_exit_angle);
    o.straight_leg_angle = readParameter(nh, "straight_leg_angle", o.straight_leg_angle);
    o.corner_deceleration = readParameter(nh, "corner_deceleration", o.corner_deceleration);
    o.final_approach_distance = readParameter(nh, "final_approach_distance", o.final_approach_distance);
    o.final_goal_tolerance = readParameter(nh, "final_goal_tolerance", o.final_goal_tolerance);
    o.final_turn_angle = readParameter(nh, "final_turn_angle", o.final_turn_angle);
    o.final_approach_gain = readParameter(nh, "final_approach_gain", o.final_approach_gain);
    o.final_turn_gain = readParameter(nh, "final_turn_gain", o.final_turn_gain);
    o.align_final_heading = readParameter(nh, "align_final_heading", o.align_final_heading);
    o.final_heading_tolerance = readParameter(nh, "final_heading_tolerance", o.final_heading_tolerance);
    o.degraded_speed_factor = readParameter(nh, "degraded_speed_factor", o.degraded_speed_factor);
    o.lost_search_delay = readParameter(nh, "lost_search_delay", o.lost_search_delay);
    o.lost_search_angle = readParameter(nh, "lost_search_angle", o.lost_search_angle);
    o.lost_search_velocity = readParameter(nh, "lost_search_velocity", o.lost_search_velocity);
    o.robot_radius = readParameter(nh, "robot_radius", o.robot_radius);
    o.obstacle_stop_gap = readParameter(nh, "obstacle_stop_gap", o.obstacle_stop_gap);
    o.obstacle_slow_gap = readParameter(nh, "obstacle_slow_gap", o.obstacle_slow_gap);
    o.pass_offset = readParameter(nh, "pass_offset", o.pass_offset);
    o.pass_clearance = readParameter(nh, "pass_clearance", o.pass_clearance);
    o.pass_lookahead = readParameter(nh, "pass_lookahead", o.pass_lookahead);
    o.validate();
  });
  return o;
}

void ControllerNode::onReconfigure(ControllerConfig& config, uint32_t /*level*/) {
  RouteFollowerOptions options = options_;
  PotentialFieldParameters& p = options.controller;
  p.viscous_friction = config.viscous_friction;
  p.inertia_ratio = config.inertia_ratio;
  p.lever = config.lever;
  p.attractive_gain = config.attractive_gain;
  p.attraction_saturation = config.attraction_saturation;
  p.repulsive_gain = config.repulsive_gain;
  p.repulsive_range = config.repulsive_range;
  p.max_linear_velocity = config.max_linear_velocity;
  p.max_angular_velocity = config.max_angular_velocity;
  p.max_linear_acceleration = config.max_linear_acceleration;
  p.max_angular_acceleration = config.max_angular_acceleration;
  p.allow_reverse = config.allow_reverse;
  p.goal_tolerance = config.goal_tolerance;
  p.goal_heading_tolerance = config.goal_heading_tolerance;
  options.require_goal_heading = config.require_goal_heading;
  options.pose_timeout = config.pose_timeout;
  try {
    options.validate();
    std::lock_guard<std::mutex> lock(mutex_);
    if (follower_) follower_->retune(options);
    options_.controller = options.controller;
    options_.require_goal_heading = options.require_goal_heading;
    options_.pose_timeout = options.pose_timeout;
  } catch (const std::invalid_argument& e) {
    ROS_ERROR("controller_node: reconfiguration refused: %s", e.what());
    config.pose_timeout = options_.pose_timeout;  // dynamic_reconfigure reports the values kept
    config.goal_tolerance = options_.controller.goal_tolerance;
    return;
  }
  ROS_INFO("controller_node: reconfigured: v_max %.2f m/s, w_max %.2f rad/s, epsilon %.2f m, pose_timeout %.2f s",
           p.max_linear_velocity, p.max_angular_velocity, p.goal_tolerance, options.pose_timeout);
}

}  // namespace homography_teach_repeat
