#include "homography_teach_repeat/control/route_follower.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace homography_teach_repeat {

std::string toString(FollowState state) {
  switch (state) {
    case FollowState::kWaiting: return "waiting";
    case FollowState::kFollowing: return "following";
    case FollowState::kStopped: return "stopped";
    case FollowState::kSearching: return "searching";
    case FollowState::kFinished: return "finished";
  }
  return "unknown";
}

void RouteFollowerOptions::validate() const {
  controller.validate();
  if (!std::isfinite(pose_timeout) || !(pose_timeout > 0.0)) {
    throw std::invalid_argument("pose_timeout must be finite and > 0");
  }
  if (!std::isfinite(odometry_timeout) || !(odometry_timeout > 0.0)) {
    throw std::invalid_argument("odometry_timeout must be finite and > 0");
  }
  if (!std::isfinite(carried_pose_timeout) || !(carried_pose_timeout > 0.0)) {
    throw std::invalid_argument("carried_pose_timeout must be finite and > 0");
  }
  if (start_index < 0) throw std::invalid_argument("start_index must be >= 0");
  if (laps < 1) throw std::invalid_argument("laps must be >= 1");
  auto positive = [](double value, const char* name) {
    if (!std::isfinite(value) || !(value > 0.0)) {
      throw std::invalid_argument(std::string(name) + " must be finite and > 0");
    }
  };
  if (!std::isfinite(closed_route_gap) || closed_route_gap < 0.0) {
    throw std::invalid_argument("closed_route_gap must be finite and >= 0");
  }
  positive(corner_radius, "corner_radius");
  positive(corner_tolerance, "corner_tolerance");
  if (!std::isfinite(turn_in_place_angle) || turn_in_place_angle < 0.0 || turn_in_place_angle > M_PI) {
    throw std::invalid_argument("turn_in_place_angle must be in [0, pi]");
  }
  if (!std::isfinite(turn_in_place_exit_angle) || turn_in_place_exit_angle < 0.0 ||
      turn_in_place_exit_angle > turn_in_place_angle) {
    throw std::invalid_argument("turn_in_place_exit_angle must be in [0, turn_in_place_angle]");
  }
  if (!std::isfinite(corner_deceleration) || corner_deceleration < 0.0 ||
      corner_deceleration > controller.max_linear_acceleration) {
    throw std::invalid_argument("corner_deceleration must be in [0, max_linear_acceleration]");
  }
  positive(final_approach_distance, "final_approach_distance");
  positive(final_goal_tolerance, "final_goal_tolerance");
  positive(final_approach_gain, "final_approach_gain");
  positive(final_turn_gain, "final_turn_gain");
  positive(final_heading_tolerance, "final_heading_tolerance");
  if (!(final_turn_angle > 0.0 && final_turn_angle <= M_PI)) {
    throw std::invalid_argument("final_turn_angle must be in (0, pi]");
  }
  if (!(degraded_speed_factor > 0.0 && degraded_speed_factor <= 1.0)) {
    throw std::invalid_argument("degraded_speed_factor must be in (0, 1]");
  }
  if (!std::isfinite(robot_radius) || robot_radius < 0.0) throw std::invalid_argument("robot_radius must be >= 0");
  if (!std::isfinite(obstacle_stop_gap) || obstacle_stop_gap < 0.0) {
    throw std::invalid_argument("obstacle_stop_gap must be finite and >= 0");
  }
  if (!std::isfinite(obstacle_slow_gap) || !(obstacle_slow_gap > obstacle_stop_gap)) {
    throw std::invalid_argument("obstacle_slow_gap must be finite and > obstacle_stop_gap");
  }
  if (!std::isfinite(pass_offset) || pass_offset < 0.0) throw std::invalid_argument("pass_offset must be finite and >= 0");
  if (!std::isfinite(pass_clearance) || pass_clearance < 0.0) {
    throw std::invalid_argument("pass_clearance must be finite and >= 0");
  }
  positive(pass_lookahead, "pass_lookahead");
  if (!std::isfinite(lost_search_delay) || lost_search_delay < 0.0) {
    throw std::invalid_argument("lost_search_delay must be finite and >= 0");
  }
  if (!std::isfinite(lost_search_angle) || lost_search_angle < 0.0 || lost_search_angle > M_PI) {
    throw std::invalid_argument("lost_search_angle must be in [0, pi]");
  }
  positive(lost_search_velocity, "lost_search_velocity");
  if (!std::isfinite(straight_leg_angle) || straight_leg_angle < 0.0 || straight_leg_angle > M_PI / 2) {
    throw std::invalid_argument("straight_leg_angle must be in [0, pi/2]");
  }
}

