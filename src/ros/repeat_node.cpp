#include "homography_teach_repeat/ros/repeat_node.h"

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <visualization_msgs/MarkerArray.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>
#include <vector>

#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {
namespace {

// The odometry of an image's instant may arrive after the image (a simulator publishes both at
// once); for the odometry gate the newest sample is close enough within this lag [s].
constexpr double kOdometryLagForGate = 0.1;

RepeatOptions readRepeatOptions(const ros::NodeHandle& nh) {
  RepeatOptions options;
  try {
    options.mode = repeatModeFromString(readParameter<std::string>(nh, "mode", "fast_hd"));
    options.max_features = readParameter(nh, "max_features", options.max_features);
    options.pose.pixel_sigma_px = readParameter(nh, "pixel_sigma", options.pose.pixel_sigma_px);
    options.pose.refine = readParameter(nh, "refine", options.pose.refine);
    options.min_inliers = readParameter(nh, "min_inliers", options.min_inliers);
    options.neighbour_search = readParameter(nh, "neighbour_search", options.neighbour_search);
    options.max_degraded_frames = readParameter(nh, "max_degraded_frames", options.max_degraded_frames);
    options.max_tracked_frames = readParameter(nh, "max_tracked_frames", options.max_tracked_frames);
    options.tracking_tolerance_px = readParameter(nh, "tracking_tolerance", options.tracking_tolerance_px);
    options.max_plane_residual_px = readParameter(nh, "max_plane_residual", options.max_plane_residual_px);
    options.closed_route_gap = readParameter(nh, "closed_route_gap", options.closed_route_gap);
    options.mu_skip_turn_keyframes = readParameter(nh, "mu_skip_turn_keyframes", options.mu_skip_turn_keyframes);
    options.mu_max_reference_angle = readParameter(nh, "mu_max_reference_angle", options.mu_max_reference_angle);
    options.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("invalid parameter in " + nh.getNamespace() + ": " + e.what());
  }
  return options;
}

// The run-time tunables of RepeatOptions as dynamic_reconfigure reports them.
void writeTunables(const RepeatOptions& options, RepeatConfig& config) {
  config.mode = toString(options.mode);
  config.pixel_sigma = options.pose.pixel_sigma_px;
  config.refine = options.pose.refine;
  config.min_inliers = options.min_inliers;
  config.neighbour_search = options.neighbour_search;
  config.max_degraded_frames = options.max_degraded_frames;
}

HeadingAidedOdometryOptions readHeadingAidedOptions(const ros::NodeHandle& nh) {
  HeadingAidedOdometryOptions o;
  try {
    o.initial_position_variance = readParameter(nh, "mu_initial_position_variance", o.initial_position_variance);
    o.position_variance_per_metre = readParameter(nh, "mu_position_variance_per_metre", o.position_variance_per_metre);
    o.heading_fix_variance = readParameter(nh, "mu_heading_fix_variance", o.heading_fix_variance);
    o.heading_variance_per_metre = readParameter(nh, "mu_heading_variance_per_metre", o.heading_variance_per_metre);
    o.heading_variance_per_radian = readParameter(nh, "mu_heading_variance_per_radian", o.heading_variance_per_radian);
    o.min_mu_variance = readParameter(nh, "mu_variance", o.min_mu_variance);
    o.innovation_gate = readParameter(nh, "mu_innovation_gate", o.innovation_gate);
    o.refused_before_reset = readParameter(nh, "mu_gate_switch_after", o.refused_before_reset);
    o.max_mu_step_px = readParameter(nh, "mu_max_step", o.max_mu_step_px);
    o.max_confirmation_distance = readParameter(nh, "mu_max_confirmation_distance", o.max_confirmation_distance);
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("invalid parameter in " + nh.getNamespace() + ": " + e.what());
  }
  return o;
}

OdometryGateOptions readGateOptions(const ros::NodeHandle& nh) {
  OdometryGateOptions o;
  try {
    o.position_tolerance = readParameter(nh, "gate_position_tolerance", o.position_tolerance);
    o.heading_tolerance = readParameter(nh, "gate_heading_tolerance", o.heading_tolerance);
    o.drift_fraction = readParameter(nh, "gate_drift_fraction", o.drift_fraction);
    o.heading_drift_per_metre = readParameter(nh, "gate_heading_drift_per_metre", o.heading_drift_per_metre);
    o.rotation_drift_fraction = readParameter(nh, "gate_rotation_drift_fraction", o.rotation_drift_fraction);
    o.switch_after = readParameter(nh, "gate_switch_after", o.switch_after);
    o.window = readParameter(nh, "gate_window", o.window);
    o.validate();
  } catch (const std::invalid_argument& e) {
    throw std::runtime_error("invalid parameter in " + nh.getNamespace() + ": " + e.what());
  }
  return o;
}

}  // namespace

