// trifocal_localizer: three-view localization of the robot and the landmarks from bearing-only
// data with the 1D trifocal tensor (paper 003), on a sliding triplet of the live stream. A thin
// wrapper over TrifocalLocalizer (core).
//
// A new view is taken when odometry shows the robot `min_baseline` [m] away from the previous one
// (other frames are dropped unprocessed); with three views the tensor is estimated robustly, its
// motion disambiguated and scaled by the odometry of the three views, and the oldest view leaves.
//
// Subscribes: camera/image_raw + camera/camera_info (image_transport::CameraSubscriber),
//             odom (nav_msgs/Odometry); tf base_frame -> camera frame (the camera must be level).
// Publishes:  ~poses (geometry_msgs/PoseArray, odom frame, stamped with the newest view):
//             base_link at the three views, oldest first (the oldest at its odometry pose);
//             ~landmarks (visualization_msgs/MarkerArray, odom frame): the triangulated landmarks;
//             /diagnostics (status, views, matches, inliers, failures).
// Parameters: see config/trifocal_localizer.yaml (validated at start-up).
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <deque>
#include <mutex>
#include <optional>
#include <memory>
#include <string>

#include "homography_teach_repeat/ros/camera_subscription.h"
#include "homography_teach_repeat/geometry/odometry_buffer.h"
#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/trifocal/trifocal_localizer.h"

namespace homography_teach_repeat {

class TrifocalLocalizerNode {
 public:
  // Throws std::runtime_error naming the parameter on a bad value.
  TrifocalLocalizerNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);

 private:
  void onImage(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& camera_info);
  void onOdometry(const nav_msgs::OdometryConstPtr& odometry);
  // The localizer for this camera (built on the first image: calibration and the tf mount).
  Status ensureLocalizer(const sensor_msgs::CameraInfo& camera_info);
  void publish(const std_msgs::Header& header, const TrifocalLocalization& result);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  std::string base_frame_;
  std::string odom_frame_;
  double min_baseline_ = 0.3;
  double max_camera_tilt_ = 0.05;
  double max_transfer_error_px_ = 3.0;
  TrifocalLocalizerOptions options_;

  std::unique_ptr<CameraSubscription> camera_subscriber_;
  ros::Subscriber odometry_subscriber_;
  ros::Publisher poses_publisher_;
  ros::Publisher landmarks_publisher_;
  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  diagnostic_updater::Updater diagnostics_;
  ros::Timer diagnostics_timer_;

  std::mutex mutex_;
  OdometryBuffer odometry_{10.0, 0.5};
  std::optional<TrifocalLocalizer> localizer_;
  std::deque<TrifocalView> views_;  // the two previous views, oldest first
  // The last localization's motion between its views 2 and 3 (= views 1 and 2 of the next one).
  std::optional<Pose2D> shared_motion_;
  Status last_status_{StatusCode::kTooFewPoints, "waiting for three views"};
  int views_taken_ = 0;
  int localizations_ = 0;
  int failures_ = 0;
  int last_triplets_ = 0;
  int last_inliers_ = 0;
  int last_off_plane_ = 0;
};

}  // namespace homography_teach_repeat
