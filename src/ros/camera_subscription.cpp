#include "homography_teach_repeat/ros/camera_subscription.h"

#include <image_transport/camera_common.h>

#include <stdexcept>
#include <utility>

#include "homography_teach_repeat/ros/compressed_image.h"

namespace homography_teach_repeat {

std::string readImageTransport(const ros::NodeHandle& private_nh) {
  std::string transport = "raw";
  private_nh.param<std::string>("image_transport", transport, transport);
  if (transport != "raw" && transport != "compressed") {
    throw std::invalid_argument("parameter '" + private_nh.resolveName("image_transport") + "' is '" + transport +
                                "': 'raw' (sensor_msgs/Image) or 'compressed' (sensor_msgs/CompressedImage, JPEG or PNG)");
  }
  return transport;
}

CameraSubscription::CameraSubscription(const ros::NodeHandle& nh_in, const ros::NodeHandle& private_nh,
                                       const std::string& image_topic, uint32_t queue_size, const std::string& node_name,
                                       ImageCallback on_image)
    : transport_(readImageTransport(private_nh)), node_name_(node_name), on_image_(std::move(on_image)) {
  ros::NodeHandle nh = nh_in;
  if (transport_ == "raw") {
    image_transport::ImageTransport it(nh);
    raw_ = it.subscribeCamera(
        image_topic, queue_size,
        [this](const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) {
          on_image_(image, info);
        },
        ros::VoidPtr(), image_transport::TransportHints("raw"));
    return;
  }
  const std::string base_topic = nh.resolveName(image_topic);
  compressed_ = std::make_unique<message_filters::Subscriber<sensor_msgs::CompressedImage>>(
      nh, base_topic + "/compressed", queue_size);
  camera_info_ = std::make_unique<message_filters::Subscriber<sensor_msgs::CameraInfo>>(
      nh, image_transport::getCameraInfoTopic(base_topic), queue_size);
  synchronizer_ = std::make_unique<message_filters::TimeSynchronizer<sensor_msgs::CompressedImage, sensor_msgs::CameraInfo>>(
      *compressed_, *camera_info_, queue_size);
  synchronizer_->registerCallback(&CameraSubscription::onCompressed, this);
}

void CameraSubscription::onCompressed(const sensor_msgs::CompressedImageConstPtr& image,
                                      const sensor_msgs::CameraInfoConstPtr& info) {
  auto decoded = ros_conversions::decompress(*image);
  if (!decoded) {
    ++undecodable_;
    const std::string reason = "image at " + std::to_string(image->header.stamp.toSec()) + " s on " +
                               compressed_->getTopic() + " dropped: " + decoded.status().message();
    std::lock_guard<std::mutex> lock(error_mutex_);
    last_error_ = reason;
    last_error_time_ = ros::Time::now();
    const ros::WallTime now = ros::WallTime::now();
    if (last_logged_.isZero() || (now - last_logged_).toSec() >= 2.0) {
      last_logged_ = now;
      ROS_WARN("%s: %s (%zu undecodable so far)", node_name_.c_str(), reason.c_str(), undecodable_.load());
    }
    return;
  }
  on_image_(*decoded, info);
}

std::string CameraSubscription::getTopic() const {
  return transport_ == "raw" ? raw_.getTopic() : compressed_->getTopic();
}

void CameraSubscription::addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat, double recent) const {
  stat.add("image transport", transport_ + " (" + getTopic() + ")");
  if (transport_ != "compressed") return;
  stat.add("undecodable images dropped", undecodable_.load());
  std::lock_guard<std::mutex> lock(error_mutex_);
  if (!last_error_.empty() && (ros::Time::now() - last_error_time_).toSec() <= recent) {
    stat.mergeSummary(diagnostic_msgs::DiagnosticStatus::WARN, last_error_);
  }
}

}  // namespace homography_teach_repeat