RepeatNode::RepeatNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      map_frame_(readParameter<std::string>(private_nh, "map_frame", "map")),
      odom_frame_(readParameter<std::string>(private_nh, "odom_frame", "odom")),
      publish_tf_(readParameter(private_nh, "publish_tf", false)),
      unobserved_variance_(readParameter(private_nh, "unobserved_variance", 1e6)),
      start_keyframe_(readParameter(private_nh, "start_keyframe", 0)),
      mu_max_unaided_distance_(readParameter(private_nh, "mu_max_unaided_distance", 3.0)),
      image_transport_(nh),
      diagnostics_(nh, private_nh) {
  const std::string directory = readRequiredParameter<std::string>(private_nh, "route_directory");
  const RepeatOptions options = readRepeatOptions(private_nh);
  mode_ = options.mode;
  options_ = options;
  heading_aided_ = HeadingAidedOdometry(readHeadingAidedOptions(private_nh));
  if (readParameter(private_nh, "odometry_gate", true)) {
    const OdometryGateOptions gate = readGateOptions(private_nh);
    odometry_gate_.emplace(gate);
  }
  if (!std::isfinite(mu_max_unaided_distance_) || mu_max_unaided_distance_ < 0.0) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("mu_max_unaided_distance") +
                             "' must be finite and >= 0");
  }
  // OpenCV's worker threads (feature extraction, matching) for the whole process (a nodelet
  // manager included): 0 keeps OpenCV's default (one per core).
  const int opencv_threads = readParameter(private_nh, "opencv_threads", 0);
  if (opencv_threads < 0) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("opencv_threads") + "' must be >= 0");
  }
  if (opencv_threads > 0) cv::setNumThreads(opencv_threads);
  image_timeout_ = readParameter(private_nh, "image_timeout", image_timeout_);
  if (!std::isfinite(image_timeout_) || !(image_timeout_ > 0.0)) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("image_timeout") +
                             "' must be finite and > 0");
  }
  if (!(unobserved_variance_ > 0.0)) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("unobserved_variance") +
                             "' must be > 0");
  }
  const auto route = loadRoute(directory);
  if (!route) throw std::runtime_error(route.status().message());
  auto localizer = RepeatLocalizer::create(*route, options);
  if (!localizer) throw std::runtime_error(localizer.status().message());
  localizer_.emplace(std::move(*localizer));
  if (start_keyframe_ >= localizer_->keyframeCount()) {
    throw std::runtime_error("parameter '" + private_nh.resolveName("start_keyframe") + "' = " +
                             std::to_string(start_keyframe_) + " but the route has " +
                             std::to_string(localizer_->keyframeCount()) + " keyframes");
  }
  if (start_keyframe_ >= 0) {
    localizer_->setTrackedKeyframe(start_keyframe_);
    initialized_ = true;
  }
  pose_publisher_ = private_nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 5);
  heading_publisher_ = private_nh_.advertise<HeadingCorrectionStamped>("heading_correction", 5);
  marker_publisher_ =
      private_nh_.advertise<visualization_msgs::MarkerArray>("route_markers", 1, /*latch=*/true);
  publishMarkers(localizer_->trackedKeyframe());
  image_transport::ImageTransport private_transport(private_nh_);
  debug_publisher_ = private_transport.advertise("debug_image", 1);
  odometry_subscriber_ = nh_.subscribe("odom", 50, &RepeatNode::onOdometry, this);
  camera_subscriber_ =
      image_transport_.subscribeCamera("camera/image_raw", 1, &RepeatNode::onImage, this);
  diagnostics_.setHardwareID("repeat_node");
  diagnostics_.add("localization", this, &RepeatNode::produceDiagnostics);
  start_time_ = ros::Time::now();
  diagnostics_timer_ = nh_.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      // Under use_sim_time the clock may not have started when the node was constructed.
      if (start_time_.isZero()) start_time_ = ros::Time::now();
      const double silence = cameraSilence();
      if (silence > image_timeout_) {
        ROS_WARN_THROTTLE(10.0, "repeat_node: no image on %s for %.1f s: no pose is published",
                          camera_subscriber_.getTopic().c_str(), silence);
      }
    }
    diagnostics_.update();
  });
  // dynamic_reconfigure starts from the validated parameters (one source of defaults: the YAML).
  reconfigure_server_ =
      std::make_unique<dynamic_reconfigure::Server<RepeatConfig>>(reconfigure_mutex_, private_nh_);
  RepeatConfig config = RepeatConfig::__getDefault__();  // every field initialised (UBSan)
  writeTunables(options, config);
  reconfigure_server_->updateConfig(config);
  reconfigure_server_->setCallback(
      [this](RepeatConfig& c, uint32_t level) { onReconfigure(c, level); });
  ROS_INFO("repeat_node: route '%s' with %d keyframes, mode %s", directory.c_str(),
           localizer_->keyframeCount(), toString(options.mode).c_str());
}

