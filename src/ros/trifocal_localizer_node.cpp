#include "homography_teach_repeat/ros/trifocal_localizer_node.h"

#include <geometry_msgs/PoseArray.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <stdexcept>

#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {
namespace {

// The odometry of an image's instant may arrive just after the image (see repeat_node).
constexpr double kOdometryLag = 0.1;

TrifocalLocalizerOptions readOptions(const ros::NodeHandle& nh) {
  TrifocalLocalizerOptions o;
  readParameters(nh, [&] {
    o.features.type = featureTypeFromString(readParameter<std::string>(nh, "feature_type", "sift"));
    o.features.max_features = readParameter(nh, "max_features", 1500);
    o.matching.ratio = readParameter(nh, "match_ratio", o.matching.ratio);
    o.ransac.method = trifocalMethodFromString(readParameter<std::string>(nh, "method", "TT5"));
    o.ransac.confidence = readParameter(nh, "confidence", o.ransac.confidence);
    o.ransac.max_iterations = readParameter(nh, "max_iterations", o.ransac.max_iterations);
    o.motion.min_in_front_fraction = readParameter(nh, "min_in_front_fraction", o.motion.min_in_front_fraction);
    o.motion.refine = readParameter(nh, "refine", o.motion.refine);
    o.min_inliers = readParameter(nh, "min_inliers", o.min_inliers);
    o.min_off_plane = readParameter(nh, "min_off_plane", o.min_off_plane);
    o.min_off_plane_fraction = readParameter(nh, "min_off_plane_fraction", o.min_off_plane_fraction);
    o.max_prior_disagreement_fraction =
        readParameter(nh, "max_prior_disagreement_fraction", o.max_prior_disagreement_fraction);
    o.max_prior_heading_disagreement =
        readParameter(nh, "max_prior_heading_disagreement", o.max_prior_heading_disagreement);
    o.validate();
  });
  return o;
}

void requirePositive(const ros::NodeHandle& nh, const std::string& name, double value) {
  if (!std::isfinite(value) || !(value > 0.0)) {
    throw std::runtime_error("parameter '" + nh.resolveName(name) + "' must be finite and > 0");
  }
}

geometry_msgs::Pose toPoseMsg(const Pose2D& pose) {
  geometry_msgs::Pose msg;
  msg.position.x = pose.x;
  msg.position.y = pose.y;
  msg.orientation = ros_conversions::yawQuaternion(pose.yaw);
  return msg;
}

}  // namespace

TrifocalLocalizerNode::TrifocalLocalizerNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      base_frame_(readParameter<std::string>(private_nh, "base_frame", "base_link")),
      odom_frame_(readParameter<std::string>(private_nh, "odom_frame", "odom")),
      min_baseline_(readParameter(private_nh, "min_baseline", 0.3)),
      max_camera_tilt_(readParameter(private_nh, "max_camera_tilt", 0.05)),
      max_transfer_error_px_(readParameter(private_nh, "max_transfer_error", 3.0)),
      options_(readOptions(private_nh)),
      tf_listener_(tf_buffer_),
      diagnostics_(nh, private_nh) {
  requirePositive(private_nh, "min_baseline", min_baseline_);
  requirePositive(private_nh, "max_camera_tilt", max_camera_tilt_);
  requirePositive(private_nh, "max_transfer_error", max_transfer_error_px_);
  poses_publisher_ = private_nh_.advertise<geometry_msgs::PoseArray>("poses", 5);
  landmarks_publisher_ = private_nh_.advertise<visualization_msgs::MarkerArray>("landmarks", 5);
  odometry_subscriber_ = nh_.subscribe("odom", 50, &TrifocalLocalizerNode::onOdometry, this, ros::TransportHints().tcpNoDelay());
  camera_subscriber_ = std::make_unique<CameraSubscription>(
      nh_, private_nh_, "camera/image_raw", 1, "trifocal_localizer",
      [this](const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) { onImage(image, info); });
  diagnostics_.setHardwareID("trifocal_localizer");
  diagnostics_.add("three-view localization", this, &TrifocalLocalizerNode::produceDiagnostics);
  diagnostics_timer_ = nh_.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) { diagnostics_.update(); });
  ROS_INFO("trifocal_localizer: %s, a view every %.2f m, transfer threshold %.1f px",
           toString(options_.ransac.method).c_str(), min_baseline_, max_transfer_error_px_);
}

void TrifocalLocalizerNode::onOdometry(const nav_msgs::OdometryConstPtr& odometry) {
  const auto pose = ros_conversions::toPose2D(odometry->pose.pose);
  std::lock_guard<std::mutex> lock(mutex_);
  if (!pose) {
    last_status_ = Status(StatusCode::kInvalidInput, "odometry rejected: " + pose.status().message());
    ROS_WARN_THROTTLE(5.0, "trifocal_localizer: %s", last_status_.message().c_str());
    return;
  }
  const Status added = odometry_.add(odometry->header.stamp.toSec(), *pose);
  if (!added.isOk()) {
    last_status_ = Status(added.code(), "odometry rejected: " + added.message());
    ROS_WARN_THROTTLE(5.0, "trifocal_localizer: %s", last_status_.message().c_str());
  }
}

