// controller_node: drives the base along a taught route with the potential-field controller of
// paper 002 §5.1, from the poses of repeat_node. A thin wrapper over RouteFollower (core).
//
// Subscribes: pose (geometry_msgs/PoseWithCovarianceStamped: repeat_node's ~pose, route frame),
//             heading_correction (homography_teach_repeat/HeadingCorrectionStamped: ok = false
//             means localization failed: stop), scan (sensor_msgs/LaserScan, optional repulsion;
//             the scanner is assumed at base_link)
// Publishes:  cmd_vel (geometry_msgs/Twist) at control_rate: zero when waiting, when the pose is
//             older than pose_timeout, when localization is lost, on NaN input and at the end of
//             the route; ~state (std_msgs/String: waiting | following | stopped | finished);
//             /diagnostics
// Parameters: see config/controller_node.yaml
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>
#include <sensor_msgs/LaserScan.h>

#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/route_follower.h"

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
  void onScan(const sensor_msgs::LaserScanConstPtr& scan);
  void onTimer(const ros::TimerEvent& event);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  double control_period_ = 0.05;
  double scan_timeout_ = 0.5;

  std::mutex mutex_;
  std::optional<RouteFollower> follower_;
  FollowOutput last_output_;
  std::vector<Eigen::Vector2d> obstacles_;
  ros::Time obstacles_stamp_;

  ros::Subscriber pose_subscriber_;
  ros::Subscriber heading_subscriber_;
  ros::Subscriber scan_subscriber_;
  ros::Publisher command_publisher_;
  ros::Publisher state_publisher_;
  ros::Timer timer_;
  diagnostic_updater::Updater diagnostics_;
};

}  // namespace homography_teach_repeat
