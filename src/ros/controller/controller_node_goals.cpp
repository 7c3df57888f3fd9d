// ControllerNode and the repeat_route action (docs/nodes/controller_node.md): a goal loads its
// route into a new follower, a preempted goal stops the robot.
#include "homography_teach_repeat/ros/controller_node.h"

#include <geometry_msgs/Twist.h>

#include <stdexcept>
#include <string>
#include <vector>

#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

void ControllerNode::startRoute(const std::string& directory, const RouteFollowerOptions& options) {
  if (directory.empty()) throw std::runtime_error("no route directory (goal and ~route_directory are empty)");
  const auto route = loadRoute(directory);
  if (!route) throw std::runtime_error(route.status().message());
  std::vector<Pose2D> goals;
  for (const auto& k : route->keyframes) goals.push_back(k.pose);
  try {
    RouteFollower follower(goals, options);
    std::lock_guard<std::mutex> lock(mutex_);
    follower_.emplace(std::move(follower));
    last_output_ = FollowOutput();
    stopped_since_ = -1.0;
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error(std::string("route '") + directory + "': " + e.what());
  }
}

void ControllerNode::onGoal() {
  const auto goal = action_server_->acceptNewGoal();
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
  command_publisher_.publish(geometry_msgs::Twist());
  publishState("idle: goal preempted");
  RepeatRouteResult result;
  result.reached = false;
  result.reason = "preempted";
  result.progress = 100.0 * last_output_.progress;
  action_server_->setPreempted(result, result.reason);
}

}  // namespace homography_teach_repeat