void RepeatNode::onReconfigure(RepeatConfig& config, uint32_t /*level*/) {
  std::lock_guard<std::mutex> lock(mutex_);
  RepeatOptions options = options_;
  auto revert = [&](const std::string& why) {
    ROS_ERROR("repeat_node: reconfiguration refused: %s; keeping mode %s", why.c_str(),
              toString(options_.mode).c_str());
    last_status_ = Status(StatusCode::kInvalidInput, "reconfiguration refused: " + why);
    writeTunables(options_, config);
  };
  try {
    options.mode = repeatModeFromString(config.mode);
  } catch (const std::invalid_argument& e) {
    return revert(e.what());
  }
  options.pose.pixel_sigma_px = config.pixel_sigma;
  options.pose.refine = config.refine;
  options.min_inliers = config.min_inliers;
  options.neighbour_search = config.neighbour_search;
  options.max_degraded_frames = config.max_degraded_frames;
  if (options.mode == options_.mode && options.pose.pixel_sigma_px == options_.pose.pixel_sigma_px &&
      options.pose.refine == options_.pose.refine && options.min_inliers == options_.min_inliers &&
      options.neighbour_search == options_.neighbour_search &&
      options.max_degraded_frames == options_.max_degraded_frames) {
    return;  // the initial callback, or nothing changed
  }
  // A new localizer with the new options (a mode change loads other keyframe data), tracking the
  // same keyframe; the old one stays when the route cannot support the change.
  auto localizer = RepeatLocalizer::create(localizer_->route(), options);
  if (!localizer) return revert(localizer.status().message());
  const int tracked = localizer_->trackedKeyframe();
  localizer_.emplace(std::move(*localizer));
  localizer_->setTrackedKeyframe(tracked);
  if (options.mode != options_.mode) debug_keyframe_ = -1;
  options_ = options;
  mode_ = options.mode;
  ROS_INFO("repeat_node: reconfigured: mode %s, min_inliers %d, neighbour_search %d, pixel_sigma %.2f px",
           toString(mode_).c_str(), options_.min_inliers, options_.neighbour_search,
           options_.pose.pixel_sigma_px);
}

