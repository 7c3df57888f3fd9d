#include "homography_teach_repeat/eval/bag_sequence.h"

#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <rosbag/view.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <tf2/buffer_core.h>
#include <tf2/exceptions.h>
#include <tf2_msgs/TFMessage.h>

#include <Eigen/Geometry>

#include <cmath>
#include <map>
#include <memory>
#include <optional>
#include <set>

#include "homography_teach_repeat/ros/compressed_image.h"
#include "homography_teach_repeat/ros/conversions.h"

namespace homography_teach_repeat {
namespace eval {
namespace {

Status invalid(const std::string& message) { return Status(StatusCode::kInvalidInput, message); }

// The topics of `type` in the bag, for a message naming what is there.
std::string topicsOfType(const rosbag::Bag& bag, const std::string& type) {
  rosbag::View view(bag);
  std::set<std::string> topics;
  for (const auto* connection : view.getConnections()) {
    if (connection->datatype == type) topics.insert(connection->topic);
  }
  if (topics.empty()) return "the bag has no " + type + " topic";
  std::string list;
  for (const auto& t : topics) list += (list.empty() ? "" : ", ") + t;
  return "the bag's " + type + " topics: " + list;
}

// `topic` as the bag names it: rosbag record writes absolute names, bags written by programs may
// hold relative ones; "/odom" and "odom" are the same topic to a user. Empty: not in the bag.
std::string resolveTopic(const rosbag::Bag& bag, const std::string& topic, const std::string& type) {
  const std::string other = topic.rfind('/', 0) == 0 ? topic.substr(1) : "/" + topic;
  for (const std::string& name : {topic, other}) {
    rosbag::View view(bag, rosbag::TopicQuery(name));
    for (const auto* connection : view.getConnections()) {
      if (connection->datatype == type) return name;
    }
  }
  return "";
}

// The header of an image message (raw or compressed); nullopt for another type.
std::optional<std_msgs::Header> imageHeader(const rosbag::MessageInstance& message, bool compressed) {
  if (compressed) {
    const auto image = message.instantiate<sensor_msgs::CompressedImage>();
    if (image) return image->header;
  } else {
    const auto image = message.instantiate<sensor_msgs::Image>();
    if (image) return image->header;
  }
  return std::nullopt;
}

Expected<std::vector<StampedPose2D>> readOdometry(const rosbag::Bag& bag, const std::string& topic) {
  std::vector<StampedPose2D> samples;
  rosbag::View view(bag, rosbag::TopicQuery(topic));
  for (const auto& message : view) {
    const auto odometry = message.instantiate<nav_msgs::Odometry>();
    if (!odometry) continue;
    const auto pose = ros_conversions::toPose2D(odometry->pose.pose);
    if (!pose) return invalid(topic + " at " + std::to_string(odometry->header.stamp.toSec()) + ": " + pose.status().message());
    const double stamp = odometry->header.stamp.toSec();
    if (!samples.empty() && !(stamp > samples.back().stamp)) continue;  // duplicates / out of order
    samples.push_back({stamp, *pose});
  }
  return samples;
}

}  // namespace

Expected<RecordedSequence> readBagSequence(const std::string& path, const BagTopics& topics) {
  auto bag = std::make_shared<rosbag::Bag>();
  try {
    bag->open(path, rosbag::bagmode::Read);
  } catch (const std::exception& e) {
    return invalid("cannot open bag '" + path + "': " + e.what());
  }
  // The images: sensor_msgs/Image on the topic, or sensor_msgs/CompressedImage on it or on
  // <topic>/compressed (what a camera driver publishes and rosbag record records over wifi).
  const std::string raw_type = "sensor_msgs/Image", compressed_type = "sensor_msgs/CompressedImage";
  std::string image_topic = resolveTopic(*bag, topics.image, raw_type);
  bool compressed = false;
  if (image_topic.empty()) {
    for (const std::string& candidate : {topics.image, topics.image + "/compressed"}) {
      image_topic = resolveTopic(*bag, candidate, compressed_type);
      if (!image_topic.empty()) break;
    }
    compressed = !image_topic.empty();
  }
  if (image_topic.empty()) {
    return invalid("bag '" + path + "' has no image topic '" + topics.image + "' (" + topicsOfType(*bag, raw_type) +
                   "; " + topicsOfType(*bag, compressed_type) + ")");
  }
  std::string info_request = topics.camera_info;
  if (info_request.empty()) info_request = topics.image.substr(0, topics.image.rfind('/') + 1) + "camera_info";
  const std::string info_type = "sensor_msgs/CameraInfo";
  const std::string info_topic = resolveTopic(*bag, info_request, info_type);
  if (info_topic.empty()) {
    return invalid("bag '" + path + "' has no camera_info topic '" + info_request + "' (" +
                   topicsOfType(*bag, info_type) + "); the camera calibration is needed");
  }
  const std::string odometry_type = "nav_msgs/Odometry";
  const std::string odometry_topic = resolveTopic(*bag, topics.odometry, odometry_type);
  if (odometry_topic.empty()) {
    return invalid("bag '" + path + "' has no odometry topic '" + topics.odometry + "' (" +
                   topicsOfType(*bag, odometry_type) + ")");
  }
  std::string truth_topic;
  if (!topics.ground_truth.empty()) {
    truth_topic = resolveTopic(*bag, topics.ground_truth, odometry_type);
    if (truth_topic.empty()) {
      return invalid("bag '" + path + "' has no ground-truth topic '" + topics.ground_truth + "' (" +
                     topicsOfType(*bag, odometry_type) + ")");
    }
  }

  RecordedSequence sequence;
  // Camera: the first camera_info.
  std::optional<CameraCalibration> calibration;
  {
    rosbag::View view(*bag, rosbag::TopicQuery(info_topic));
    for (const auto& message : view) {
      const auto info = message.instantiate<sensor_msgs::CameraInfo>();
      if (!info) continue;
      const auto camera = ros_conversions::toPinholeCamera(*info);
      if (!camera) return invalid(info_topic + ": " + camera.status().message());
      calibration = ros_conversions::toCalibration(*info);
      break;
    }
  }
  if (!calibration) return invalid("bag '" + path + "': no message on '" + info_topic + "'");

  // Images: stamps and bag times (to find each again).
  std::vector<ros::Time> bag_times;
  std::string camera_frame;
  {
    rosbag::View view(*bag, rosbag::TopicQuery(image_topic));
    for (const auto& message : view) {
      const auto header = imageHeader(message, compressed);
      if (!header) continue;
      const double stamp = header->stamp.toSec();
      if (!sequence.stamps.empty() && !(stamp > sequence.stamps.back())) continue;
      sequence.stamps.push_back(stamp);
      bag_times.push_back(message.getTime());
      if (camera_frame.empty()) camera_frame = header->frame_id;
    }
  }
  if (sequence.stamps.size() < 2) return invalid("bag '" + path + "': fewer than 2 images on '" + image_topic + "'");

  auto odometry = readOdometry(*bag, odometry_topic);
  if (!odometry) return odometry.status();
  if (odometry->empty()) return invalid("bag '" + path + "': no message on the odometry topic '" + topics.odometry + "'");
  sequence.odometry = std::move(*odometry);
  if (!truth_topic.empty()) {
    auto truth = readOdometry(*bag, truth_topic);
    if (!truth) return truth.status();
    if (truth->empty()) return invalid("bag '" + path + "': no message on the ground-truth topic '" + topics.ground_truth + "'");
    sequence.ground_truth = std::move(*truth);
  }

  // The camera mount from the bag's tf.
  tf2::BufferCore tf(ros::Duration(std::max(1.0, sequence.stamps.back() - sequence.stamps.front() + 10.0)));
  {
    rosbag::View view(*bag, rosbag::TopicQuery(std::vector<std::string>{"/tf", "/tf_static", "tf", "tf_static"}));
    for (const auto& message : view) {
      const auto transforms = message.instantiate<tf2_msgs::TFMessage>();
      if (!transforms) continue;
      const bool is_static = message.getTopic() == "/tf_static" || message.getTopic() == "tf_static";
      for (const auto& t : transforms->transforms) tf.setTransform(t, "bag", is_static);
    }
  }
  Eigen::Isometry3d base_T_optical;
  try {
    base_T_optical = ros_conversions::toIsometry(
        tf.lookupTransform(topics.base_frame, camera_frame, ros::Time(0)).transform);
  } catch (const tf2::TransformException& e) {
    return invalid("bag '" + path + "': no tf " + topics.base_frame + " -> " + camera_frame +
                   " (the camera mount; record /tf_static): " + e.what());
  }
  try {
    // Any tilt up to 30 deg: it is removed by the level rotation below.
    const CameraMount mount = CameraMount::fromExtrinsic(base_T_optical, 0.52);
    sequence.camera_mount = mount.forwardFrame();
  } catch (const std::invalid_argument& e) {
    return invalid(std::string("camera mount: ") + e.what());
  }
  sequence.mount_camera_to_level = CameraMount::cameraToLevel(base_T_optical);
  const double tilt_deg = Eigen::AngleAxisd(sequence.mount_camera_to_level).angle() * 180.0 / M_PI;
  sequence.mount_source = "tf " + topics.base_frame + " -> " + camera_frame + " (tilt " + std::to_string(tilt_deg) + " deg)";
  sequence.description = "bag '" + path + "', " + std::to_string(sequence.stamps.size()) + " images on " + image_topic + (compressed ? " (compressed)" : "");

  const CameraCalibration camera = *calibration;
  const std::vector<double> stamps = sequence.stamps;
  sequence.load_image = [bag, image_topic, compressed, camera, bag_times, stamps](int index) -> Expected<SequenceImage> {
    const auto i = static_cast<std::size_t>(index);
    rosbag::View view(*bag, rosbag::TopicQuery(image_topic), bag_times[i], bag_times[i]);
    for (const auto& message : view) {
      const auto header = imageHeader(message, compressed);
      if (!header || std::abs(header->stamp.toSec() - stamps[i]) > 1e-9) continue;
      sensor_msgs::ImageConstPtr image;
      if (compressed) {
        auto decoded = ros_conversions::decompress(*message.instantiate<sensor_msgs::CompressedImage>());
        if (!decoded) return invalid(image_topic + " image " + std::to_string(index) + ": " + decoded.status().message());
        image = *decoded;
      } else {
        image = message.instantiate<sensor_msgs::Image>();
      }
      auto converted = ros_conversions::toCvImage(image);
      if (!converted) return invalid(image_topic + " image " + std::to_string(index) + ": " + converted.status().message());
      if (converted->cols != camera.width || converted->rows != camera.height) {
        return invalid(image_topic + " image " + std::to_string(index) + " is " + std::to_string(converted->cols) + "x" +
                       std::to_string(converted->rows) + ", camera_info says " + std::to_string(camera.width) + "x" +
                       std::to_string(camera.height));
      }
      return SequenceImage{converted->clone(), camera, std::nullopt};
    }
    return invalid(image_topic + ": image " + std::to_string(index) + " not found again in the bag");
  };
  return sequence;
}

}  // namespace eval
}  // namespace homography_teach_repeat
