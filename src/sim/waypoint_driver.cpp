#include "homography_teach_repeat/sim/waypoint_driver.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {

void WaypointDriverOptions::validate() const {
  const std::pair<const char*, double> fields[] = {{"linear_speed", linear_speed},
                                                   {"angular_speed", angular_speed},
                                                   {"heading_gain", heading_gain},
                                                   {"position_tolerance", position_tolerance},
                                                   {"turn_in_place_angle", turn_in_place_angle},
                                                   {"final_yaw_tolerance", final_yaw_tolerance}};
  for (const auto& [name, value] : fields) {
    if (!std::isfinite(value) || !(value > 0.0)) {
      throw std::invalid_argument(std::string("waypoint driver: ") + name + " must be > 0");
    }
  }
  if (!std::isfinite(final_yaw)) throw std::invalid_argument("waypoint driver: final_yaw must be finite");
}

WaypointDriver::WaypointDriver(std::vector<Eigen::Vector2d> waypoints, const WaypointDriverOptions& options)
    : waypoints_(std::move(waypoints)), options_(options) {
  options_.validate();
  if (waypoints_.empty()) throw std::invalid_argument("waypoint driver: no waypoints");
  for (const auto& w : waypoints_) {
    if (!w.allFinite()) throw std::invalid_argument("waypoint driver: non-finite waypoint");
  }
}

VelocityCommand WaypointDriver::update(const Pose2D& pose) {
  VelocityCommand command;
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw)) return command;
  while (next_ < waypoints_.size() &&
         (waypoints_[next_] - Eigen::Vector2d(pose.x, pose.y)).norm() < options_.position_tolerance) {
    ++next_;
  }
  if (finished()) return command;
  if (next_ >= waypoints_.size()) {  // the final turn in place
    const double error = wrapToPi(options_.final_yaw - pose.yaw);
    if (std::abs(error) < options_.final_yaw_tolerance) {
      aligned_ = true;
      return command;
    }
    command.angular = std::clamp(options_.heading_gain * error, -options_.angular_speed, options_.angular_speed);
    return command;
  }
  const Eigen::Vector2d to_goal = waypoints_[next_] - Eigen::Vector2d(pose.x, pose.y);
  const double error = wrapToPi(std::atan2(to_goal.y(), to_goal.x()) - pose.yaw);
  command.angular = std::clamp(options_.heading_gain * error, -options_.angular_speed, options_.angular_speed);
  if (std::abs(error) > options_.turn_in_place_angle) return command;  // turn in place first
  const bool last = next_ + 1 == waypoints_.size();
  const double speed = last ? std::min(options_.linear_speed, 0.5 * to_goal.norm() + 0.02) : options_.linear_speed;
  command.linear = speed * std::cos(error);
  return command;
}

Status driveWaypoints(WaypointDriver& driver, DifferentialDriveSim& robot, double dt, double frame_period,
                      double max_duration,
                      const std::function<Status(const DifferentialDriveSim& robot, double t)>& on_frame) {
  if (!(dt > 0.0) || !(frame_period > 0.0) || !std::isfinite(dt) || !std::isfinite(frame_period)) {
    return Status(StatusCode::kInvalidInput, "driveWaypoints: dt and frame_period must be finite and > 0");
  }
  const auto steps = static_cast<long>(std::min(max_duration / dt, 1e9));
  long frames = 0;
  for (long step = 0; step <= steps; ++step) {
    if (driver.finished()) return Status::ok();
    const double t = static_cast<double>(step) * dt;
    // Frame k is due at k * frame_period; the step nearest to it (from below by half a step) takes it.
    if (t + 0.5 * dt >= static_cast<double>(frames) * frame_period) {
      Status status = on_frame(robot, t);
      if (!status.isOk()) return status;
      ++frames;
    }
    const VelocityCommand command = driver.update(robot.odometry());
    robot.step(command.linear, command.angular, dt);
  }
  return Status(StatusCode::kInvalidInput,
                "driveWaypoints: the drive did not finish within " + std::to_string(max_duration) + " s");
}

}  // namespace homography_teach_repeat