RouteFollower::RouteFollower(std::vector<Pose2D> goals, const RouteFollowerOptions& options)
    : goals_(std::move(goals)), options_(options), controller_(options.controller) {
  options_.validate();
  // Enough odometry for a fix as old as it may be, interpolated across any gap within it.
  const double odometry_kept = options_.carried_pose_timeout + 1.0;
  odometry_ = OdometryBuffer(odometry_kept, odometry_kept);
  if (goals_.empty()) throw std::invalid_argument("the route has no keyframe to follow");
  const int last = options_.end_index < 0 ? static_cast<int>(goals_.size()) - 1 : options_.end_index;
  if (options_.start_index >= static_cast<int>(goals_.size()) ||
      last >= static_cast<int>(goals_.size()) || last < options_.start_index) {
    throw std::invalid_argument("start_index/end_index outside the route's " +
                                std::to_string(goals_.size()) + " keyframes");
  }
  const int count = static_cast<int>(goals_.size());
  if (options_.return_to_start && options_.start_index > 0 && last == count - 1 &&
      isClosedLoop(goals_, options_.closed_route_gap)) {
    // A loop: every lap runs through all keyframes from start_index round to the keyframe the
    // robot started at (start_index − 1), including the keyframe between the last and the first.
    for (int lap = 0; lap < options_.laps; ++lap) {
      for (int i = 0; i < count; ++i) sequence_.push_back((options_.start_index + i) % count);
    }
    goals_per_lap_ = static_cast<std::size_t>(count);
  } else {
    for (int lap = 0; lap < options_.laps; ++lap) {
      for (int k = options_.start_index; k <= last; ++k) sequence_.push_back(k);
    }
    const int goals_per_lap = last - options_.start_index + 1;
    goals_per_lap_ = static_cast<std::size_t>(goals_per_lap);
  }
}

int RouteFollower::lapOf(std::size_t position) const {
  return static_cast<int>(std::min(position / goals_per_lap_, static_cast<std::size_t>(options_.laps - 1)));
}

void RouteFollower::setControllerParameters(const PotentialFieldParameters& parameters) {
  parameters.validate();
  options_.controller = parameters;
  applyTrustToLimits();
}

void RouteFollower::applyTrustToLimits() {
  PotentialFieldParameters limits = options_.controller;
  if (trust_ == PoseTrust::kDegraded) {
    limits.max_linear_velocity *= options_.degraded_speed_factor;
    limits.max_angular_velocity *= options_.degraded_speed_factor;
  }
  controller_.setParameters(limits);
}

void RouteFollower::setTrust(PoseTrust trust, const std::string& reason, double stamp, bool search_helps) {
  if (!std::isfinite(stamp) || stamp < trust_stamp_) return;
  trust_stamp_ = stamp;
  trust_reason_ = reason;
  search_helps_ = search_helps;
  if (trust == PoseTrust::kLost && trust_ != PoseTrust::kLost) lost_since_ = stamp;
  if (trust != PoseTrust::kLost) lost_since_ = std::numeric_limits<double>::quiet_NaN();
  const bool limits_change = (trust == PoseTrust::kDegraded) != (trust_ == PoseTrust::kDegraded);
  trust_ = trust;
  if (limits_change) applyTrustToLimits();
}