void RepeatNode::onOdometry(const nav_msgs::OdometryConstPtr& odometry) {
  const auto pose = ros_conversions::toPose2D(odometry->pose.pose);
  std::lock_guard<std::mutex> lock(mutex_);
  if (!pose) {
    ROS_WARN_THROTTLE(5.0, "repeat_node: odometry rejected: %s", pose.status().message().c_str());
    return;
  }
  odometry_.add(odometry->header.stamp.toSec(), *pose);
}

void RepeatNode::onImage(const sensor_msgs::ImageConstPtr& image,
                         const sensor_msgs::CameraInfoConstPtr& camera_info) {
  const double age_ms = 1e3 * (ros::Time::now() - image->header.stamp).toSec();
  const ros::WallTime started = ros::WallTime::now();
  processImage(image, camera_info);
  const double processing_ms = 1e3 * (ros::WallTime::now() - started).toSec();
  std::lock_guard<std::mutex> lock(mutex_);
  frame_timing_.push_back({processing_ms, age_ms, frame_localize_timing_});
  if (frame_timing_.size() > kTimingWindow) frame_timing_.pop_front();
}

void RepeatNode::processImage(const sensor_msgs::ImageConstPtr& image,
                              const sensor_msgs::CameraInfoConstPtr& camera_info) {
  std::lock_guard<std::mutex> lock(mutex_);
  ++frames_;
  last_image_arrival_ = ros::Time::now();
  frame_localize_timing_.reset();
  HeadingCorrectionStamped heading;
  heading.header = image->header;
  heading.mode = toString(mode_);
  heading.reference_index = -1;
  auto fail = [&](const Status& status) {
    ++failures_;
    last_status_ = status;
    heading.ok = false;
    heading.status = status.toString();
    heading_publisher_.publish(heading);
    if (debug_publisher_.getNumSubscribers() > 0) {
      const auto current = ros_conversions::toCvImage(image);
      if (current) publishDebugImage(image, *current, nullptr, status.toString());
    }
    ROS_WARN_THROTTLE(2.0, "repeat_node: no estimate: %s", status.toString().c_str());
  };
  const auto camera = ros_conversions::toPinholeCamera(*camera_info);
  if (!camera) return fail(camera.status());
  if (camera->width() != localizer_->camera().width() ||
      camera->height() != localizer_->camera().height()) {
    return fail(Status(StatusCode::kInvalidInput,
                       "camera_info is " + std::to_string(camera->width()) + "x" +
                           std::to_string(camera->height()) + ", the route was taught at " +
                           std::to_string(localizer_->camera().width()) + "x" +
                           std::to_string(localizer_->camera().height())));
  }
  const auto cv_image = ros_conversions::toCvImage(image);
  if (!cv_image) return fail(cv_image.status());
  const auto estimate = initialized_ ? localizer_->localize(*cv_image, predictedMuPose(image->header.stamp.toSec()))
                                     : localizer_->initializeGlobally(*cv_image);
  frame_localize_timing_ = localizer_->lastTiming();
  if (!estimate) {
    fail(estimate.status());
    if (mode_ == RepeatMode::kMu) publishUnaidedMuPose(image->header);
    return;
  }
  if (estimate->has_pose && odometry_gate_) {
    const auto odom = odometry_.poseNear(image->header.stamp.toSec(), kOdometryLagForGate);
    if (odom) {
      const Status gated = odometry_gate_->check(estimate->base_pose, *odom);
      if (!gated.isOk()) {
        ++gated_;
        return fail(gated);
      }
    } else {
      ROS_WARN_THROTTLE(10.0, "repeat_node: no odometry at the image stamp, the pose is not checked "
                              "against odometry (odometry_gate): %s", odom.status().toString().c_str());
    }
  }
  std::optional<std::pair<Pose2D, Eigen::Matrix3d>> aided;
  if (!estimate->has_pose) {
    // mu mode: the fix corrects the heading-aided odometry; refused by the filter (kNoConsensus:
    // its innovation gate, or no confirmation by the previous frame) or without odometry it is a
    // failed frame.
    auto fixed = headingAidedPose(image->header.stamp.toSec(), *estimate);
    if (!fixed) {
      if (fixed.status().code() == StatusCode::kNoConsensus) ++gated_;
      fail(fixed.status());
      publishUnaidedMuPose(image->header);
      return;
    }
    aided = *fixed;
  }
  initialized_ = true;
  last_status_ = Status::ok();
  last_inliers_ = estimate->inliers;
  last_degraded_ = estimate->degraded;
  if (estimate->degraded) ++degraded_;
  heading.mode = toString(estimate->mode);
  heading.theta = estimate->heading_correction;
  heading.mu = estimate->mu;
  heading.inliers = static_cast<uint32_t>(estimate->inliers);
  heading.matches = static_cast<uint32_t>(estimate->matches);
  heading.reference_index = estimate->keyframe;
  heading.degraded = estimate->degraded;
  heading.tracked = estimate->tracked;
  heading.ok = true;
  heading.status = "ok";
  heading_publisher_.publish(heading);
  if (estimate->keyframe != last_keyframe_) {
    last_keyframe_ = estimate->keyframe;
    publishMarkers(estimate->keyframe);
  }
  if (debug_publisher_.getNumSubscribers() > 0) publishDebugImage(image, *cv_image, &*estimate, "");
  if (estimate->has_pose) {
    publishPose(image->header, estimate->base_pose,
                estimate->covariance_known ? &estimate->covariance : nullptr);
    if (publish_tf_) {
      const auto odom = odometry_.poseAt(image->header.stamp.toSec());
      if (!odom) {
        ROS_WARN_THROTTLE(5.0, "repeat_node: no map -> odom tf: %s", odom.status().toString().c_str());
        return;
      }
      publishMapToOdom(image->header.stamp, estimate->base_pose.compose(odom->inverse()));
    }
    return;
  }
  // mu mode: the heading-aided odometry corrected by this frame's μ.
  localizer_->advanceTrackingTo(aided->first);
  publishPose(image->header, aided->first, &aided->second);
  if (publish_tf_) publishMapToOdom(image->header.stamp, heading_aided_.alignment());
}

