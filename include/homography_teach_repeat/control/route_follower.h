// Following a taught route with the potential-field controller (paper 002 §5): the goals are the
// keyframe positions in order (optionally several laps); the robot pose comes from the repeat
// phase's localization, carried forward from the instant of its image to now on the wheel
// odometry (addOdometry; an image is 50-150 ms old when its pose arrives, docs/controller.md), and
// every condition that makes it untrustworthy stops the robot: no fix yet, a fix older than
// `pose_timeout` (`carried_pose_timeout` while odometry carries it), lost tracking, a non-finite
// input. At the end of the route the command is zero and the follower reports finished.
#pragma once

#include <Eigen/Core>

#include <limits>

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/geometry/odometry_buffer.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/control/potential_field_controller.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

enum class FollowState { kWaiting, kFollowing, kStopped, kSearching, kFinished };
// How far the localization's pose can be trusted (repeat_node's ~integrity; the control module
// has its own enum: it depends on geometry only).
enum class PoseTrust { kOk, kDegraded, kLost };
std::string toString(FollowState state);

struct RouteFollowerOptions {
  PotentialFieldParameters controller;
  double pose_timeout = 0.5;  // [s] a fix older than this stops the robot (no odometry to carry it)
  // With odometry (addOdometry) no older than odometry_timeout [s], the fix is carried from its
  // stamp to now on the odometry's increment and stops the robot only when older than
  // carried_pose_timeout [s, > 0; pose_timeout when smaller]: a late pose is still a pose of where
  // the robot is.
  double odometry_timeout = 0.2;
  double carried_pose_timeout = 1.0;
  int start_index = 1;        // first goal keyframe (the robot starts at keyframe 0)
  int end_index = -1;         // last goal keyframe (-1: the last one)
  int laps = 1;               // closed routes: goals start_index..end_index repeated
  // A goal is passed within goal_tolerance (ε). Paper 002's second test, the heading within
  // goal_heading_tolerance (δ) of the keyframe's, decides whether the images can be matched; the
  // attraction has no orientation term, so requiring it for the goal would make a robot that
  // arrives at a corner from the previous side circle there. Off by default.
  bool require_goal_heading = false;
  // Closed routes (at least 3 keyframes, the last within closed_route_gap [m] of the first,
  // end_index the last): every lap runs round all keyframes from start_index to the keyframe
  // before it, where the robot started, so each lap (and the run) ends where it began and the
  // corner between the route's last and first keyframes is followed like any other. Not for
  // start_index 0 (the route's own last keyframe ends it).
  bool return_to_start = true;
  double closed_route_gap = 1.0;
  // Corners. Where the teach run turned in place (the next keyframe within corner_radius [m] of
  // the goal), the goal is reached within corner_tolerance [m] instead of ε, so the robot turns
  // where the route turns instead of cutting the corner at ε and swinging wide (found in the
  // simulator: at 0.4 m it overshot by 0.3 m into views never taught, and vision went wrong there).
  // A goal more than turn_in_place_angle [rad] off the robot's heading is turned to in place
  // (w = final_turn_gain · bearing) instead of by the force direction of eq. (3) (0: never); leaving
  // a corner, until it is within turn_in_place_exit_angle [rad, 0..turn_in_place_angle]: the force direction turns
  // the rest far too gently (0.04 rad/s for 12°), and leaving a corner 29° off the next leg the
  // robot drove 15 cm beside it and crept to the next corner (docs/nodes/controller_node.md).
  double corner_radius = 0.05;
  double corner_tolerance = 0.15;
  double turn_in_place_angle = 0.5;
  double turn_in_place_exit_angle = 0.1;
  // Straight legs. The attraction of eq. (3) grows with the distance to the goal, and keyframes
  // are close (0.5 m with ε 0.4 m in the demo: the robot averaged half its speed limit on straights).
  // The distance the attraction sees is the goal's plus the route's length beyond it while the
  // route stays within straight_leg_angle [rad] of straight (no turn in place): the robot keeps
  // its speed along a straight leg and slows down where the route turns or ends. 0: the goal's
  // distance alone (paper 002).
  double straight_leg_angle = 0.35;
  // Where the drive ends (a corner, a bend beyond straight_leg_angle), the attraction of eq. (3)
  // falls in proportion to the distance: the robot settles at k_a d / 2b, 0.1 m/s 0.2 m before
  // the corner, and crawled most of the last metre of every leg. With corner_deceleration [m/s²,
  // 0..max_linear_acceleration] > 0 the attraction sees at least the distance at which its
  // steady speed is the one from which the robot stops at that deceleration, sqrt(2 a d) (0: the
  // paper's field all the way; docs/nodes/controller_node.md "Corners").
  double corner_deceleration = 0.3;
  // The end of the run. Paper 002's robot stops once within ε of the last keyframe; here the last
  // goal is approached within final_approach_distance [m] with a go-to-point law (turn in place
  // while the goal's bearing exceeds final_turn_angle [rad]; otherwise v = final_approach_gain ·
  // distance, w = final_turn_gain · bearing) until it is within final_goal_tolerance [m], then
  // (align_final_heading) the robot turns in place to the keyframe's heading within
  // final_heading_tolerance [rad]: the pose the route ends with, not just a point near it.
  double final_approach_distance = 1.0;
  double final_goal_tolerance = 0.05;
  double final_turn_angle = 0.5;
  double final_approach_gain = 0.5;  // [1/s]
  double final_turn_gain = 1.5;      // [1/s]
  bool align_final_heading = true;
  double final_heading_tolerance = 0.02;
  // Integrity (setTrust): a DEGRADED pose caps the linear and angular velocity at
  // degraded_speed_factor (0, 1] of the limits; a LOST one stops the robot, and after
  // lost_search_delay [s, >= 0] of LOST it turns in place to look for a taught view: lost_search_angle
  // [rad, >= 0; 0: it stands] to each side of where it stopped at lost_search_velocity [rad/s, > 0]
  // (timed, not steered by the pose it does not trust; never a linear motion).
  double degraded_speed_factor = 0.5;
  double lost_search_delay = 1.0;
  double lost_search_angle = 0.6;
  double lost_search_velocity = 0.3;
  // Something in the way (a person, a box; the obstacle points of update()): in the corridor
  // ahead of the base as wide as 2 robot_radius [m, > 0] (along the lane while passing beside, see
  // below), the forward velocity is capped at
  // max_linear_velocity · (gap − obstacle_stop_gap) / (obstacle_slow_gap − obstacle_stop_gap),
  // clamped to [0, 1], where gap is the free distance in front of the robot's radius [m]: the robot
  // slows down, stops obstacle_stop_gap [m, >= 0] short of it and waits (turning is still allowed),
  // and drives on once it has gone. obstacle_slow_gap [m] > obstacle_stop_gap; robot_radius 0:
  // off. The repulsion of eq. (3) still acts besides.
  double robot_radius = 0.3;
  double obstacle_stop_gap = 0.25;
  double obstacle_slow_gap = 0.8;
  // Passing beside (docs/nodes/controller_node.md): where something stands in the way on a
  // straight stretch but leaves a lane within pass_offset [m, >= 0; 0: never, the robot waits] of
  // the route's line, the robot aims along that lane, pass_clearance [m, >= 0] beyond its radius
  // from everything beside it, until it has passed, then comes back to the line. The lane nearest
  // the line wins; the side chosen is kept while it stays free.
  // It drives onto the lane by pure pursuit of the lane's point pass_lookahead [m, > 0] ahead.
  double pass_offset = 0.25;
  double pass_clearance = 0.1;
  double pass_lookahead = 0.6;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct FollowOutput {
  VelocityCommand command;  // zero unless kFollowing
  FollowState state = FollowState::kWaiting;
  std::string reason;       // why the robot stopped or waits
  int goal_index = -1;      // keyframe index of the current goal
  int lap = 0;
  double distance_to_goal = 0.0;
  double progress = 0.0;    // goals reached / goals in the run, [0, 1]
};

class RouteFollower {
 public:
  // `goals`: keyframe poses of base_link in the route frame. Throws std::invalid_argument on bad
  // options or an empty route.
  RouteFollower(std::vector<Pose2D> goals, const RouteFollowerOptions& options);

