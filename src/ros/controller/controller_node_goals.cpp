// ControllerNode and the repeat_route action (docs/nodes/controller_node.md): a goal loads its
// route into a new follower, a preempted goal stops the robot.
#include "homography_teach_repeat/ros/controller_node.h"

#include <geometry_msgs/Twist.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "homography_teach_repeat/PlanWay.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

void ControllerNode::startRoute(const std::string& directory, const RouteFollowerOptions& options) {
  if (directory.empty()) throw std::runtime_error("no route directory (goal and ~route_directory are empty)");
  const auto route = loadRoute(directory);
  if (!route) throw std::runtime_error(route.status().message());
  std::vector<Pose2D> goals;
  for (const auto& k : route->keyframes) goals.push_back(k.pose);
  startFollowing(goals, options, "route '" + directory + "'");
}

void ControllerNode::startFollowing(const std::vector<Pose2D>& goals, const RouteFollowerOptions& options,
                                    const std::string& what) {
  try {
    RouteFollower follower(goals, options);
    std::lock_guard<std::mutex> lock(mutex_);
    follower_.emplace(std::move(follower));
    last_output_ = FollowOutput();
    stopped_since_ = -1.0;
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(what + ": " + e.what());
  }
}

void ControllerNode::abortGoal(const std::string& reason) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    follower_.reset();
  }
  pending_destination_.clear();
  command_publisher_.publish(geometry_msgs::Twist());
  publishState("idle: goal aborted: " + reason);
  ROS_ERROR("controller_node: repeat_route aborted: %s", reason.c_str());
  RepeatRouteResult result;
  result.reached = false;
  result.reason = reason;
  result.progress = 100.0 * last_output_.progress;
  if (action_server_->isActive()) action_server_->setAborted(result, result.reason);
}

void ControllerNode::planWay(const ros::Time& now) {
  const double waited = (now - destination_since_).toSec();
  RepeatRouteFeedback feedback;
  feedback.goal_index = -1;
  feedback.reference_index = -1;
  feedback.state = relocalizing_ ? "searching" : "waiting";
  if (now < next_plan_) {
    // Between two questions: stand, or turn in place so that the camera sees more of the map.
    geometry_msgs::Twist command;
    if (relocalizing_) command.angular.z = relocalization_turn_speed_;
    command_publisher_.publish(command);
    feedback.reason = plan_reason_;
    action_server_->publishFeedback(feedback);
    return;
  }
  next_plan_ = now + ros::Duration(plan_retry_period_);
  command_publisher_.publish(geometry_msgs::Twist());  // the call may take a while: standing
  PlanWay plan;
  plan.request.destination = pending_destination_;
  if (!plan_way_client_.exists() || !plan_way_client_.call(plan)) {
    plan_reason_ = "no answer from the service " + plan_way_client_.getService() +
                   " (repeat_node with map_directory, remapped to plan_way)";
    relocalizing_ = false;
    if (waited > stop_abort_timeout_) abortGoal(plan_reason_);
    else publishState("waiting: " + plan_reason_);
    return;
  }
  const PlanWay::Response& way = plan.response;
  if (way.outcome == PlanWay::Response::NOT_PLACED) {
    relocalizing_ = true;
    plan_reason_ = way.reason;
    if (waited > relocalization_timeout_) {
      abortGoal("no place within relocalization_timeout (" + std::to_string(relocalization_timeout_) + " s): " + way.reason);
    } else {
      publishState("searching: " + way.reason);
    }
    return;
  }
  relocalizing_ = false;
  if (!way.success) {
    abortGoal("goal refused: " + way.reason);
    return;
  }
  std::vector<Pose2D> goals;
  for (const auto& pose : way.path.poses) {
    const auto planar = ros_conversions::toPose2D(pose.pose);
    if (!planar) {
      abortGoal("the planned way has a bad pose: " + planar.status().message());
      return;
    }
    goals.push_back(*planar);
  }
  RouteFollowerOptions options = options_;
  options.start_index = 0;
  options.end_index = -1;
  options.laps = 1;
  try {
    startFollowing(goals, options, "the way to " + pending_destination_);
  } catch (const std::exception& e) {
    abortGoal(e.what());
    return;
  }
  ROS_INFO("controller_node: %s", way.reason.c_str());
  way_junctions_ = way.junctions_crossed;
  pending_destination_.clear();
}

void ControllerNode::onGoal() {
  const auto goal = action_server_->acceptNewGoal();
  if (!goal->destination.empty()) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      follower_.reset();
    }
    pending_destination_ = goal->destination;
    way_junctions_ = 0;
    destination_since_ = ros::Time::now();
    next_plan_ = destination_since_;
    relocalizing_ = false;
    plan_reason_ = "asking repeat_node for the way";
    publishState("waiting: planning the way to " + pending_destination_);
    ROS_INFO("controller_node: repeat_route goal: to %s through the map of routes", pending_destination_.c_str());
    return;
  }
  pending_destination_.clear();
  way_junctions_ = 0;
  RouteFollowerOptions options = options_;
  options.start_index = goal->start_index;
  options.end_index = goal->end_index;
  options.laps = goal->laps == 0 ? 1 : goal->laps;
  const std::string directory = goal->route_directory.empty() ? default_directory_ : goal->route_directory;
  try {
    options.validate();
    startRoute(directory, options);
  } catch (const std::exception& e) {
    RepeatRouteResult result;
    result.reached = false;
    result.reason = std::string("goal refused: ") + e.what();
    ROS_ERROR("controller_node: %s", result.reason.c_str());
    action_server_->setAborted(result, result.reason);
    return;
  }
  ROS_INFO("controller_node: repeat_route goal: '%s' keyframes %d..%d, %d lap(s)", directory.c_str(),
           options.start_index, options.end_index, options.laps);
}

void ControllerNode::onPreempt() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    follower_.reset();
  }
  pending_destination_.clear();
  command_publisher_.publish(geometry_msgs::Twist());
  publishState("idle: goal preempted");
  RepeatRouteResult result;
  result.reached = false;
  result.reason = "preempted";
  result.progress = 100.0 * last_output_.progress;
  action_server_->setPreempted(result, result.reason);
}

}  // namespace homography_teach_repeat