FollowOutput RouteFollower::searchInPlace(double now, double dt) {
  const std::string why = "integrity LOST (" + trust_reason_ + ")";
  const double lost_for = std::isfinite(lost_since_) && std::isfinite(now) ? now - lost_since_ : 0.0;
  const RouteFollowerOptions& o = options_;
  if (!(o.lost_search_angle > 0.0) || !search_helps_ || lost_for < o.lost_search_delay) {
    return stop(FollowState::kStopped, why + ": standing");
  }
  // A triangle wave in angle: +A, back through the start to −A, back to the start, ...
  const double quarter = o.lost_search_angle / o.lost_search_velocity;  // [s] from 0 to ±A
  const double phase = std::fmod(lost_for - o.lost_search_delay, 4.0 * quarter);
  const double direction = phase < quarter || phase >= 3.0 * quarter ? 1.0 : -1.0;
  const auto command = controller_.track(0.0, direction * o.lost_search_velocity, dt);
  if (!command) return stop(FollowState::kStopped, why + ": " + command.status().message());
  FollowOutput out = report(FollowState::kSearching, why + ": turning in place to look for a taught view");
  out.command.linear = 0.0;  // never a linear motion on a pose it does not trust
  out.command.angular = command->angular;
  return out;
}

void RouteFollower::retune(const RouteFollowerOptions& options) {
  options.validate();
  setControllerParameters(options.controller);
  // Everything but the goal sequence, which was unrolled at construction.
  const RouteFollowerOptions kept = options_;
  options_ = options;
  options_.start_index = kept.start_index;
  options_.end_index = kept.end_index;
  options_.laps = kept.laps;
  options_.return_to_start = kept.return_to_start;
  options_.closed_route_gap = kept.closed_route_gap;
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
  fix_ = pose;
  pose_ = pose;
  stamp_ = stamp;
  heading_offset_ = heading_offset;
  return Status::ok();
}

Status RouteFollower::addOdometry(const Pose2D& odometry, double stamp) {
  return odometry_.add(stamp, odometry);
}

Pose2D RouteFollower::currentPose(double now, double* limit) const {
  *limit = options_.pose_timeout;
  if (odometry_.empty() || !(now - odometry_.newestStamp() <= options_.odometry_timeout)) return fix_;
  const auto at_fix = odometry_.poseAt(stamp_);
  const auto newest = odometry_.poseAt(odometry_.newestStamp());
  if (!at_fix || !newest) return fix_;
  *limit = std::max(options_.pose_timeout, options_.carried_pose_timeout);
  // The fix composed with the odometry's motion since its image (both in the robot's own frame).
  return fix_.compose(at_fix->inverse().compose(*newest));
}

void RouteFollower::setLost(const std::string& reason, double stamp) {
  if (has_fix_ && stamp <= stamp_) return;
  lost_ = true;
  lost_reason_ = reason;
}

FollowOutput RouteFollower::stop(FollowState state, const std::string& reason) {
  controller_.reset();
  return report(state, reason);
}

FollowOutput RouteFollower::report(FollowState state, const std::string& reason) const {
  FollowOutput out;
  out.state = state;
  out.reason = reason;
  out.goal_index = next_ < sequence_.size() ? sequence_[next_] : -1;
  out.lap = lapOf(std::min(next_, sequence_.size() - 1));
  out.progress = static_cast<double>(next_) / static_cast<double>(sequence_.size());
  return out;
}

