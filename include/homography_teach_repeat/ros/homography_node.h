// homography_node: registers every camera frame against a reference image and publishes the
// plane homography (HomographyStamped) with diagnostics. A thin wrapper over ImageRegistration.
//
// Subscribes: camera/image_raw + camera/camera_info (image_transport::CameraSubscriber)
// Publishes:  ~homography (homography_teach_repeat/HomographyStamped), only for successful
//             estimates; ~debug_image (bgr8: reference border mapped by H, inliers green,
//             rejected matches red; drawn only while subscribed); /diagnostics (registration
//             status, inliers, frame age)
// Parameters: see config/homography_node.yaml
#pragma once

#include <diagnostic_updater/diagnostic_updater.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <memory>
#include <string>

#include "homography_teach_repeat/ros/camera_subscription.h"
#include "homography_teach_repeat/homography/image_registration.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

class HomographyNode {
 public:
  // Throws std::runtime_error with the parameter name on a missing or invalid parameter, or an
  // unreadable reference image.
  HomographyNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);

 private:
  void onImage(const sensor_msgs::ImageConstPtr& image,
               const sensor_msgs::CameraInfoConstPtr& camera_info);
  void reportFailure(const Status& status);
  void produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  std::string reference_path_;
  double image_timeout_s_ = 2.0;
  ImageRegistration registration_;

  std::unique_ptr<CameraSubscription> camera_subscriber_;
  image_transport::Publisher debug_image_publisher_;
  ros::Publisher homography_publisher_;
  diagnostic_updater::Updater diagnostics_;
  ros::Timer diagnostics_timer_;

  Status last_status_{StatusCode::kInvalidInput, "no image received yet"};
  ros::WallTime last_image_time_;
  unsigned frames_ = 0;
  unsigned failures_ = 0;
  unsigned last_inliers_ = 0;
};

}  // namespace homography_teach_repeat
