// repeat_node: localizes the robot against a taught route (paper 000 / 002 repeat phase).
// Parameters in, messages out: RepeatPipeline (teach_repeat/repeat_pipeline.h) does the work, one
// call per callback. Topics, parameters and errors: docs/nodes/repeat_node.md.
//
// Subscribes: camera/image_raw + camera/camera_info (image_transport::CameraSubscriber), odom.
// Publishes:  ~pose (PoseWithCovarianceStamped, map_frame), ~heading_correction, ~integrity,
//             ~route_markers (latched), ~debug_image (while subscribed), /diagnostics,
//             tf map_frame -> odom_frame (publish_tf).
// Services:   ~save_experiences (std_srvs/Trigger; with learn_experiences): adds the views learned
//             so far to the route (also done when the node shuts down).
// A map of routes (~map_directory instead of ~route_directory; network/map_navigator.h): the node
// relocalizes (integrity LOST "relocalizing: ..." until a place is confirmed, then the place's
// pose), takes /initialpose (rviz's 2D Pose Estimate, map_frame) as a hint, and follows the way
// ~plan_way (homography_teach_repeat/PlanWay) plans; ~relocalize (std_srvs/Trigger) starts over.
// Also publishes ~way (nav_msgs/Path, latched) and ~map_markers (the routes and junctions, latched).
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_msgs/Header.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <opencv2/core.hpp>

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include <geometry_msgs/PoseWithCovarianceStamped.h>

#include "homography_teach_repeat/PlanWay.h"
#include "homography_teach_repeat/RepeatConfig.h"
#include "homography_teach_repeat/network/map_navigator.h"
#include "homography_teach_repeat/ros/camera_subscription.h"
#include "homography_teach_repeat/ros/odometry_subscriber.h"
#include "homography_teach_repeat/teach_repeat/experience_learning.h"
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"
#include "homography_teach_repeat/ros/repeat_visualization.h"

namespace homography_teach_repeat {

class RepeatNode {
 public:
  // Throws std::runtime_error naming the parameter or the route file on any problem.
  RepeatNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);
  // With learn_experiences: what the run learned is added to the route.
  ~RepeatNode();

 private:
  // The single route of route_directory, or the way followed in a map (nullptr while relocalizing).
  RepeatPipeline* pipeline();
  void startRoute(const std::string& directory, const RepeatPipelineOptions& options);
  // Map mode (repeat_node_map.cpp).
  void startMap(const std::string& directory, const RepeatPipelineOptions& options);
  // The frame's localization timing when it went to the way's repeat.
  std::optional<LocalizeTiming> processMapFrame(const sensor_msgs::ImageConstPtr& image,
                                                const Expected<cv::Mat>& cv_image,
                                                const Expected<PinholeCamera>& camera);
  void publishRelocalization(const std_msgs::Header& header, const NavigatorFrame& frame);
  bool onPlanWay(PlanWay::Request& request, PlanWay::Response& response);
  void onInitialPose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& pose);
  void publishMapMarkers();
  void addMapDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);
  void onImage(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& camera_info);
  void onOdometry(const nav_msgs::OdometryConstPtr& odometry);
  void onReconfigure(RepeatConfig& config, uint32_t level);
  void publish(const sensor_msgs::ImageConstPtr& image, const RepeatFrameResult& result, const Expected<cv::Mat>& cv_image);
  void publishPose(const ros::Time& stamp, const RepeatFrameResult& result);  // and the map -> odom tf
  void publishDebugImage(const sensor_msgs::ImageConstPtr& image, const cv::Mat& current, const RepeatFrameResult& result);
  void publishMarkers(int current_keyframe);
  void publishIntegrity(const std_msgs::Header& header, const IntegrityReport& report, const std::string& fixes,
                        bool camera_silent);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);
  // Seconds (ROS time) since the last image, or since the start when none came yet; mutex_ held.
  double cameraSilence() const;
  // Once, at the first image: the camera's tilt in tf against the levelling the route was taught
  // with (docs/math.md §1.10). A difference is a warning (log + diagnostics), not an error.
  void checkCameraMount(const std::string& camera_frame);
  // Routes that learn (experience_learning.h): the candidates into the route; mutex_ held. The
  // outcome as a sentence for the log and the service.
  std::string saveExperiences(bool* ok);

  ros::NodeHandle nh_, private_nh_;
  std::string map_frame_, odom_frame_;
  bool publish_tf_ = false;
  double unobserved_variance_ = 1e6;
  double image_timeout_ = 1.0;

  std::mutex mutex_;
  std::optional<RepeatPipeline> route_pipeline_;  // route_directory
  std::optional<MapNavigator> navigator_;         // map_directory
  std::string last_relocalization_;               // map mode: the last verdict, for the log
  ros::ServiceServer plan_way_service_, relocalize_service_;
  ros::Subscriber initial_pose_subscriber_;
  ros::Publisher way_publisher_, map_marker_publisher_;
  std::optional<Route> route_;                    // learning: the route as loaded, written into
  std::optional<ExperienceRecorder> recorder_;    // learn_experiences
  std::optional<FeatureExtractor> experience_extractor_;
  int experiences_saved_ = 0;
  ros::ServiceServer save_experiences_service_;
  FrameTimingWindow timing_;
  int marked_keyframe_ = -1;
  int debug_keyframe_ = -1;
  cv::Mat debug_reference_;  // cached reference keyframe image (BGR)
  // Arrival (ROS time: simulated under use_sim_time) of the last image, and of the node's start.
  ros::Time last_image_arrival_, start_time_;
  IntegrityReport last_integrity_;
  std::string base_frame_;
  Eigen::Matrix3d taught_camera_to_level_ = Eigen::Matrix3d::Identity();
  double max_mount_change_ = 0.01;  // [rad]
  bool mount_checked_ = false;
  std::string mount_warning_;  // empty: the mount is as taught (or could not be checked)
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_{tf_buffer_};

  std::unique_ptr<CameraSubscription> camera_subscriber_;
  image_transport::Publisher debug_publisher_;
  ros::Publisher pose_publisher_, heading_publisher_, marker_publisher_, integrity_publisher_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  diagnostic_updater::Updater diagnostics_;
  ros::Timer diagnostics_timer_;
  // Its thread calls onOdometry, which uses the members above (destroyed before them).
  std::unique_ptr<OdometrySubscriber> odometry_subscriber_;
  double odometry_wait_ = 0.2;  // [s] an image waits this long for the odometry of its stamp
  // Declared last: its first callback runs in the constructor, when everything else exists.
  boost::recursive_mutex reconfigure_mutex_;  // ours, so updateConfig() cannot deadlock
  std::unique_ptr<dynamic_reconfigure::Server<RepeatConfig>> reconfigure_server_;
};

}  // namespace homography_teach_repeat