FollowOutput RouteFollower::update(double now, double dt,
                                   const std::vector<Eigen::Vector2d>& obstacles) {
  if (next_ >= sequence_.size()) return stop(FollowState::kFinished, "end of the route");
  if (!has_fix_) return stop(FollowState::kWaiting, "no localization yet");
  if (invalid_) return stop(FollowState::kStopped, "non-finite localization");
  if (trust_ == PoseTrust::kLost) return searchInPlace(now, dt);
  if (lost_) return stop(FollowState::kStopped, "localization lost: " + lost_reason_);
  double age_limit = options_.pose_timeout;
  pose_ = currentPose(now, &age_limit);
  if (!std::isfinite(now) || now - stamp_ > age_limit) {
    return stop(FollowState::kStopped, std::string("localization older than ") +
                                           (age_limit > options_.pose_timeout ? "carried_pose_timeout" : "pose_timeout") +
                                           " (" + std::to_string(now - stamp_) + " s)");
  }
  // Goals reached (distance < ε; and heading within δ when required, paper 002 Fig. 8) are passed;
  // the last one has its own test (finalApproach).
  auto reached = [&](std::size_t position) {
    const Pose2D& goal = goals_[static_cast<std::size_t>(sequence_[position])];
    const bool near = std::hypot(goal.x - pose_.x, goal.y - pose_.y) < toleranceOf(position);
    return near && (!options_.require_goal_heading ||
                    std::abs(wrapToPi(goal.yaw - pose_.yaw)) < options_.controller.goal_heading_tolerance);
  };
  while (next_ + 1 < sequence_.size() && reached(next_)) {
    if (isCorner(next_)) passed_corner_ = true;
    ++next_;
  }
  const Pose2D& goal = goals_[static_cast<std::size_t>(sequence_[next_])];
  const double distance = std::hypot(goal.x - pose_.x, goal.y - pose_.y);
  // Whatever drives the robot forward is capped for what stands in the corridor ahead (along the
  // lane while passing beside something).
  std::optional<Lane> lane;
  auto go = [&](double to_goal) {
    std::string blocked;
    const double speed_cap = obstacleSpeedLimit(obstacles, lane ? &*lane : nullptr, &blocked);
    if (blocked.empty() && lane) blocked = "passing beside something in the way";
    return following(controller_.capLinearVelocity(speed_cap), to_goal, blocked);
  };
  if (next_ + 1 == sequence_.size() && (at_final_position_ || distance < options_.final_approach_distance)) {
    const auto command = finalApproach(goal, distance, dt);
    if (!command) {
      next_ = sequence_.size();
      return stop(FollowState::kFinished, "end of the route");
    }
    if (!*command) return stop(FollowState::kStopped, command->status().message());
    return go(distance);
  }
  // Something beside the route in the way: pure pursuit of a point pass_lookahead ahead on the free
  // lane (the potential field turns far too gently for a lane change, and its repulsion would hold
  // the robot back beside what it passes; the corridor cap still guards the lane). The turn in
  // place looks at the lane's target then: the next goal, on the route's line, may be more than
  // turn_in_place_angle off a robot driving beside it, while one leaving a corner on a lane must
  // still turn in place first (it drove a loop of 0.4 m round the room's north-east corner).
  lane = passingLane(obstacles);
  std::optional<Eigen::Vector2d> lane_target;
  if (lane) {
    lane_target = lane->origin + (lane->robot_along + options_.pass_lookahead) * lane->along + lane->offset * lane->left;
  }
  const double bearing =
      goalBearing(pose_, lane_target ? Pose2D(lane_target->x(), lane_target->y(), 0.0) : goal, heading_offset_);
  // Leaving a corner (a goal where the teach run turned in place was passed since the robot last
  // drove on), a turn in place goes on until the bearing is within turn_in_place_exit_angle; elsewhere (a goal close ahead seen
  // from a few centimetres beside the line) it stops at turn_in_place_angle.
  const bool exit_at_corner = turning_in_place_ && passed_corner_;
  turning_in_place_ = options_.turn_in_place_angle > 0.0 &&
                      std::abs(bearing) > (exit_at_corner ? options_.turn_in_place_exit_angle : options_.turn_in_place_angle);
  if (!turning_in_place_) passed_corner_ = false;
  if (turning_in_place_) {
    const auto command = controller_.track(0.0, options_.final_turn_gain * bearing, dt);
    if (!command) return stop(FollowState::kStopped, command.status().message());
    return go(distance);
  }
  if (lane) {
    // The arc to the target, κ = 2 sin α / L, at the speed the robot has (the corridor cap may hold
    // it below the limit; ω for the limit would then turn it far more sharply than the arc).
    const double v_max = options_.controller.max_linear_velocity;
    const double curvature = 2.0 * std::sin(bearing) / options_.pass_lookahead;
    const double v_now = std::max(controller_.state().linear, kArcSpeedFloor * v_max);
    const auto command = controller_.track(v_max, curvature * v_now, dt);
    if (!command) return stop(FollowState::kStopped, command.status().message());
    return go(distance);
  }
  const auto command = controller_.step(attractionDistance(next_, distance), bearing, obstacles, dt);
  if (!command) return stop(FollowState::kStopped, command.status().message());
  return go(distance);
}