Status TrifocalLocalizerNode::ensureLocalizer(const sensor_msgs::CameraInfo& camera_info) {
  if (localizer_) return Status::ok();
  const auto camera = ros_conversions::toPinholeCamera(camera_info);
  if (!camera) return camera.status();
  const auto mount =
      ros_conversions::lookupCameraMount(tf_buffer_, base_frame_, camera_info.header.frame_id, max_camera_tilt_);
  if (!mount) return mount.status();
  // Bearings are taken in the level camera (docs/math.md §1.1): a tilted mount's rays are levelled.
  CameraCalibration calibration = camera->calibration();
  calibration.camera_to_level = mount->camera_to_level;
  TrifocalLocalizerOptions options = options_;
  // The threshold in pixels of this camera (bearing noise scales with 1/f).
  options.ransac.max_transfer_error = max_transfer_error_px_ / camera->fx();
  try {
    localizer_.emplace(PinholeCamera(calibration), mount->mount, options);
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  ROS_INFO("trifocal_localizer: camera %dx%d, fx %.1f px, mount (%.2f, %.2f, %.3f)", camera->width(),
           camera->height(), camera->fx(), mount->mount.forwardFrame().x, mount->mount.forwardFrame().y,
           mount->mount.forwardFrame().yaw);
  return Status::ok();
}

void TrifocalLocalizerNode::onImage(const sensor_msgs::ImageConstPtr& image,
                                    const sensor_msgs::CameraInfoConstPtr& camera_info) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto fail = [&](const Status& status) {
    last_status_ = status;
    ++failures_;
    ROS_WARN_THROTTLE(2.0, "trifocal_localizer: %s", status.toString().c_str());
  };
  const auto odometry = odometry_.poseNear(image->header.stamp.toSec(), kOdometryLag);
  if (!odometry) {
    last_status_ = Status(odometry.status().code(), "no odometry at the image stamp: " + odometry.status().message());
    ROS_WARN_THROTTLE(5.0, "trifocal_localizer: %s", last_status_.message().c_str());
    return;
  }
  if (!views_.empty()) {
    const Pose2D& previous = views_.back().odometry;
    if (std::hypot(odometry->x - previous.x, odometry->y - previous.y) < min_baseline_) return;  // not a new view
  }
  const Status ready = ensureLocalizer(*camera_info);
  if (!ready.isOk()) return fail(ready);
  const auto cv_image = ros_conversions::toCvImage(image);
  if (!cv_image) return fail(cv_image.status());
  auto features = localizer_->extract(*cv_image);
  if (!features) return fail(features.status());
  TrifocalView view{std::move(*features), *odometry};
  ++views_taken_;
  if (views_.size() == 2) {
    const auto result = localizer_->localize(views_[0], views_[1], view, shared_motion_);
    shared_motion_.reset();
    if (result) {
      shared_motion_ = result->base_poses[1].inverse().compose(result->base_poses[2]);
      last_status_ = Status::ok();
      ++localizations_;
      last_triplets_ = result->triplets;
      last_inliers_ = result->inliers;
      last_off_plane_ = result->off_plane;
      ROS_DEBUG("trifocal_localizer: %d matches, %d inliers (%d off the dominant wall)%s", result->triplets,
                result->inliers, result->off_plane, result->ambiguous ? ", ambiguous: odometry chose" : "");
      publish(image->header, *result);
    } else {
      fail(result.status());
    }
    views_.pop_front();
  }
  views_.push_back(std::move(view));
}

void TrifocalLocalizerNode::publish(const std_msgs::Header& header, const TrifocalLocalization& result) {
  geometry_msgs::PoseArray poses;
  poses.header.stamp = header.stamp;
  poses.header.frame_id = odom_frame_;
  for (const auto& pose : result.base_poses) poses.poses.push_back(toPoseMsg(pose));
  poses_publisher_.publish(poses);
  if (landmarks_publisher_.getNumSubscribers() == 0) return;
  visualization_msgs::MarkerArray markers;
  visualization_msgs::Marker points;
  points.header = poses.header;
  points.ns = "landmarks";
  points.id = 0;
  points.type = visualization_msgs::Marker::SPHERE_LIST;
  points.action = visualization_msgs::Marker::ADD;
  points.pose.orientation.w = 1.0;
  points.scale.x = points.scale.y = points.scale.z = 0.05;
  points.color.r = 0.9f;
  points.color.g = 0.5f;
  points.color.a = 1.0f;
  for (const auto& landmark : result.landmarks) {
    geometry_msgs::Point p;
    p.x = landmark.x();
    p.y = landmark.y();
    points.points.push_back(p);
  }
  markers.markers.push_back(points);
  landmarks_publisher_.publish(markers);
}

void TrifocalLocalizerNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (last_status_.isOk()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "localized");
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, last_status_.toString());
  }
  if (camera_subscriber_) camera_subscriber_->addDiagnostics(stat);
  stat.add("views taken", views_taken_);
  stat.add("localizations", localizations_);
  stat.add("failures", failures_);
  stat.add("three-view matches (last)", last_triplets_);
  stat.add("tensor inliers (last)", last_inliers_);
  stat.add("inliers off the dominant wall (last)", last_off_plane_);
  stat.add("method", toString(options_.ransac.method));
}

}  // namespace homography_teach_repeat
