#include "homography_teach_repeat/route_follower.h"

#include <cmath>
#include <stdexcept>

namespace homography_teach_repeat {

std::string toString(FollowState state) {
  switch (state) {
    case FollowState::kWaiting: return "waiting";
    case FollowState::kFollowing: return "following";
    case FollowState::kStopped: return "stopped";
    case FollowState::kFinished: return "finished";
  }
  return "unknown";
}

void RouteFollowerOptions::validate() const {
  controller.validate();
  if (!std::isfinite(pose_timeout) || !(pose_timeout > 0.0)) {
    throw std::invalid_argument("pose_timeout must be finite and > 0");
  }
  if (start_index < 0) throw std::invalid_argument("start_index must be >= 0");
  if (laps < 1) throw std::invalid_argument("laps must be >= 1");
}

RouteFollower::RouteFollower(std::vector<Pose2D> goals, const RouteFollowerOptions& options)
    : goals_(std::move(goals)), options_(options), controller_(options.controller) {
  options_.validate();
  if (goals_.empty()) throw std::invalid_argument("the route has no keyframe to follow");
  const int last = options_.end_index < 0 ? static_cast<int>(goals_.size()) - 1 : options_.end_index;
  if (options_.start_index >= static_cast<int>(goals_.size()) ||
      last >= static_cast<int>(goals_.size()) || last < options_.start_index) {
    throw std::invalid_argument("start_index/end_index outside the route's " +
                                std::to_string(goals_.size()) + " keyframes");
  }
  for (int lap = 0; lap < options_.laps; ++lap) {
    for (int k = options_.start_index; k <= last; ++k) sequence_.push_back(k);
  }
}

void RouteFollower::setControllerParameters(const PotentialFieldParameters& parameters) {
  controller_.setParameters(parameters);
  options_.controller = parameters;
}

void RouteFollower::retune(const RouteFollowerOptions& options) {
  options.validate();
  setControllerParameters(options.controller);
  options_.pose_timeout = options.pose_timeout;
  options_.require_goal_heading = options.require_goal_heading;
}

Status RouteFollower::setFix(const Pose2D& pose, double stamp, double heading_offset) {
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw) ||
      !std::isfinite(stamp) || !std::isfinite(heading_offset)) {
    invalid_ = true;
    return Status(StatusCode::kInvalidInput, "localization fix is not finite: stopping");
  }
  invalid_ = false;
  lost_ = false;
  has_fix_ = true;
  pose_ = pose;
  stamp_ = stamp;
  heading_offset_ = heading_offset;
  return Status::ok();
}

void RouteFollower::setLost(const std::string& reason) {
  lost_ = true;
  lost_reason_ = reason;
}

FollowOutput RouteFollower::stop(FollowState state, const std::string& reason) {
  controller_.reset();
  FollowOutput out;
  out.state = state;
  out.reason = reason;
  out.goal_index = next_ < sequence_.size() ? sequence_[next_] : -1;
  out.lap = static_cast<int>(std::min(next_, sequence_.size() - 1) /
                             (sequence_.size() / static_cast<std::size_t>(options_.laps)));
  out.progress = static_cast<double>(next_) / static_cast<double>(sequence_.size());
  return out;
}

FollowOutput RouteFollower::update(double now, double dt,
                                   const std::vector<Eigen::Vector2d>& obstacles) {
  if (next_ >= sequence_.size()) return stop(FollowState::kFinished, "end of the route");
  if (!has_fix_) return stop(FollowState::kWaiting, "no localization yet");
  if (invalid_) return stop(FollowState::kStopped, "non-finite localization");
  if (lost_) return stop(FollowState::kStopped, "localization lost: " + lost_reason_);
  if (!std::isfinite(now) || now - stamp_ > options_.pose_timeout) {
    return stop(FollowState::kStopped, "localization older than pose_timeout (" +
                                           std::to_string(now - stamp_) + " s)");
  }
  // Goals reached (distance < ε; and heading within δ when required, paper 002 Fig. 8) are passed.
  auto reached = [&](const Pose2D& goal) {
    return options_.require_goal_heading
               ? goalReached(pose_, goal, options_.controller)
               : std::hypot(goal.x - pose_.x, goal.y - pose_.y) < options_.controller.goal_tolerance;
  };
  while (next_ < sequence_.size() && reached(goals_[static_cast<std::size_t>(sequence_[next_])])) {
    ++next_;
  }
  if (next_ >= sequence_.size()) return stop(FollowState::kFinished, "end of the route");
  const Pose2D& goal = goals_[static_cast<std::size_t>(sequence_[next_])];
  const double distance = std::hypot(goal.x - pose_.x, goal.y - pose_.y);
  const auto command =
      controller_.step(distance, goalBearing(pose_, goal, heading_offset_), obstacles, dt);
  if (!command) return stop(FollowState::kStopped, command.status().message());
  FollowOutput out;
  out.command = *command;
  out.state = FollowState::kFollowing;
  out.goal_index = sequence_[next_];
  out.lap = static_cast<int>(next_ / (sequence_.size() / static_cast<std::size_t>(options_.laps)));
  out.distance_to_goal = distance;
  out.progress = static_cast<double>(next_) / static_cast<double>(sequence_.size());
  return out;
}

}  // namespace homography_teach_repeat