double RouteFollower::straightRunAfter(std::size_t position) const {
  if (!(options_.straight_leg_angle > 0.0) || position == 0) return 0.0;
  auto at = [&](std::size_t p) {
    const Pose2D& g = goals_[static_cast<std::size_t>(sequence_[p])];
    return Eigen::Vector2d(g.x, g.y);
  };
  Eigen::Vector2d direction = at(position) - at(position - 1);
  if (direction.norm() < options_.corner_radius) return 0.0;
  double run = 0.0;
  // Far enough for the attraction's saturation: nothing beyond it changes the force.
  const double enough = options_.controller.attraction_saturation;
  for (std::size_t q = position; q + 1 < sequence_.size() && run < enough; ++q) {
    const Eigen::Vector2d segment = at(q + 1) - at(q);
    if (segment.norm() < options_.corner_radius) break;  // a turn in place
    const double turn = std::atan2(direction.x() * segment.y() - direction.y() * segment.x(), direction.dot(segment));
    if (std::abs(turn) > options_.straight_leg_angle) break;
    run += segment.norm();
    direction = segment;
  }
  return run;
}

double RouteFollower::attractionDistance(std::size_t position, double distance) const {
  const double run = straightRunAfter(position);
  if (run > 0.0 || !(options_.corner_deceleration > 0.0)) return distance + run;
  // The field settles at v = k_a D / 2b (below the saturation); the robot stops from
  // sqrt(2 a d) within d at deceleration a. The field's first-order lag (1/2b) keeps the robot
  // a little faster than that as it brakes; the turn in place at corner_tolerance stops it.
  const PotentialFieldParameters& p = options_.controller;
  const double braking = 2.0 * p.viscous_friction * std::sqrt(2.0 * options_.corner_deceleration * distance) /
                         p.attractive_gain;
  return std::max(distance, braking);
}

bool RouteFollower::isCorner(std::size_t position) const {
  if (position + 1 >= sequence_.size()) return false;
  const Pose2D& goal = goals_[static_cast<std::size_t>(sequence_[position])];
  const Pose2D& next = goals_[static_cast<std::size_t>(sequence_[position + 1])];
  return std::hypot(next.x - goal.x, next.y - goal.y) < options_.corner_radius;
}

double RouteFollower::toleranceOf(std::size_t position) const {
  return isCorner(position) ? std::min(options_.corner_tolerance, options_.controller.goal_tolerance)
                            : options_.controller.goal_tolerance;
}

FollowOutput RouteFollower::following(const VelocityCommand& command, double distance,
                                      const std::string& reason) const {
  FollowOutput out;
  out.command = command;
  out.state = FollowState::kFollowing;
  out.goal_index = sequence_[next_];
  out.lap = lapOf(next_);
  out.distance_to_goal = distance;
  out.progress = static_cast<double>(next_) / static_cast<double>(sequence_.size());
  if (trust_ == PoseTrust::kDegraded) out.reason = "slowed down: integrity DEGRADED (" + trust_reason_ + ")";
  if (!reason.empty()) out.reason = out.reason.empty() ? reason : out.reason + "; " + reason;
  return out;
}

std::optional<Expected<VelocityCommand>> RouteFollower::finalApproach(const Pose2D& goal, double distance,
                                                                      double dt) {
  const RouteFollowerOptions& o = options_;
  // Hysteresis: a new fix a little off the point does not restart the approach.
  if (distance < o.final_goal_tolerance) at_final_position_ = true;
  if (distance > 2.0 * o.final_goal_tolerance) at_final_position_ = false;
  if (at_final_position_) {
    const double heading_error = wrapToPi(goal.yaw - pose_.yaw - heading_offset_);
    if (!o.align_final_heading || std::abs(heading_error) < o.final_heading_tolerance) return std::nullopt;
    return controller_.track(0.0, o.final_turn_gain * heading_error, dt);
  }
  const double bearing = goalBearing(pose_, goal, heading_offset_);
  if (std::abs(bearing) > o.final_turn_angle) return controller_.track(0.0, o.final_turn_gain * bearing, dt);
  return controller_.track(o.final_approach_gain * distance * std::cos(bearing), o.final_turn_gain * bearing, dt);
}

}  // namespace homography_teach_repeat
