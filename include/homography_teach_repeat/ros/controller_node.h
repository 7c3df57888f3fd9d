// controller_node: drives the base along a taught route with the potential-field controller of
// paper 002 §5.1, from the poses of repeat_node. A thin wrapper over RouteFollower (core).
//
// Subscribes: pose (geometry_msgs/PoseWithCovarianceStamped: repeat_node's ~pose, route frame),
//             heading_correction (homography_teach_repeat/HeadingCorrectionStamped: ok = false
//             means localization failed: stop), integrity (homography_teach_repeat/Integrity:
//             DEGRADED slows down, LOST stops and then turns in place to look for a taught view),
//             scan (sensor_msgs/LaserScan, optional repulsion; the scanner is assumed at base_link)
// Publishes:  cmd_vel (geometry_msgs/Twist) at control_rate: zero when waiting, when the pose is
//             older than pose_timeout, when localization is lost, on NaN input and at the end of
//             the route; ~state (std_msgs/String: waiting | following | stopped | searching |
//             finished);
//             /diagnostics
// Action:     repeat_route (homography_teach_repeat/RepeatRouteAction): follow a route from a
//             start to an end keyframe for some laps; feedback at the control rate (progress,
//             goal, distance, repeat_node's reference keyframe and inliers); result reached, or
//             aborted (bad goal, or stopped longer than stop_abort_timeout) / preempted with the
//             reason. A new goal replaces the running route; without a goal the node follows
//             ~route_directory from start-up when `autostart` is true, and is idle (publishes
//             nothing, so a joystick can drive) otherwise. A goal with a `destination` (a map of
//             routes) asks repeat_node's plan_way (service `plan_way`, homography_teach_repeat/
//             PlanWay) for the way from where the robot is, every plan_retry_period while repeat_node
//             still relocalizes (turning in place at relocalization_turn_speed, 0: standing), and
//             follows it once; a destination not in the map or not reachable aborts the goal with
//             the reason, and so does no place within relocalization_timeout.
// Parameters: see config/controller_node.yaml; gains, limits and thresholds also through
//             dynamic_reconfigure (cfg/Controller.cfg).
// Callbacks run one at a time (ros::spin, or the nodelet's single-threaded queue).
#pragma once

#include <actionlib/server/simple_action_server.h>
#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>

#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/ControllerConfig.h"
#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/Integrity.h"
#include "homography_teach_repeat/RepeatRouteAction.h"
#include "homography_teach_repeat/control/route_follower.h"

namespace homography_teach_repeat {

class ControllerNode {
 public:
  // Throws std::runtime_error naming the parameter or the route file on any problem.
  ControllerNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);
  // Publishes a zero command.
  ~ControllerNode();

 private:
  void onPose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& pose);
  void onHeading(const HeadingCorrectionStampedConstPtr& heading);
  void onIntegrity(const IntegrityConstPtr& integrity);
  void onScan(const sensor_msgs::LaserScanConstPtr& scan);
  void onTimer(const ros::TimerEvent& event);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void onGoal();
  void onPreempt();
  void onReconfigure(ControllerConfig& config, uint32_t level);
  // Loads the route and starts following it; throws std::runtime_error naming the problem.
  void startRoute(const std::string& directory, const RouteFollowerOptions& options);
  // Follows `goals` (base_link poses in the pose's frame); throws std::runtime_error naming `what`.
  void startFollowing(const std::vector<Pose2D>& goals, const RouteFollowerOptions& options, const std::string& what);
  // A goal with a destination, while no way is planned yet (controller_node_goals.cpp).
  void planWay(const ros::Time& now);
  void abortGoal(const std::string& reason);
  void publishState(const std::string& state);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  double control_period_ = 0.05;
  double scan_timeout_ = 0.5;
  double stop_abort_timeout_ = 20.0;
  double bridging_slow_after_ = 1.0;  // [s] without a fix: slow down as on DEGRADED (0: never)
  bool shutdown_when_finished_ = false;  // scripts: exit at the end of the route
  std::string default_directory_;
  RouteFollowerOptions options_;  // start-up / reconfigured values; goals override the sequence

  std::mutex mutex_;
  std::optional<RouteFollower> follower_;
  FollowOutput last_output_;
  std::string last_state_;
  double stopped_since_ = -1.0;  // [s] when the robot stopped during an action goal (-1: not)
  int reference_index_ = -1;     // from repeat_node's heading correction
  unsigned inliers_ = 0;
  std::string integrity_, integrity_reason_;  // the last ~integrity of repeat_node
  // A goal with a destination whose way is not planned yet (empty: none).
  std::string pending_destination_;
  ros::Time destination_since_, next_plan_;
  std::string plan_reason_;  // why the way is not planned yet
  bool relocalizing_ = false;
  int way_junctions_ = 0;  // of the way followed for a destination
  double plan_retry_period_ = 1.0;         // [s]
  double relocalization_timeout_ = 60.0;   // [s]
  double relocalization_turn_speed_ = 0.0; // [rad/s] turning in place while relocalizing (0: standing)
  ros::ServiceClient plan_way_client_;
  std::vector<Eigen::Vector2d> obstacles_;
  ros::Time obstacles_stamp_;

  ros::Subscriber pose_subscriber_;
  ros::Subscriber odometry_subscriber_;  // carries the pose from its image to now (RouteFollower::addOdometry)
  ros::Subscriber heading_subscriber_, integrity_subscriber_;
  ros::Subscriber scan_subscriber_;
  ros::Publisher command_publisher_;
  ros::Publisher state_publisher_;
  ros::Timer timer_;
  diagnostic_updater::Updater diagnostics_;
  std::unique_ptr<actionlib::SimpleActionServer<RepeatRouteAction>> action_server_;
  boost::recursive_mutex reconfigure_mutex_;  // ours, so updateConfig() cannot deadlock
  std::unique_ptr<dynamic_reconfigure::Server<ControllerConfig>> reconfigure_server_;
};

}  // namespace homography_teach_repeat