std::optional<Pose2D> RepeatNode::predictedMuPose(double stamp) {
  if (mode_ != RepeatMode::kMu || !heading_aided_.aligned()) return std::nullopt;
  const auto odom = odometry_.poseNear(stamp, kOdometryLagForGate);
  if (!odom) return std::nullopt;
  const auto predicted = heading_aided_.predictedPose(*odom);
  if (!predicted) return std::nullopt;
  return *predicted;
}

Expected<Pose2D> RepeatNode::unaidedMuPose(const Pose2D& odom) {
  if (!(mu_max_unaided_distance_ > 0.0)) {
    return Status(StatusCode::kNoConsensus, "mu mode: no heading fix in this frame and mu_max_unaided_distance is 0 "
                                            "(no pose from the odometry alone)");
  }
  const auto pose = heading_aided_.routePose(odom);
  if (!pose) return pose.status();
  if (heading_aided_.distanceSinceFix() > mu_max_unaided_distance_) {
    char message[160];
    std::snprintf(message, sizeof(message),
                  "mu mode: %.2f m without a heading fix (mu_max_unaided_distance %.2f m): no pose until vision "
                  "is back", heading_aided_.distanceSinceFix(), mu_max_unaided_distance_);
    return Status(StatusCode::kNoConsensus, message);
  }
  return pose;
}

void RepeatNode::publishUnaidedMuPose(const std_msgs::Header& image_header) {
  if (!heading_aided_.aligned()) return;
  const auto odom = odometry_.poseAt(image_header.stamp.toSec());
  if (!odom) return;
  const auto pose = unaidedMuPose(*odom);
  if (!pose) {
    ROS_WARN_THROTTLE(2.0, "repeat_node: %s", pose.status().message().c_str());
    return;
  }
  localizer_->advanceTrackingTo(*pose);
  const Eigen::Matrix3d covariance = heading_aided_.covariance();
  publishPose(image_header, *pose, &covariance);
  if (publish_tf_) publishMapToOdom(image_header.stamp, heading_aided_.alignment());
}

