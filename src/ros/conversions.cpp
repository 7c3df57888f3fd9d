#include "homography_teach_repeat/ros/conversions.h"

#include "homography_teach_repeat/ros/repeat_visualization.h"

#include <cv_bridge/cv_bridge.h>
#include <sensor_msgs/image_encodings.h>

#include <cmath>
#include <optional>
#include <stdexcept>

namespace homography_teach_repeat {
namespace ros_conversions {

CameraCalibration toCalibration(const sensor_msgs::CameraInfo& info) {
  CameraCalibration c;
  c.width = static_cast<int>(info.width);
  c.height = static_cast<int>(info.height);
  c.fx = info.K[0];
  c.fy = info.K[4];
  c.cx = info.K[2];
  c.cy = info.K[5];
  c.distortion_model = info.distortion_model;
  c.distortion = info.D;
  // camera_info commonly carries D = [0, 0, 0, 0, 0] with an empty model name.
  if (c.distortion_model.empty()) {
    bool all_zero = true;
    for (double d : c.distortion) all_zero = all_zero && d == 0.0;
    if (all_zero) c.distortion.clear();
  }
  return c;
}

Expected<PinholeCamera> toPinholeCamera(const sensor_msgs::CameraInfo& info) {
  try {
    return PinholeCamera(toCalibration(info));
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, std::string("camera_info: ") + e.what());
  }
}

Expected<cv::Mat> toCvImage(const sensor_msgs::ImageConstPtr& image) {
  namespace enc = sensor_msgs::image_encodings;
  if (image->width == 0 || image->height == 0 || image->data.empty()) {
    return Status(StatusCode::kInvalidInput, "empty image (" + std::to_string(image->width) + "x" +
                                                 std::to_string(image->height) + ")");
  }
  if (static_cast<std::size_t>(image->step) * image->height > image->data.size()) {
    return Status(StatusCode::kInvalidInput,
                  "truncated image: step*height = " +
                      std::to_string(static_cast<std::size_t>(image->step) * image->height) +
                      " bytes but only " + std::to_string(image->data.size()) + " in data");
  }
  const std::string& encoding = image->encoding;
  const bool mono = encoding == enc::MONO8 || encoding == enc::TYPE_8UC1;
  const bool colour = encoding == enc::BGR8 || encoding == enc::RGB8 || encoding == enc::BGRA8 ||
                      encoding == enc::RGBA8;
  if (!mono && !colour) {
    return Status(StatusCode::kInvalidInput,
                  "unsupported image encoding '" + encoding +
                      "' (accepted: mono8, 8UC1, bgr8, rgb8, bgra8, rgba8)");
  }
  const int bytes_per_pixel = enc::numChannels(encoding) * (enc::bitDepth(encoding) / 8);
  if (image->step < image->width * static_cast<uint32_t>(bytes_per_pixel)) {
    return Status(StatusCode::kInvalidInput, "image step " + std::to_string(image->step) +
                                                 " is smaller than a row of " + encoding);
  }
  try {
    const auto cv_image = cv_bridge::toCvShare(image, mono ? enc::MONO8 : enc::BGR8);
    if (cv_image->image.empty()) return Status(StatusCode::kInvalidInput, "empty image");
    return cv_image->image;
  } catch (const cv_bridge::Exception& e) {
    return Status(StatusCode::kInvalidInput,
                  "cannot convert image with encoding '" + encoding + "': " + e.what());
  }
}

HomographyStamped toMsg(const RobustHomographyResult& homography, int tentative_matches,
                        const std_msgs::Header& header, const std::string& reference) {
  HomographyStamped msg;
  msg.header = header;
  msg.reference = reference;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) msg.h[static_cast<std::size_t>(3 * r + c)] = homography.H(r, c);
  }
  msg.matches = static_cast<uint32_t>(tentative_matches);
  msg.inliers = static_cast<uint32_t>(homography.inliers.size());
  msg.rms_transfer_error_px = homography.rms_transfer_error_px;
  return msg;
}

geometry_msgs::Quaternion yawQuaternion(double yaw) {
  geometry_msgs::Quaternion q;
  q.z = std::sin(yaw / 2.0);
  q.w = std::cos(yaw / 2.0);
  return q;
}