  // A localization fix: the robot pose in the route frame at `stamp` [s]; `heading_offset` is
  // the visual heading correction the force direction gets (0 when the pose already includes it).
  // kInvalidInput for non-finite values (the robot then stops at the next update).
  Status setFix(const Pose2D& pose, double stamp, double heading_offset = 0.0);
  // The wheel odometry (any fixed odom frame) at `stamp` [s], in increasing stamps: carries the fix
  // forward. kInvalidInput for non-finite values or a stamp not after the last (ignored).
  Status addOdometry(const Pose2D& odometry, double stamp);
  // Localization reported failure (lost tracking) for the frame at `stamp` [s]: stop until the next
  // good fix. Ignored when a fix at least as new has arrived already (repeat_node's mu mode still
  // publishes a pose for a frame without a heading fix, and the two topics may arrive in any order).
  void setLost(const std::string& reason, double stamp = std::numeric_limits<double>::infinity());
  // The integrity of the pose at `stamp` [s] with its reason (ignored when older than the last one).
  // `search_helps` false (the camera is silent): a LOST robot stands instead of turning to look.
  void setTrust(PoseTrust trust, const std::string& reason, double stamp, bool search_helps = true);

  // One control step at time `now` [s] with obstacle points in the robot frame.
  FollowOutput update(double now, double dt, const std::vector<Eigen::Vector2d>& obstacles = {});

