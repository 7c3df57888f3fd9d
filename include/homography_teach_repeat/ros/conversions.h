// Conversions between ROS messages and the ROS-free core types.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <geometry_msgs/Pose.h>
#include <geometry_msgs/Transform.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/buffer.h>

#include <opencv2/core.hpp>

#include <string>

#include "homography_teach_repeat/HomographyStamped.h"
#include "homography_teach_repeat/pinhole_camera.h"
#include "homography_teach_repeat/planar_pose.h"
#include "homography_teach_repeat/robust_homography.h"
#include "homography_teach_repeat/status.h"

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

// The camera mount from tf (base_frame -> camera_frame, waiting up to 0.5 s): kInvalidInput naming
// the frames when there is no transform, or the measured tilt when the camera is not level within
// max_tilt_rad (CameraMount::fromExtrinsic).
Expected<CameraMount> lookupCameraMount(const tf2_ros::Buffer& tf_buffer, const std::string& base_frame,
                                        const std::string& camera_frame, double max_tilt_rad);

HomographyStamped toMsg(const RobustHomographyResult& homography, int tentative_matches,
                        const std_msgs::Header& header, const std::string& reference);

}  // namespace ros_conversions
}  // namespace homography_teach_repeat
