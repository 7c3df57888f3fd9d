// Drives a differential base through a list of waypoints, for the scripted teach run of the
// simulator (the human with the joystick): turn in place towards the next waypoint when it is
// more than `turn_in_place_angle` off the heading, otherwise drive at `linear_speed` with a
// proportional heading correction, slowing down before the last waypoint.
#pragma once

#include <Eigen/Core>

#include <functional>
#include <vector>

#include "homography_teach_repeat/sim/differential_drive.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/control/potential_field_controller.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct WaypointDriverOptions {
  double linear_speed = 0.3;           // [m/s] > 0
  double angular_speed = 0.6;          // [rad/s] > 0, largest turn rate
  double heading_gain = 2.0;           // [1/s] > 0, turn rate per radian of heading error
  double position_tolerance = 0.05;    // [m] > 0, a waypoint is reached within this
  double turn_in_place_angle = 0.25;   // [rad] > 0
  // After the last waypoint, turn in place to final_yaw [rad] (within final_yaw_tolerance [rad]
  // > 0): a loop's teach run ends facing as it started, so the corner where the loop closes is
  // taught like the others (keyframes while turning there).
  bool turn_to_final_yaw = false;
  double final_yaw = 0.0;
  double final_yaw_tolerance = 0.02;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

class WaypointDriver {
 public:
  // Throws std::invalid_argument on invalid options, no waypoint or a non-finite waypoint.
  WaypointDriver(std::vector<Eigen::Vector2d> waypoints, const WaypointDriverOptions& options);

  // The command for the robot at `pose`; zero once the last waypoint is reached (or for a
  // non-finite pose).
  VelocityCommand update(const Pose2D& pose);
  bool finished() const { return next_ >= waypoints_.size() && (!options_.turn_to_final_yaw || aligned_); }
  std::size_t nextWaypoint() const { return next_; }

 private:
  std::vector<Eigen::Vector2d> waypoints_;
  WaypointDriverOptions options_;
  bool aligned_ = false;  // turned to final_yaw after the last waypoint
  std::size_t next_ = 0;
};

// The scripted drive without ROS (offline teach runs, test fixtures, the soak benchmark's camera
// stream): steps `robot` by `dt` [s] with `driver`'s commands computed from the robot's odometry
// until the driver finishes, and calls `on_frame(robot, t)` at simulated times t = 0,
// frame_period, 2 frame_period, ... (to within dt) before the step at t. Returns the first status
// of on_frame that is not ok; kInvalidInput for dt or frame_period not > 0 or a drive that does
// not finish within `max_duration` [s].
Status driveWaypoints(WaypointDriver& driver, DifferentialDriveSim& robot, double dt, double frame_period,
                      double max_duration,
                      const std::function<Status(const DifferentialDriveSim& robot, double t)>& on_frame);

}  // namespace homography_teach_repeat
