// A camera's images with their camera_info, through the transport the node's `~image_transport`
// parameter names (ROS's own parameter, as image_transport reads it):
//   raw         sensor_msgs/Image on IMAGE_TOPIC (image_transport's CameraSubscriber);
//   compressed  sensor_msgs/CompressedImage on IMAGE_TOPIC/compressed (JPEG or PNG), decoded here
//               with OpenCV (compressed_image.h): Debian ships no compressed_image_transport plugin.
// Either way an image is paired with the camera_info of the same stamp (the camera_info topic
// beside the image topic) and handed to `on_image` as an Image. A compressed frame that cannot be
// decoded (corrupt, truncated, not JPEG/PNG) never reaches `on_image`: it is counted, logged under
// the node's name (at most every 2 s) and reported in the node's diagnostics (addDiagnostics).
// docs/using.md, "Compressed camera streams".
#pragma once

#include <diagnostic_updater/DiagnosticStatusWrapper.h>
#include <image_transport/image_transport.h>
#include <message_filters/subscriber.h>
#include <message_filters/time_synchronizer.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <string>

namespace homography_teach_repeat {

// `~image_transport` of a node: "raw" (default) or "compressed". Throws std::invalid_argument
// naming the parameter and the accepted values for anything else.
std::string readImageTransport(const ros::NodeHandle& private_nh);

class CameraSubscription {
 public:
  using ImageCallback =
      std::function<void(const sensor_msgs::ImageConstPtr&, const sensor_msgs::CameraInfoConstPtr&)>;

  // `image_topic` is resolved in `nh` (e.g. "camera/image_raw"); the transport is the node's
  // `~image_transport` (readImageTransport: throws std::invalid_argument naming the parameter).
  CameraSubscription(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh, const std::string& image_topic,
                     uint32_t queue_size, const std::string& node_name, ImageCallback on_image);
  CameraSubscription(const CameraSubscription&) = delete;
  CameraSubscription& operator=(const CameraSubscription&) = delete;

  // The topic the images come on (IMAGE_TOPIC, or IMAGE_TOPIC/compressed), resolved.
  std::string getTopic() const;
  // Into a node's diagnostics: the transport, the frames dropped undecodable, and a WARN naming the
  // last one when it was dropped within the last `recent` seconds.
  void addDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat, double recent = 10.0) const;

 private:
  void onCompressed(const sensor_msgs::CompressedImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info);

  std::string transport_;
  std::string node_name_;
  ImageCallback on_image_;
  std::atomic<std::size_t> undecodable_{0};
  mutable std::mutex error_mutex_;
  std::string last_error_;
  ros::Time last_error_time_;
  ros::WallTime last_logged_;
  // raw
  image_transport::CameraSubscriber raw_;
  // compressed
  std::unique_ptr<message_filters::Subscriber<sensor_msgs::CompressedImage>> compressed_;
  std::unique_ptr<message_filters::Subscriber<sensor_msgs::CameraInfo>> camera_info_;
  std::unique_ptr<message_filters::TimeSynchronizer<sensor_msgs::CompressedImage, sensor_msgs::CameraInfo>> synchronizer_;
};

}  // namespace homography_teach_repeat