Expected<std::pair<Pose2D, Eigen::Matrix3d>> RepeatNode::headingAidedPose(double stamp,
                                                                         const RepeatEstimate& estimate) {
  const auto odom = odometry_.poseAt(stamp);
  if (!odom) {
    return Status(StatusCode::kInvalidInput,
                  "mu mode needs odometry ('odom') at the image stamp: " + odom.status().toString());
  }
  const RouteKeyframe& keyframe = localizer_->route().keyframes[static_cast<std::size_t>(estimate.keyframe)];
  const double route_yaw = wrapToPi(keyframe.pose.yaw + estimate.heading_correction);
  const bool aligning = !heading_aided_.aligned();
  if (aligning) {
    // The repeat run starts at the keyframe the robot was placed at (start_keyframe, or the best
    // match of the global initialization), with the heading vision measures there.
    const Status aligned = heading_aided_.align(Pose2D(keyframe.pose.x, keyframe.pose.y, route_yaw), *odom);
    if (!aligned.isOk()) return aligned;
    ROS_INFO("repeat_node: mu mode: odometry aligned to keyframe %d", estimate.keyframe);
  }
  if (estimate.degraded) {
    // The temporary reference (the last good frame) has no wall and its pose is itself an
    // estimate; as a heading fix its μ put the lateral offset into the heading (measured in the
    // simulator: 15 cm off the path read as 4° and moved the estimate 13 cm the wrong way). No
    // fix: the odometry carries on, within mu_max_unaided_distance.
    const auto pose = unaidedMuPose(*odom);
    if (!pose) return Status(pose.status().code(), "only the temporary reference matched; " + pose.status().message());
    return std::make_pair(*pose, heading_aided_.covariance());
  }
  // A keyframe with a known wall gives the full μ model (heading and lateral offset); a keyframe
  // without a plane gives a heading-only fix.
  auto wall = muWallOf(keyframe.pose, keyframe.plane, localizer_->route().info.camera_mount,
                       localizer_->camera().fx(), estimate.keyframe);
  Status corrected;
  if (wall) {
    wall->mu = estimate.mu;
    wall->variance = 0.0;  // the filter's mu_variance
    corrected = heading_aided_.correctWithMu(*wall, *odom);
  } else {
    corrected = heading_aided_.correctHeading(route_yaw, *odom);
  }
  // The aligning frame's own fix only waits for the next frame's confirmation: it already gave
  // the heading.
  if (!corrected.isOk() && !aligning) return corrected;
  const auto pose = heading_aided_.routePose(*odom);
  if (!pose) return pose.status();
  return std::make_pair(*pose, heading_aided_.covariance());
}

void RepeatNode::publishPose(const std_msgs::Header& image_header, const Pose2D& base_pose,
                             const Eigen::Matrix3d* covariance) {
  geometry_msgs::PoseWithCovarianceStamped pose;
  pose.header.stamp = image_header.stamp;
  pose.header.frame_id = map_frame_;
  pose.pose.pose.position.x = base_pose.x;
  pose.pose.pose.position.y = base_pose.y;
  pose.pose.pose.orientation = ros_conversions::yawQuaternion(base_pose.yaw);
  auto& c = pose.pose.covariance;  // row-major 6x6 (x, y, z, roll, pitch, yaw)
  c.fill(0.0);
  const int index[3] = {0, 1, 5};
  for (int r = 0; r < 3; ++r) {
    for (int k = 0; k < 3; ++k) {
      c[index[r] * 6 + index[k]] =
          covariance != nullptr ? (*covariance)(r, k) : (r == k ? unobserved_variance_ : 0.0);
    }
  }
  c[2 * 6 + 2] = c[3 * 6 + 3] = c[4 * 6 + 4] = unobserved_variance_;
  pose_publisher_.publish(pose);
}

void RepeatNode::publishMapToOdom(const ros::Time& stamp, const Pose2D& map_to_odom) {
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = map_frame_;
  t.child_frame_id = odom_frame_;
  t.transform.translation.x = map_to_odom.x;
  t.transform.translation.y = map_to_odom.y;
  t.transform.rotation = ros_conversions::yawQuaternion(map_to_odom.yaw);
  tf_broadcaster_.sendTransform(t);
}

