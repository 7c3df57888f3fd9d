#include "homography_teach_repeat/ros/controller_node.h"

#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <std_msgs/String.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "homography_teach_repeat/PlanWay.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/controller_parameters.h"
#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {
ControllerNode::ControllerNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh), diagnostics_(nh, private_nh) {
  const bool autostart = readParameter(private_nh, "autostart", true);
  default_directory_ = autostart ? readRequiredParameter<std::string>(private_nh, "route_directory")
                                 : readParameter<std::string>(private_nh, "route_directory", "");
  const double rate = readParameter(private_nh, "control_rate", 20.0);
  scan_timeout_ = readParameter(private_nh, "scan_timeout", 0.5);
  bridging_slow_after_ = readCheckedParameter(private_nh, "bridging_slow_after", bridging_slow_after_,
                                              [](double v) { return std::isfinite(v) && v >= 0.0; },
                                              "must be finite and >= 0 s");
  stop_abort_timeout_ = readParameter(private_nh, "stop_abort_timeout", 20.0);
  shutdown_when_finished_ = readParameter(private_nh, "shutdown_when_finished", false);
  if (!(rate > 0.0) || !std::isfinite(rate)) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("control_rate") + "' must be > 0 Hz");
  }
  if (!(stop_abort_timeout_ > 0.0) || !std::isfinite(stop_abort_timeout_)) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("stop_abort_timeout") + "' must be > 0 s");
  }
  control_period_ = 1.0 / rate;
  const auto non_negative = [](double v) { return std::isfinite(v) && v >= 0.0; };
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  plan_retry_period_ = readCheckedParameter(private_nh, "plan_retry_period", plan_retry_period_, positive, "must be > 0 s");
  relocalization_timeout_ = readCheckedParameter(private_nh, "relocalization_timeout", relocalization_timeout_, positive,
                                                 "must be > 0 s");
  relocalization_turn_speed_ = readCheckedParameter(private_nh, "relocalization_turn_speed", relocalization_turn_speed_,
                                                    non_negative, "must be finite and >= 0 rad/s");
  plan_way_client_ = nh_.serviceClient<PlanWay>("plan_way");
  options_ = readRouteFollowerOptions(private_nh);
  if (autostart) startRoute(default_directory_, options_);
  command_publisher_ = nh_.advertise<geometry_msgs::Twist>("cmd_vel", 1);
  state_publisher_ = private_nh_.advertise<std_msgs::String>("state", 1, /*latch=*/true);
  publishState(follower_ ? "waiting: no localization yet" : "idle: no route (send a repeat_route goal)");
  const std::string pose_source = readParameter<std::string>(private_nh, "pose_source", "localization");
  if (pose_source == "localization") {
    pose_subscriber_ = nh_.subscribe("pose", 5, &ControllerNode::onPose, this);
    odometry_subscriber_ = nh_.subscribe<nav_msgs::Odometry>("odom", 50, [this](const nav_msgs::OdometryConstPtr& odom) {
      const auto pose = ros_conversions::toPose2D(odom->pose.pose);
      std::lock_guard<std::mutex> lock(mutex_);
      if (!follower_) return;
      // A bad odometry message is not used to carry the pose (the fix alone, with pose_timeout).
      const Status added = pose ? follower_->addOdometry(*pose, odom->header.stamp.toSec()) : pose.status();
      if (!added.isOk()) ROS_WARN_THROTTLE(5.0, "controller_node: odometry: %s", added.message().c_str());
    });
  } else if (pose_source == "odometry") {
    // The baseline without vision: the raw odometry as the route pose (its frame must be the
    // route frame, i.e. the run starts where the teach run started).
    pose_subscriber_ = nh_.subscribe<nav_msgs::Odometry>("odom", 20, [this](const nav_msgs::OdometryConstPtr& odom) {
      auto pose = boost::make_shared<geometry_msgs::PoseWithCovarianceStamped>();
      pose->header = odom->header;
      pose->pose = odom->pose;
      onPose(pose);
    });
    ROS_WARN("controller_node: pose_source is odometry: following the route WITHOUT vision (baseline)");
  } else {
    throw std::runtime_error("parameter '" + private_nh.resolveName("pose_source") +
                             "' must be 'localization' or 'odometry', not '" + pose_source + "'");
  }
  heading_subscriber_ = nh_.subscribe("heading_correction", 5, &ControllerNode::onHeading, this);
  integrity_subscriber_ = nh_.subscribe("integrity", 5, &ControllerNode::onIntegrity, this);
  scan_subscriber_ = nh_.subscribe("scan", 1, &ControllerNode::onScan, this);
  diagnostics_.setHardwareID("controller_node");
  diagnostics_.add("controller", this, &ControllerNode::produceDiagnostics);

  action_server_ = std::make_unique<actionlib::SimpleActionServer<RepeatRouteAction>>(nh_, "repeat_route", false);
  action_server_->registerGoalCallback([this] { onGoal(); });
  action_server_->registerPreemptCallback([this] { onPreempt(); });
  action_server_->start();

  // dynamic_reconfigure starts from the validated parameters (one source of defaults: the YAML).
  reconfigure_server_ =
      std::make_unique<dynamic_reconfigure::Server<ControllerConfig>>(reconfigure_mutex_, private_nh_);
  const PotentialFieldParameters& p = options_.controller;
  ControllerConfig config = ControllerConfig::__getDefault__();  // every field initialised (UBSan)
  config.viscous_friction = p.viscous_friction;
  config.inertia_ratio = p.inertia_ratio;
  config.lever = p.lever;
  config.attractive_gain = p.attractive_gain;
  config.attraction_saturation = p.attraction_saturation;
  config.repulsive_gain = p.repulsive_gain;
  config.repulsive_range = p.repulsive_range;
  config.max_linear_velocity = p.max_linear_velocity;
  config.max_angular_velocity = p.max_angular_velocity;
  config.max_linear_acceleration = p.max_linear_acceleration;
  config.max_angular_acceleration = p.max_angular_acceleration;
  config.allow_reverse = p.allow_reverse;
  config.goal_tolerance = p.goal_tolerance;
  config.goal_heading_tolerance = p.goal_heading_tolerance;
  config.require_goal_heading = options_.require_goal_heading;
  config.pose_timeout = options_.pose_timeout;
  reconfigure_server_->updateConfig(config);
  reconfigure_server_->setCallback(
      [this](ControllerConfig& c, uint32_t level) { onReconfigure(c, level); });

  timer_ = nh_.createTimer(ros::Duration(control_period_), &ControllerNode::onTimer, this);
  ROS_INFO("controller_node: %s at %.0f Hz; action server 'repeat_route' ready",
           follower_ ? ("following '" + default_directory_ + "' (" + std::to_string(options_.laps) +
                        " lap(s))").c_str()
                     : "idle",
           rate);
}