Expected<Pose2D> toPose2D(const geometry_msgs::Pose& pose) {
  const auto& p = pose.position;
  const auto& q = pose.orientation;
  if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z) || !std::isfinite(q.x) ||
      !std::isfinite(q.y) || !std::isfinite(q.z) || !std::isfinite(q.w)) {
    return Status(StatusCode::kInvalidInput, "pose has NaN/Inf values");
  }
  const double norm = std::sqrt(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w);
  if (std::abs(norm - 1.0) > 1e-3) {
    return Status(StatusCode::kInvalidInput, "pose orientation is not a unit quaternion");
  }
  // Yaw about z of the rotation (REP-103, Tait-Bryan z-y-x).
  const double yaw = std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
  return Pose2D(p.x, p.y, yaw);
}

Eigen::Isometry3d toIsometry(const geometry_msgs::Transform& transform) {
  Eigen::Isometry3d iso = Eigen::Isometry3d::Identity();
  iso.translation() = Eigen::Vector3d(transform.translation.x, transform.translation.y,
                                      transform.translation.z);
  iso.linear() = Eigen::Quaterniond(transform.rotation.w, transform.rotation.x,
                                    transform.rotation.y, transform.rotation.z)
                     .normalized()
                     .toRotationMatrix();
  return iso;
}

Expected<MountFromTf> lookupCameraMount(const tf2_ros::Buffer& tf_buffer, const std::string& base_frame,
                                        const std::string& camera_frame, double max_tilt_rad) {
  geometry_msgs::TransformStamped mount;
  try {
    mount = tf_buffer.lookupTransform(base_frame, camera_frame, ros::Time(0), ros::Duration(0.5));
  } catch (const tf2::TransformException& e) {
    return Status(StatusCode::kInvalidInput, "no tf " + base_frame + " -> " + camera_frame + ": " + e.what());
  }
  try {
    const Eigen::Isometry3d base_T_optical = toIsometry(mount.transform);
    return MountFromTf{CameraMount::fromExtrinsic(base_T_optical, max_tilt_rad), CameraMount::cameraToLevel(base_T_optical),
                       CameraMount::tiltOf(base_T_optical)};
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, std::string("camera mount: ") + e.what());
  }
}

namespace {
// Rows and columns of x, y and yaw in the row-major 6x6 (x, y, z, roll, pitch, yaw) covariance.
constexpr std::size_t kPlanarIndex[3] = {0, 1, 5};
}  // namespace

geometry_msgs::PoseWithCovariance toPoseWithCovariance(const Pose2D& pose, const Eigen::Matrix3d* covariance,
                                                       double unobserved_variance) {
  geometry_msgs::PoseWithCovariance message;
  message.pose.position.x = pose.x;
  message.pose.position.y = pose.y;
  message.pose.orientation = yawQuaternion(pose.yaw);
  auto& c = message.covariance;
  c.fill(0.0);
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) {
      c[kPlanarIndex[r] * 6 + kPlanarIndex[k]] =
          covariance != nullptr ? (*covariance)(r, k) : (r == k ? unobserved_variance : 0.0);
    }
  }
  c[2 * 6 + 2] = c[3 * 6 + 3] = c[4 * 6 + 4] = unobserved_variance;
  return message;
}

Eigen::Matrix3d planarCovariance(const geometry_msgs::PoseWithCovariance& pose) {
  Eigen::Matrix3d covariance;
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) covariance(r, k) = pose.covariance[6 * kPlanarIndex[r] + kPlanarIndex[k]];
  }
  return covariance;
}