void RepeatNode::publishDebugImage(const sensor_msgs::ImageConstPtr& image, const cv::Mat& current,
                                   const RepeatEstimate* estimate, const std::string& failure) {
  cv::Mat right;
  if (current.channels() == 1) {
    cv::cvtColor(current, right, cv::COLOR_GRAY2BGR);
  } else {
    right = current.clone();
  }
  cv::Mat canvas;
  if (estimate != nullptr && estimate->keyframe >= 0) {
    if (estimate->keyframe != debug_keyframe_) {
      const auto reference = loadKeyframeImage(localizer_->route(), static_cast<std::size_t>(estimate->keyframe));
      debug_reference_ = cv::Mat();
      if (reference) {
        if (reference->channels() == 1) {
          cv::cvtColor(*reference, debug_reference_, cv::COLOR_GRAY2BGR);
        } else {
          debug_reference_ = reference->clone();
        }
      } else {
        ROS_WARN_THROTTLE(10.0, "repeat_node: debug_image without its reference keyframe: %s",
                          reference.status().toString().c_str());
      }
      debug_keyframe_ = estimate->keyframe;
    }
  }
  if (!debug_reference_.empty() && estimate != nullptr && debug_reference_.size() == right.size()) {
    cv::hconcat(debug_reference_, right, canvas);
    const double offset = debug_reference_.cols;
    for (const auto& m : estimate->inlier_matches) {
      cv::line(canvas, cv::Point2d(m.reference.x(), m.reference.y()),
               cv::Point2d(m.current.x() + offset, m.current.y()), cv::Scalar(0, 200, 0), 1, cv::LINE_AA);
    }
  } else {
    canvas = right;
  }
  const std::string text =
      estimate != nullptr
          ? "keyframe " + std::to_string(estimate->keyframe) + "  " + toString(estimate->mode) +
                "  inliers " + std::to_string(estimate->inliers) + (estimate->degraded ? "  DEGRADED" : "")
          : "no estimate: " + failure;
  cv::putText(canvas, text, cv::Point(10, 25), cv::FONT_HERSHEY_SIMPLEX, 0.6,
              estimate != nullptr ? cv::Scalar(0, 255, 0) : cv::Scalar(0, 0, 255), 2, cv::LINE_AA);
  debug_publisher_.publish(cv_bridge::CvImage(image->header, "bgr8", canvas).toImageMsg());
}

void RepeatNode::publishMarkers(int current_keyframe) {
  visualization_msgs::MarkerArray markers;
  const Route& route = localizer_->route();
  for (std::size_t k = 0; k < route.keyframes.size(); ++k) {
    const RouteKeyframe& keyframe = route.keyframes[k];
    visualization_msgs::Marker arrow;
    arrow.header.frame_id = map_frame_;
    arrow.header.stamp = ros::Time::now();
    arrow.ns = "keyframes";
    arrow.id = static_cast<int>(k);
    arrow.type = visualization_msgs::Marker::ARROW;
    arrow.pose.position.x = keyframe.pose.x;
    arrow.pose.position.y = keyframe.pose.y;
    arrow.pose.orientation = ros_conversions::yawQuaternion(keyframe.pose.yaw);
    arrow.scale.x = 0.4;
    arrow.scale.y = arrow.scale.z = 0.06;
    const bool current = static_cast<int>(k) == current_keyframe;
    arrow.color.r = current ? 1.0f : 0.2f;
    arrow.color.g = current ? 0.3f : 0.6f;
    arrow.color.b = current ? 0.1f : 1.0f;
    arrow.color.a = 1.0f;
    markers.markers.push_back(arrow);
    if (!keyframe.plane) continue;
    // The plane as a vertical wall segment 2 m wide, seen from the keyframe camera.
    const ScenePlane& plane = *keyframe.plane;
    const Pose2D camera = keyframe.pose.compose(route.info.camera_mount);
    // Foot of the perpendicular from the camera (camera axes: x right, z forward) in base axes.
    const Eigen::Vector2d foot_camera(plane.normal.x() * plane.distance, plane.normal.z() * plane.distance);
    const Eigen::Vector2d foot = camera.transformPoint(Eigen::Vector2d(foot_camera.y(), -foot_camera.x()));
    const Eigen::Vector2d along = camera.transformPoint(Eigen::Vector2d(-plane.normal.x(), -plane.normal.z())) -
                                  camera.transformPoint(Eigen::Vector2d::Zero());
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
    geometry_msgs::Point a, b;
    a.x = foot.x() - along.x();
    a.y = foot.y() - along.y();
    b.x = foot.x() + along.x();
    b.y = foot.y() + along.y();
    wall.points = {a, b};
    markers.markers.push_back(wall);
  }
  marker_publisher_.publish(markers);
}