  const PotentialFieldController& controller() const { return controller_; }
  void setControllerParameters(const PotentialFieldParameters& parameters);
  // Run-time tuning (dynamic_reconfigure): the controller parameters, pose_timeout,
  // require_goal_heading and the final approach of `options`; the goal sequence (start/end index,
  // laps, return_to_start) stays. Throws
  // std::invalid_argument naming the bad field and then changes nothing.
  void retune(const RouteFollowerOptions& options);
  const RouteFollowerOptions& options() const { return options_; }

 private:
  FollowOutput stop(FollowState state, const std::string& reason);  // zero command, controller at rest
  FollowOutput report(FollowState state, const std::string& reason) const;  // the output without a command
  FollowOutput following(const VelocityCommand& command, double distance, const std::string& reason = "") const;
  struct Lane;
  // The forward velocity cap for the obstacle points in the corridor ahead (robot_radius either
  // side of the arc the last command drives, or of `lane` while passing), and why.
  double obstacleSpeedLimit(const std::vector<Eigen::Vector2d>& obstacles, const Lane* lane, std::string* reason) const;
  // An arc's curvature is ω over v, v no less than this fraction of max_linear_velocity (a robot
  // starting from standstill): the corridor's arc, and the passing lane's pure pursuit.
  static constexpr double kArcSpeedFloor = 0.1;
  // The last goal: go-to-point, then the heading alignment. Empty optional = finished.
  std::optional<Expected<VelocityCommand>> finalApproach(const Pose2D& goal, double distance, double dt);
  int lapOf(std::size_t position) const;
  // LOST: the robot stands, then turns in place to each side (lost_search_*).
  FollowOutput searchInPlace(double now, double dt);
  // The controller's limits for the current trust (DEGRADED: scaled).
  void applyTrustToLimits();
  double toleranceOf(std::size_t position) const;
  // The teach run turned in place at the goal at `position` (the next one within corner_radius).
  bool isCorner(std::size_t position) const;
  // The route's length beyond the goal at `position` while it runs straight on (straight_leg_angle).
  double straightRunAfter(std::size_t position) const;
  // The distance the attraction sees towards the goal at `position`, `distance` [m] away: the
  // straight run beyond it added, or the braking distance for corner_deceleration.
  double attractionDistance(std::size_t position, double distance) const;
  // Passing beside (pass_offset): the route's line from the previous goal to the current one and
  // the lane along it to drive for these obstacle points (robot frame); none when the line is
  // free, when no lane within pass_offset is, or on a turn in place.
  struct Lane {
    Eigen::Vector2d origin, along, left;  // the previous goal, the line's direction, its left
    double robot_along = 0.0;             // [m] of the robot along the line
    double robot_lateral = 0.0;           // [m] of the robot from the line, + left
    double offset = 0.0;                  // [m] of the lane, + left
    // A world point's distance ahead of the robot along the line and its offset left of the line [m].
    Eigen::Vector2d coordinates(const Eigen::Vector2d& world) const {
      const Eigen::Vector2d d = world - origin;
      return Eigen::Vector2d(d.dot(along) - robot_along, d.dot(left));
    }
  };
  std::optional<Lane> passingLane(const std::vector<Eigen::Vector2d>& obstacles);
  // The fix carried to `now` on the odometry, or the fix itself; `limit`: the age allowed.
  Pose2D currentPose(double now, double* limit) const;

  std::vector<Pose2D> goals_;
  RouteFollowerOptions options_;
  PotentialFieldController controller_;
  std::vector<int> sequence_;  // goal keyframe indices for the whole run (laps unrolled)
  std::size_t goals_per_lap_ = 1;
  std::size_t next_ = 0;       // position in sequence_
  bool turning_in_place_ = false;   // until the bearing is within turn_in_place_exit_angle
  // A corner goal was passed since the robot last drove on: its turn in place goes on to
  // turn_in_place_exit_angle. (With ε 0.7 m the goals passed with the corner include the next
  // leg's first ones: "the goal just passed" was no longer the corner, and the robot left every
  // corner 0.3 rad off and bowed 0.2 m off the leg.)
  bool passed_corner_ = false;
  bool at_final_position_ = false;  // the last goal's position is reached: aligning the heading
  bool has_fix_ = false;
  bool lost_ = false;
  bool invalid_ = false;
  std::string lost_reason_;
  Pose2D fix_;     // the last fix, at stamp_
  Pose2D pose_;    // the pose this update works with (the fix carried to now)
  double stamp_ = 0.0;
  OdometryBuffer odometry_;  // the last carried_pose_timeout + 1 s, interpolated at the fix's stamp
  double heading_offset_ = 0.0;
  std::optional<double> pass_lane_;  // the lane passingLane() chose last [m]
  PoseTrust trust_ = PoseTrust::kOk;
  std::string trust_reason_;
  bool search_helps_ = true;
  double trust_stamp_ = -std::numeric_limits<double>::infinity();
  double lost_since_ = std::numeric_limits<double>::quiet_NaN();  // [s] when LOST began (NaN: not lost)
};

}  // namespace homography_teach_repeat
