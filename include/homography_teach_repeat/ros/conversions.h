// Conversions between ROS messages and the ROS-free core types.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/PoseWithCovariance.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>
#include <visualization_msgs/MarkerArray.h>

#include <opencv2/core.hpp>

#include <map>
#include <string>

#include "homography_teach_repeat/HomographyStamped.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {
namespace ros_conversions {

// CameraInfo -> calibration record (K from camera_info.K, D and distortion_model as given).
CameraCalibration toCalibration(const sensor_msgs::CameraInfo& info);

// Validated camera from a CameraInfo: kInvalidInput with PinholeCamera's message when the
// calibration is missing (all-zero K), zero/negative/NaN focal length, unknown model, ...
Expected<PinholeCamera> toPinholeCamera(const sensor_msgs::CameraInfo& info);

// Image message -> 8-bit grey or BGR cv::Mat, sharing the buffer where possible. kInvalidInput
// naming the encoding for anything cv_bridge cannot turn into mono8/bgr8, and for empty images.
Expected<cv::Mat> toCvImage(const sensor_msgs::ImageConstPtr& image);

// Planar part of a 3D pose (REP-103: x, y, yaw about z). kInvalidInput for non-finite values or a
// quaternion that is not (close to) unit.
Expected<Pose2D> toPose2D(const geometry_msgs::Pose& pose);

// The quaternion of a rotation by `yaw` [rad] about z (REP-103 planar poses).
geometry_msgs::Quaternion yawQuaternion(double yaw);

// geometry_msgs transform -> Eigen isometry.
Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& transform);

// The camera mount from tf (base_frame -> camera_frame, waiting up to 0.5 s): its planar forward
// frame, the rotation that levels its images (CameraMount::cameraToLevel, to be set in the
// camera's CameraCalibration::camera_to_level) and its tilt. kInvalidInput naming the frames when
// there is no transform, or the measured tilt when it exceeds max_tilt_rad.
struct MountFromTf {
  CameraMount mount;
  Eigen::Matrix3d camera_to_level;
  double tilt_rad;
};
Expected<MountFromTf> lookupCameraMount(const tf2_ros::Buffer& tf_buffer, const std::string& base_frame,
                                        const std::string& camera_frame, double max_tilt_rad);

HomographyStamped toMsg(const RobustHomographyResult& homography, int tentative_matches,
                        const std_msgs::Header& header, const std::string& reference);

// A planar pose with its (x, y, yaw) covariance as a PoseWithCovariance: the 6x6 covariance is
// row-major over (x, y, z, roll, pitch, yaw), rows and columns 0, 1 and 5 hold `covariance`; z,
// roll and pitch are not estimated and get `unobserved_variance`, and so does every entry of a pose
// whose covariance is unknown (nullptr).
geometry_msgs::PoseWithCovariance toPoseWithCovariance(const Pose2D& pose, const Eigen::Matrix3d* covariance,
                                                       double unobserved_variance);
// The route for rviz in `frame_id`: an arrow per keyframe (namespace "keyframes", the current one
// in orange) and its scene plane as a 2 m wall segment ("planes"; ros/repeat_visualization.h).
visualization_msgs::MarkerArray routeMarkers(const Route& route, int current_keyframe, const std::string& frame_id,
                                             const ros::Time& stamp);
// A map of routes for rviz in `frame_id` (the map frame): each route a line through its keyframes
// ("routes") and its name at its first keyframe ("route_names"), each junction a sphere at its
// `from` keyframe ("junctions"); `route_frames` places each route (routeFramesInMap), routes it
// lacks are left out.
visualization_msgs::MarkerArray networkMarkers(const RouteMap& map, const std::map<std::string, Pose2D>& route_frames,
                                               const std::string& frame_id, const ros::Time& stamp);

// The (x, y, yaw) block of a PoseWithCovariance's covariance (the inverse of the above).
Eigen::Matrix3d planarCovariance(const geometry_msgs::PoseWithCovariance& pose);

}  // namespace ros_conversions
}  // namespace homography_teach_repeat
