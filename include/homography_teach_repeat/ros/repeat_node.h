// repeat_node: localizes the robot against a taught route (paper 000 / 002 repeat phase). A thin
// wrapper over RepeatLocalizer (core).
//
// Subscribes: camera/image_raw + camera/camera_info (image_transport::CameraSubscriber),
//             odom (nav_msgs/Odometry; the position of the mu mode and the optional map -> odom tf)
// Publishes:  ~pose (geometry_msgs/PoseWithCovarianceStamped): base_link in the route frame
//             (`map_frame`), successful estimates only: fast_hd and classic from the image; mu
//             from the heading-aided odometry (an EKF on odometry corrected by μ; its covariance
//             is the filter's, heading_aided_odometry.h). Covariance row-major (x, y, z, roll,
//             pitch, yaw); fast_hd/classic poses that disagree with the odometry motion since the
//             last accepted pose are refused (odometry_gate.h; counted as failures); z, roll and pitch are not estimated and get `unobserved_variance`
//             (classic mode: every entry, it has no covariance model);
//             ~heading_correction (homography_teach_repeat/HeadingCorrectionStamped) every frame;
//             ~route_markers (visualization_msgs/MarkerArray, latched): keyframes, planes, the
//             current reference; ~debug_image (bgr8, only while subscribed: the reference
//             keyframe beside the current image with the inlier matches, or the failure reason);
//             /diagnostics; tf map_frame -> odom_frame (publish_tf).
// Parameters: see config/repeat_node.yaml; mode, pixel_sigma, refine, min_inliers,
//             neighbour_search and max_degraded_frames also through dynamic_reconfigure (cfg/Repeat.cfg).
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <dynamic_reconfigure/server.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/transform_broadcaster.h>

#include <opencv2/core.hpp>

#include <deque>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>

#include "homography_teach_repeat/RepeatConfig.h"
#include "homography_teach_repeat/heading_aided_odometry.h"
#include "homography_teach_repeat/odometry_buffer.h"
#include "homography_teach_repeat/odometry_gate.h"
#include "homography_teach_repeat/repeat_localizer.h"
#include "homography_teach_repeat/status.h"

namespace homography_teach_repeat {

class RepeatNode {
 public:
  // Throws std::runtime_error naming the parameter or the route file on any problem.
  RepeatNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);

 private:
  // Times processImage (wall clock) and records it with the image's age at the start.
  void onImage(const sensor_msgs::ImageConstPtr& image,
               const sensor_msgs::CameraInfoConstPtr& camera_info);
  void processImage(const sensor_msgs::ImageConstPtr& image,
                    const sensor_msgs::CameraInfoConstPtr& camera_info);
  void onOdometry(const nav_msgs::OdometryConstPtr& odometry);
  void publishMarkers(int current_keyframe);
  void publishDebugImage(const sensor_msgs::ImageConstPtr& image, const cv::Mat& current,
                         const RepeatEstimate* estimate, const std::string& failure);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);
  // Seconds (ROS time) since the last image, or since the start when none came yet; mutex_ held.
  double cameraSilence() const;
  void onReconfigure(RepeatConfig& config, uint32_t level);
  // mu mode: the heading-aided odometry at the image stamp corrected by the frame's μ; kNoConsensus
  // without odometry at that stamp or when the filter refuses the fix.
  Expected<std::pair<Pose2D, Eigen::Matrix3d>> headingAidedPose(double stamp, const RepeatEstimate& estimate);
  // mu mode: the pose the heading-aided odometry predicts at `stamp` (the localizer tries only
  // keyframes facing that way and matches lines where it puts them); nullopt before the first
  // fix or without odometry.
  std::optional<Pose2D> predictedMuPose(double stamp);
  // mu mode, a frame without a heading fix: the heading-aided odometry alone at `odom` (its
  // covariance keeps growing) while the robot has travelled at most mu_max_unaided_distance
  // (> 0) since the last fix; kNoConsensus naming the distance otherwise.
  Expected<Pose2D> unaidedMuPose(const Pose2D& odom);
  // mu mode, the frame failed: publishes unaidedMuPose at the image stamp (or warns why not).
  void publishUnaidedMuPose(const std_msgs::Header& image_header);
  void publishPose(const std_msgs::Header& image_header, const Pose2D& pose,
                   const Eigen::Matrix3d* covariance);
  void publishMapToOdom(const ros::Time& stamp, const Pose2D& map_to_odom);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  std::string map_frame_;
  std::string odom_frame_;
  bool publish_tf_ = false;
  double unobserved_variance_ = 1e6;
  int start_keyframe_ = 0;
  double mu_max_unaided_distance_ = 3.0;  // [m]
  RepeatMode mode_ = RepeatMode::kFastHd;
  RepeatOptions options_;

  std::mutex mutex_;
  std::optional<RepeatLocalizer> localizer_;
  bool initialized_ = false;
  OdometryBuffer odometry_;
  HeadingAidedOdometry heading_aided_;
  std::optional<OdometryGate> odometry_gate_;  // fast_hd/classic poses checked against odometry
  Status last_status_{StatusCode::kInvalidInput, "no image received yet"};
  unsigned frames_ = 0, failures_ = 0, degraded_ = 0, gated_ = 0;
  int last_inliers_ = 0;
  int last_keyframe_ = -1;
  bool last_degraded_ = false;
  // Arrival (ROS time: simulated under use_sim_time) of the last image, and of the node's start:
  // the diagnostics report a camera that stopped or never started after image_timeout_ seconds.
  ros::Time last_image_arrival_, start_time_;
  double image_timeout_ = 1.0;
  // Timing of one frame, kept for the last kTimingWindow frames.
  struct FrameTiming {
    double processing_ms = 0.0;  // image in to results published
    double age_ms = 0.0;         // image age when processing started (transport + waiting)
    // The localizer's part (absent when the frame failed before localization, e.g. bad camera_info).
    std::optional<LocalizeTiming> localize;
  };
  static constexpr std::size_t kTimingWindow = 300;
  std::deque<FrameTiming> frame_timing_;
  std::optional<LocalizeTiming> frame_localize_timing_;  // of the frame in progress

  image_transport::ImageTransport image_transport_;
  image_transport::CameraSubscriber camera_subscriber_;
  image_transport::Publisher debug_publisher_;
  int debug_keyframe_ = -1;
  cv::Mat debug_reference_;  // cached reference keyframe image (BGR)
  ros::Subscriber odometry_subscriber_;
  ros::Publisher pose_publisher_;
  ros::Publisher heading_publisher_;
  ros::Publisher marker_publisher_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  diagnostic_updater::Updater diagnostics_;
  ros::Timer diagnostics_timer_;
  // Declared last: its first callback runs in the constructor, when everything else exists.
  boost::recursive_mutex reconfigure_mutex_;  // ours, so updateConfig() cannot deadlock
  std::unique_ptr<dynamic_reconfigure::Server<RepeatConfig>> reconfigure_server_;
};

}  // namespace homography_teach_repeat