visualization_msgs::MarkerArray routeMarkers(const Route& route, int current_keyframe, const std::string& frame_id,
                                             const ros::Time& stamp) {
  visualization_msgs::MarkerArray markers;
  for (std::size_t k = 0; k < route.keyframes.size(); ++k) {
    const bool current = static_cast<int>(k) == current_keyframe;
    visualization_msgs::Marker arrow;
    arrow.header.frame_id = frame_id;
    arrow.header.stamp = stamp;
    arrow.ns = "keyframes";
    arrow.id = static_cast<int>(k);
    arrow.type = visualization_msgs::Marker::ARROW;
    arrow.pose = toPoseWithCovariance(route.keyframes[k].pose, nullptr, 0.0).pose;
    arrow.scale.x = 0.4;
    arrow.scale.y = arrow.scale.z = 0.06;
    arrow.color.r = current ? 1.0f : 0.2f;
    arrow.color.g = current ? 0.3f : 0.6f;
    arrow.color.b = current ? 0.1f : 1.0f;
    arrow.color.a = 1.0f;
    markers.markers.push_back(arrow);
    const auto segment = keyframeWallSegment(route, k);
    if (!segment) continue;
    visualization_msgs::Marker wall;
    wall.header = arrow.header;
    wall.ns = "planes";
    wall.id = static_cast<int>(k);
    wall.type = visualization_msgs::Marker::LINE_LIST;
    wall.pose.orientation.w = 1.0;
    wall.scale.x = 0.03;
    wall.color.r = wall.color.g = 0.8f;
    wall.color.b = 0.2f;
    wall.color.a = current ? 1.0f : 0.3f;
    for (const Eigen::Vector2d& end : {segment->a, segment->b}) {
      geometry_msgs::Point point;
      point.x = end.x();
      point.y = end.y();
      wall.points.push_back(point);
    }
    markers.markers.push_back(wall);
  }
  return markers;
}

visualization_msgs::MarkerArray networkMarkers(const RouteMap& map, const std::map<std::string, Pose2D>& route_frames,
                                               const std::string& frame_id, const ros::Time& stamp) {
  visualization_msgs::MarkerArray markers;
  visualization_msgs::Marker clear;  // routes removed since the last message
  clear.header.frame_id = frame_id;
  clear.action = visualization_msgs::Marker::DELETEALL;
  markers.markers.push_back(clear);
  const auto inMap = [&](const KeyframeRef& ref) -> std::optional<geometry_msgs::Point> {
    const auto frame = route_frames.find(ref.route);
    const auto keyframe = map.keyframePose(ref);
    if (frame == route_frames.end() || !keyframe) return std::nullopt;
    const Pose2D pose = frame->second.compose(*keyframe);
    geometry_msgs::Point point;
    point.x = pose.x;
    point.y = pose.y;
    return point;
  };
  int id = 0;
  for (const MapRoute& r : map.routes) {
    visualization_msgs::Marker line;
    line.header.frame_id = frame_id;
    line.header.stamp = stamp;
    line.ns = "routes";
    line.id = id++;
    line.type = visualization_msgs::Marker::LINE_STRIP;
    line.pose.orientation.w = 1.0;
    line.scale.x = 0.04;
    line.color.r = 0.3f;
    line.color.g = 0.8f;
    line.color.b = 0.3f;
    line.color.a = 0.8f;
    for (const RouteKeyframe& k : r.route.keyframes) {
      if (const auto point = inMap(KeyframeRef{r.name, k.index})) line.points.push_back(*point);
    }
    if (line.points.empty()) continue;
    visualization_msgs::Marker name = line;
    name.ns = "route_names";
    name.type = visualization_msgs::Marker::TEXT_VIEW_FACING;
    name.points.clear();
    name.pose.position = line.points.front();
    name.pose.position.z = 0.3;
    name.scale.x = name.scale.y = 0.0;
    name.scale.z = 0.2;
    name.color.r = name.color.g = name.color.b = 1.0f;
    name.text = r.name;
    markers.markers.push_back(line);
    markers.markers.push_back(name);
  }
  visualization_msgs::Marker junctions;
  junctions.header.frame_id = frame_id;
  junctions.header.stamp = stamp;
  junctions.ns = "junctions";
  junctions.type = visualization_msgs::Marker::SPHERE_LIST;
  junctions.pose.orientation.w = 1.0;
  junctions.scale.x = junctions.scale.y = junctions.scale.z = 0.2;
  junctions.color.r = 1.0f;
  junctions.color.g = 0.5f;
  junctions.color.a = 0.9f;
  for (const Junction& j : map.junctions) {
    if (const auto point = inMap(j.from)) junctions.points.push_back(*point);
  }
  if (!junctions.points.empty()) markers.markers.push_back(junctions);
  return markers;
}

}  // namespace ros_conversions
}  // namespace homography_teach_repeat