double RepeatNode::cameraSilence() const {
  if (frames_ == 0 && start_time_.isZero()) return 0.0;  // simulated clock not started yet
  return (ros::Time::now() - (frames_ > 0 ? last_image_arrival_ : start_time_)).toSec();
}

void RepeatNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  const double silence = cameraSilence();
  if (silence > image_timeout_) {
    // A camera that stops is an error: no pose is published and the controller stops the robot.
    char text[160];
    std::snprintf(text, sizeof text, "%s: no image for %.1f s (image_timeout %.1f s)",
                  frames_ > 0 ? "camera stopped" : "waiting for the camera", silence, image_timeout_);
    stat.summary(frames_ > 0 ? diagnostic_msgs::DiagnosticStatus::ERROR
                             : diagnostic_msgs::DiagnosticStatus::WARN,
                 text);
  } else if (!last_status_.isOk()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, last_status_.toString());
  } else if (last_degraded_) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                 "degraded: localized against the temporary reference (route keyframes fail)");
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "localized");
  }
  stat.add("frames", frames_);
  stat.add("seconds since the last image", frames_ > 0 ? silence : -1.0);
  stat.add("failures", failures_);
  stat.add("degraded frames", degraded_);
  stat.add("poses refused by the odometry gate", gated_);
  // Median and maximum over the last frames (the latency an image sees is its age + processing;
  // processing is mostly feature extraction + matching and estimation against the references).
  auto summary = [this](auto value) {
    std::vector<double> values;
    for (const FrameTiming& timing : frame_timing_) {
      const std::optional<double> v = value(timing);
      if (v) values.push_back(*v);
    }
    if (values.empty()) return std::string("-");
    std::sort(values.begin(), values.end());
    char text[64];
    std::snprintf(text, sizeof text, "%.1f / %.1f", values[values.size() / 2], values.back());
    return std::string(text);
  };
  stat.add("processing time median / max [ms]",
           summary([](const FrameTiming& t) { return std::optional<double>(t.processing_ms); }));
  stat.add("image age at processing start median / max [ms]",
           summary([](const FrameTiming& t) { return std::optional<double>(t.age_ms); }));
  stat.add("feature extraction median / max [ms]", summary([](const FrameTiming& t) {
             return t.localize ? std::optional<double>(t.localize->extraction_ms) : std::nullopt;
           }));
  stat.add("matching and estimation median / max [ms]", summary([](const FrameTiming& t) {
             return t.localize ? std::optional<double>(t.localize->references_ms) : std::nullopt;
           }));
  stat.add("references tried per frame median / max", summary([](const FrameTiming& t) {
             return t.localize ? std::optional<double>(t.localize->references_tried) : std::nullopt;
           }));
  const auto tracked = std::count_if(frame_timing_.begin(), frame_timing_.end(),
                                     [](const FrameTiming& t) { return t.localize && t.localize->tracked; });
  stat.addf("frames tracked by optical flow", "%ld of the last %zu", static_cast<long>(tracked), frame_timing_.size());
  stat.add("last inliers", last_inliers_);
  stat.add("reference keyframe", last_keyframe_);
  stat.add("tracked keyframe", localizer_->trackedKeyframe());
}

}  // namespace homography_teach_repeat