ControllerNode::~ControllerNode() {
  timer_.stop();
  command_publisher_.publish(geometry_msgs::Twist());
  if (action_server_ && action_server_->isActive()) {
    RepeatRouteResult result;
    result.reached = false;
    result.reason = "controller_node shut down";
    action_server_->setAborted(result, result.reason);
  }
}

void ControllerNode::publishState(const std::string& state) {
  if (state == last_state_) return;
  last_state_ = state;
  std_msgs::String message;
  message.data = state;
  state_publisher_.publish(message);
}

void ControllerNode::onPose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& pose) {
  const auto planar = ros_conversions::toPose2D(pose->pose.pose);
  std::lock_guard<std::mutex> lock(mutex_);
  if (!follower_) return;
  if (!planar) {
    follower_->setFix(Pose2D(NAN, NAN, NAN), pose->header.stamp.toSec());
    ROS_WARN_THROTTLE(2.0, "controller_node: pose rejected (%s): stopping",
                      planar.status().message().c_str());
    return;
  }
  follower_->setFix(*planar, pose->header.stamp.toSec());
}

void ControllerNode::onHeading(const HeadingCorrectionStampedConstPtr& heading) {
  std::lock_guard<std::mutex> lock(mutex_);
  reference_index_ = heading->reference_index;
  inliers_ = heading->inliers;
  // repeat_node's ~integrity, once it comes, says whether the pose can be trusted: a frame without
  // a fix whose bridged pose is still good (mu, hybrid) must not stop the robot.
  if (heading->ok || !follower_ || !integrity_.empty()) return;
  follower_->setLost(heading->status, heading->header.stamp.toSec());
}

void ControllerNode::onIntegrity(const IntegrityConstPtr& integrity) {
  std::lock_guard<std::mutex> lock(mutex_);
  integrity_ = integrity->level_name;
  integrity_reason_ = integrity->reason;
  if (!follower_) return;
  PoseTrust trust = integrity->level == Integrity::OK         ? PoseTrust::kOk
                    : integrity->level == Integrity::DEGRADED ? PoseTrust::kDegraded
                                                              : PoseTrust::kLost;
  std::string reason = integrity->reason;
  // A pose bridged on odometry may be right (the integrity says OK), but the robot drives on it
  // slowly: the view it looks for should not pass by at full speed.
  if (trust == PoseTrust::kOk && bridging_slow_after_ > 0.0 && integrity->fixes.empty() &&
      integrity->time_without_fix > bridging_slow_after_) {
    trust = PoseTrust::kDegraded;
    char text[120];
    std::snprintf(text, sizeof text, "bridging on odometry, no fix for %.1f s", integrity->time_without_fix);
    reason = text;
  }
  follower_->setTrust(trust, reason, integrity->header.stamp.toSec(), !integrity->camera_silent);
}

