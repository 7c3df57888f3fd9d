// teach_node: records a route while the robot is driven (paper 000/002 teach phase). A thin
// wrapper over TeachSession (core): parameters in, messages out.
//
// Subscribes: camera/image_raw + camera/camera_info (image_transport::CameraSubscriber),
//             odom (nav_msgs/Odometry; the pose of base_frame in the odometry frame)
// tf:         base_frame -> the image's optical frame (the camera mount; must be level)
// Publishes:  ~status (homography_teach_repeat/TeachStatus, latched), /diagnostics; a keyframe
//             stored with too few features or vertical lines is warned about at once, and the
//             finished route's weak keyframes are named (route_audit.h)
// Services:   ~finish (std_srvs/Trigger): estimates the planes (if first_plane_distance > 0),
//             writes them into the route and stops recording; also run on clean shutdown.
// Into a map of routes (~map_directory + ~route_name instead of ~route_directory; MapTeach,
//             network/map_teach.h): every keyframe is also located in the map; ~status says where
//             (map_place) and where the route touches taught ground; ~finish commits the route
//             and the junctions measured there (docs/nodes/teach_node.md, "Teaching into a map").
// Parameters: see config/teach_node.yaml
// Images and odometry are synchronised by timestamp (odometry interpolated at the image stamp),
// never by arrival order; an image whose stamp has no odometry yet is dropped with a warning.
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/buffer.h>
#include <tf2_ros/transform_listener.h>

#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "homography_teach_repeat/ros/camera_subscription.h"
#include "homography_teach_repeat/ros/odometry_subscriber.h"
#include "homography_teach_repeat/geometry/odometry_buffer.h"
#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/network/map_teach.h"
#include "homography_teach_repeat/teach_repeat/route_audit.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"

namespace homography_teach_repeat {

class TeachNode {
 public:
  // Throws std::runtime_error naming the parameter on a missing or invalid parameter.
  TeachNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);
  // Finishes the route (plane estimation) if ~finish was not called.
  ~TeachNode();

 private:
  void onImage(const sensor_msgs::ImageConstPtr& image,
               const sensor_msgs::CameraInfoConstPtr& camera_info);
  void onOdometry(const nav_msgs::OdometryConstPtr& odometry);
  bool onFinish(std_srvs::Trigger::Request& request, std_srvs::Trigger::Response& response);
  Status startSession(const sensor_msgs::CameraInfo& camera_info);
  Status finish(std::string* summary);
  // The session recording the route (alone or into the map); nullptr before the first image.
  const TeachSession* session() const;
  // Map mode (teach_node_map.cpp): the map and its place index read at start-up; the session
  // started at the first image; where the last keyframe is; the commit at finish.
  void prepareMap();
  Status startMapSession(const CameraCalibration& calibration, const Pose2D& mount);
  std::string describeMapPlace();
  Status finishMap(std::string* summary);
  void publishStatus(const std::string& state, const std::string& message);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  std::string map_directory_;  // empty: one route (route_directory)
  TeachOptions options_;
  std::string base_frame_;
  double max_camera_tilt_rad_ = 0.05;
  RouteAuditOptions audit_;  // what makes a keyframe weak (docs/route_audit.md)

  std::mutex mutex_;  // image, odometry and service callbacks may run concurrently
  std::optional<TeachSession> session_;
  std::string route_name_;  // map mode
  std::optional<RouteMap> map_;
  std::optional<PlaceIndex> map_index_;
  MapTeachOptions map_options_;
  std::optional<MapTeach> map_teach_;
  std::size_t map_contacts_ = 0;
  OdometryBuffer odometry_;
  bool finished_ = false;
  std::string state_ = "waiting";
  std::string last_message_ = "no image received yet";
  Status last_error_ = Status::ok();
  unsigned images_ = 0;
  unsigned dropped_ = 0;
  unsigned weak_keyframes_ = 0;  // stored with fewer features or lines than audit_ wants
  std::string last_weak_;

  tf2_ros::Buffer tf_buffer_;
  tf2_ros::TransformListener tf_listener_;
  std::unique_ptr<CameraSubscription> camera_subscriber_;
  ros::Publisher status_publisher_;
  ros::ServiceServer finish_service_;
  diagnostic_updater::Updater diagnostics_;
  ros::Timer diagnostics_timer_;
  // Last: its thread calls onOdometry, which uses the members above.
  std::unique_ptr<OdometrySubscriber> odometry_subscriber_;
  double odometry_wait_ = 0.2;  // [s] an image waits this long for the odometry of its stamp
};

}  // namespace homography_teach_repeat