void ControllerNode::onScan(const sensor_msgs::LaserScanConstPtr& scan) {
  std::vector<Eigen::Vector2d> points;
  for (std::size_t i = 0; i < scan->ranges.size(); ++i) {
    const float r = scan->ranges[i];
    if (!std::isfinite(r) || r < scan->range_min || r > scan->range_max) continue;
    const double angle = scan->angle_min + static_cast<double>(i) * scan->angle_increment;
    points.emplace_back(r * std::cos(angle), r * std::sin(angle));
  }
  std::lock_guard<std::mutex> lock(mutex_);
  obstacles_ = std::move(points);
  obstacles_stamp_ = scan->header.stamp;
}

void ControllerNode::onTimer(const ros::TimerEvent&) {
  const ros::Time now = ros::Time::now();
  FollowOutput out;
  RepeatRouteFeedback feedback;
  if (!pending_destination_.empty()) {
    planWay(now);
    diagnostics_.update();
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (!follower_) {
      diagnostics_.update();
      return;  // idle: no command, so another source (joystick) can drive
    }
    static const std::vector<Eigen::Vector2d> kNoObstacles;
    const bool fresh_scan = (now - obstacles_stamp_).toSec() <= scan_timeout_;
    out = follower_->update(now.toSec(), control_period_, fresh_scan ? obstacles_ : kNoObstacles);
    feedback.reference_index = reference_index_;
    feedback.inliers = inliers_;
    feedback.integrity = integrity_;
    feedback.integrity_reason = integrity_reason_;
  }
  geometry_msgs::Twist command;
  command.linear.x = out.command.linear;
  command.angular.z = out.command.angular;
  command_publisher_.publish(command);
  if (out.state != last_output_.state || out.reason != last_output_.reason) {
    publishState(toString(out.state) + (out.reason.empty() ? "" : ": " + out.reason));
    // A new state or reason is logged at once; a reason that only changes its figures in
    // parentheses (the pose's age grows every cycle while stopped) at most every 5 s.
    auto withoutFigures = [](const std::string& reason) { return reason.substr(0, reason.find('(')); };
    if (out.state != last_output_.state || withoutFigures(out.reason) != withoutFigures(last_output_.reason)) {
      if (out.state == FollowState::kStopped || out.state == FollowState::kSearching) {
        ROS_WARN("controller_node: %s: %s", toString(out.state).c_str(), out.reason.c_str());
      } else {
        ROS_INFO("controller_node: %s", last_state_.c_str());
      }
    } else if (out.state == FollowState::kStopped) {
      ROS_WARN_THROTTLE(5.0, "controller_node: stopped: %s", out.reason.c_str());
    } else {
      ROS_INFO_THROTTLE(5.0, "controller_node: %s", last_state_.c_str());
    }
  }
  last_output_ = out;
  diagnostics_.update();
  if (shutdown_when_finished_ && out.state == FollowState::kFinished) {
    ROS_INFO("controller_node: route finished, shutting down (shutdown_when_finished)");
    ros::shutdown();
    return;
  }
  if (!action_server_->isActive()) return;

  feedback.progress = 100.0 * out.progress;
  feedback.goal_index = out.goal_index;
  feedback.lap = out.lap;
  feedback.distance_to_goal = out.distance_to_goal;
  feedback.state = toString(out.state);
  feedback.reason = out.reason;
  action_server_->publishFeedback(feedback);
  RepeatRouteResult result;
  result.progress = feedback.progress;
  result.junctions_crossed = way_junctions_;
  if (out.state == FollowState::kFinished) {
    result.reached = true;
    result.reason = "reached";
    action_server_->setSucceeded(result, result.reason);
    return;
  }
  // A goal waits for localization (kStopped/kWaiting) at most stop_abort_timeout.
  if (out.state == FollowState::kFollowing) {
    stopped_since_ = -1.0;
  } else if (stopped_since_ < 0.0) {
    stopped_since_ = now.toSec();
  } else if (now.toSec() - stopped_since_ > stop_abort_timeout_) {
    abortGoal("stopped for more than stop_abort_timeout (" + std::to_string(stop_abort_timeout_) + " s): " + out.reason);
  }
}

void ControllerNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  if (!pending_destination_.empty()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "waiting for the way to " + pending_destination_ + ": " + plan_reason_);
    return;
  }
  if (!follower_) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "idle: no route");
    return;
  }
  const FollowOutput& out = last_output_;
  const unsigned char level = out.state == FollowState::kStopped || out.state == FollowState::kSearching
                                  ? diagnostic_msgs::DiagnosticStatus::WARN
                                  : diagnostic_msgs::DiagnosticStatus::OK;
  stat.summary(level, toString(out.state) + (out.reason.empty() ? "" : ": " + out.reason));
  stat.add("goal keyframe", out.goal_index);
  stat.add("lap", out.lap);
  stat.add("distance to goal [m]", out.distance_to_goal);
  stat.add("progress", out.progress);
  stat.add("linear velocity [m/s]", out.command.linear);
  stat.add("angular velocity [rad/s]", out.command.angular);
  stat.add("integrity", integrity_.empty() ? "none received" : integrity_ + (integrity_reason_.empty() ? "" : ": " + integrity_reason_));
}

}  // namespace homography_teach_repeat
