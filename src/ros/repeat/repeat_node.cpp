#include "homography_teach_repeat/ros/repeat_node.h"

#include <std_srvs/Trigger.h>

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <visualization_msgs/MarkerArray.h>

#include <opencv2/core/utility.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/Integrity.h"
#include "homography_teach_repeat/common/process_memory.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"
#include "homography_teach_repeat/ros/repeat_parameters.h"

namespace homography_teach_repeat {

RepeatNode::RepeatNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh), diagnostics_(nh, private_nh) {
  const auto positive = [](double v) { return std::isfinite(v) && v > 0.0; };
  map_frame_ = readParameter<std::string>(private_nh, "map_frame", "map");
  odom_frame_ = readParameter<std::string>(private_nh, "odom_frame", "odom");
  publish_tf_ = readParameter(private_nh, "publish_tf", false);
  base_frame_ = readParameter<std::string>(private_nh, "base_frame", "base_link");
  max_mount_change_ = readCheckedParameter(private_nh, "max_mount_change", max_mount_change_, positive, "must be finite and > 0");
  unobserved_variance_ = readCheckedParameter(private_nh, "unobserved_variance", 1e6, positive, "must be > 0");
  image_timeout_ = readCheckedParameter(private_nh, "image_timeout", image_timeout_, positive, "must be finite and > 0");
  // OpenCV's worker threads (feature extraction, matching) for the whole process (a nodelet
  // manager included): 0 keeps OpenCV's default (one per core).
  const int opencv_threads =
      readCheckedParameter(private_nh, "opencv_threads", 0, [](int n) { return n >= 0; }, "must be >= 0");
  if (opencv_threads > 0) cv::setNumThreads(opencv_threads);
  // Freed frame buffers stay in the process (common/process_memory.h), likewise process-wide.
  if (readParameter(private_nh, "keep_freed_memory", true) && !keepFreedMemoryForReuse()) {
    ROS_WARN("repeat_node: keep_freed_memory: this C library's malloc cannot be set to keep freed memory; "
             "frames that detect features may take 2-3 times as long (docs/design.md, \"Frame buffers\")");
  }
  const RepeatPipelineOptions options = readRepeatPipelineOptions(private_nh);
  const std::string route_directory = readParameter<std::string>(private_nh, "route_directory", "");
  const std::string map_directory = readParameter<std::string>(private_nh, "map_directory", "");
  if (route_directory.empty() && map_directory.empty()) {
    throw std::runtime_error("required parameter '" + private_nh.resolveName("route_directory") +
                             "' is not set (a taught route; or map_directory, a map of routes)");
  }
  if (!route_directory.empty() && !map_directory.empty()) {
    throw std::runtime_error("route_directory and map_directory are both set: repeat one route or a map of routes");
  }
  if (map_directory.empty()) startRoute(route_directory, options);
  else startMap(map_directory, options);

  pose_publisher_ = private_nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 5);
  heading_publisher_ = private_nh_.advertise<HeadingCorrectionStamped>("heading_correction", 5);
  integrity_publisher_ = private_nh_.advertise<Integrity>("integrity", 5);
  marker_publisher_ = private_nh_.advertise<visualization_msgs::MarkerArray>("route_markers", 1, /*latch=*/true);
  if (route_pipeline_) publishMarkers(route_pipeline_->localizer().trackedKeyframe());
  if (navigator_) publishMapMarkers();
  image_transport::ImageTransport private_transport(private_nh_);
  debug_publisher_ = private_transport.advertise("debug_image", 1);
  odometry_wait_ = readOdometryWait(private_nh, odometry_wait_);
  odometry_subscriber_ = std::make_unique<OdometrySubscriber>(
      nh_, "odom", [this](const nav_msgs::OdometryConstPtr& odometry) { onOdometry(odometry); });
  camera_subscriber_ = std::make_unique<CameraSubscription>(
      nh_, private_nh_, "camera/image_raw", 1, "repeat_node",
      [this](const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) { onImage(image, info); });
  diagnostics_.setHardwareID("repeat_node");
  diagnostics_.add("localization", this, &RepeatNode::produceDiagnostics);
  start_time_ = ros::Time::now();
  diagnostics_timer_ = nh_.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      if (start_time_.isZero()) start_time_ = ros::Time::now();  // simulated clock started late
      const double silence = cameraSilence();
      if (silence > image_timeout_) {
        ROS_WARN_THROTTLE(10.0, "repeat_node: no image on %s for %.1f s: no pose is published",
                          camera_subscriber_->getTopic().c_str(), silence);
        // Nothing to judge: the pose is LOST until images come again.
        IntegrityReport report;
        report.level = IntegrityLevel::kLost;
        char reason[160];
        std::snprintf(reason, sizeof reason, "camera stopped: no image for %.1f s (image_timeout %.1f s)", silence,
                      image_timeout_);
        report.reason = reason;
        std_msgs::Header header;
        header.stamp = ros::Time::now();
        header.frame_id = map_frame_;
        publishIntegrity(header, report, "", /*camera_silent=*/true);
      }
    }
    diagnostics_.update();
  });
  // dynamic_reconfigure starts from the validated parameters (one source of defaults: the YAML).
  reconfigure_server_ = std::make_unique<dynamic_reconfigure::Server<RepeatConfig>>(reconfigure_mutex_, private_nh_);
  RepeatConfig config = RepeatConfig::__getDefault__();  // every field initialised (UBSan)
  writeRepeatTunables(options.localization, config);
  reconfigure_server_->updateConfig(config);
  reconfigure_server_->setCallback([this](RepeatConfig& c, uint32_t level) { onReconfigure(c, level); });
}

void RepeatNode::startRoute(const std::string& directory, const RepeatPipelineOptions& options) {
  const auto route = loadRoute(directory);
  if (!route) throw std::runtime_error(route.status().message());
  taught_camera_to_level_ = route->info.camera.camera_to_level;
  if (!routeMeasurementsMissing(*route)) {
    ROS_INFO("repeat_node: %s", describeMeasuredNoise(options.localization, *route).c_str());
  } else {
    ROS_WARN("repeat_node: %s", describeMeasuredNoise(options.localization, *route).c_str());
  }
  auto pipeline = RepeatPipeline::create(*route, options);
  if (!pipeline) throw std::runtime_error(directory + ": " + pipeline.status().message());
  route_pipeline_.emplace(std::move(*pipeline));
  route_pipeline_->warmUp();
  // Routes that learn (docs/route_format.md, "Experiences").
  if (const auto learning = readExperienceLearningOptions(private_nh_)) {
    route_ = *route;
    std::vector<Pose2D> poses;
    for (const auto& k : route->keyframes) poses.push_back(k.pose);
    recorder_.emplace(poses, *learning);
    experience_extractor_.emplace(FeatureOptions{route->info.feature_type, options.localization.max_features});
    save_experiences_service_ = private_nh_.advertiseService<std_srvs::Trigger::Request, std_srvs::Trigger::Response>(
        "save_experiences", [this](std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
          std::lock_guard<std::mutex> lock(mutex_);
          bool ok = false;
          response.message = saveExperiences(&ok);
          response.success = ok;
          return true;
        });
    ROS_INFO("repeat_node: learning: views where a keyframe matches with fewer than %d inliers are added to the route "
             "(at most %d per keyframe)",
             learning->learn_below_inliers, learning->max_experiences);
  }
  if (route_pipeline_->localizer().experienceCount() > 0) {
    ROS_INFO("repeat_node: the route has %d learned views (experiences) besides its keyframes",
             route_pipeline_->localizer().experienceCount());
  }
  ROS_INFO("repeat_node: route '%s' with %d keyframes, mode %s", directory.c_str(),
           route_pipeline_->localizer().keyframeCount(), toString(options.localization.mode).c_str());
  if (!route_pipeline_->hybridNotes().empty()) {
    ROS_WARN("repeat_node: hybrid mode runs on what the route has: %s", route_pipeline_->hybridNotes().c_str());
  }
}

RepeatPipeline* RepeatNode::pipeline() {
  if (navigator_) return navigator_->pipeline();
  return route_pipeline_ ? &*route_pipeline_ : nullptr;
}

RepeatNode::~RepeatNode() {
  if (!recorder_) return;
  std::lock_guard<std::mutex> lock(mutex_);
  bool ok = false;
  const std::string outcome = saveExperiences(&ok);
  if (ok) ROS_INFO("repeat_node: %s", outcome.c_str());
  else ROS_ERROR("repeat_node: %s", outcome.c_str());
}

std::string RepeatNode::saveExperiences(bool* ok) {
  *ok = false;
  if (!recorder_) return "learning is off (learn_experiences)";
  const std::size_t candidates = recorder_->candidates().size();
  const auto added = recorder_->commit(*route_, *experience_extractor_);
  if (!added) return "learned views not saved: " + added.status().message();
  *ok = true;
  experiences_saved_ += *added;
  return "added " + std::to_string(*added) + " learned view(s) of " + std::to_string(candidates) + " to route '" +
         route_->directory + "' (" + std::to_string(experiences_saved_) + " in this run; used from the next run)";
}

void RepeatNode::onReconfigure(RepeatConfig& config, uint32_t /*level*/) {
  std::lock_guard<std::mutex> lock(mutex_);
  const RepeatOptions current =
      navigator_ ? navigator_->options().repeat.localization : route_pipeline_->options().localization;
  RepeatOptions options = current;
  Status changed;
  try {
    options.mode = repeatModeFromString(config.mode);
    options.pose.pixel_sigma_px = config.pixel_sigma;
    options.pose.refine = config.refine;
    options.min_inliers = config.min_inliers;
    options.neighbour_search = config.neighbour_search;
    options.max_degraded_frames = config.max_degraded_frames;
    RepeatConfig unchanged = config;
    writeRepeatTunables(current, unchanged);
    if (unchanged.mode == config.mode && unchanged.pixel_sigma == config.pixel_sigma && unchanged.refine == config.refine &&
        unchanged.min_inliers == config.min_inliers && unchanged.neighbour_search == config.neighbour_search &&
        unchanged.max_degraded_frames == config.max_degraded_frames) {
      return;  // the initial callback, or nothing changed
    }
    // A mode change loads other keyframe data.
    changed = navigator_ ? navigator_->reconfigure(options) : route_pipeline_->reconfigure(options);
  } catch (const std::invalid_argument& e) {
    changed = Status(StatusCode::kInvalidInput, e.what());
  }
  if (!changed.isOk()) {
    ROS_ERROR("repeat_node: reconfiguration refused: %s; keeping mode %s", changed.message().c_str(),
              toString(current.mode).c_str());
    writeRepeatTunables(current, config);
    return;
  }
  if (options.mode != current.mode) debug_keyframe_ = -1;
  ROS_INFO("repeat_node: reconfigured: mode %s, min_inliers %d, neighbour_search %d, pixel_sigma %.2f px",
           toString(options.mode).c_str(), options.min_inliers, options.neighbour_search, options.pose.pixel_sigma_px);
}

void RepeatNode::onOdometry(const nav_msgs::OdometryConstPtr& odometry) {
  const auto pose = ros_conversions::toPose2D(odometry->pose.pose);
  std::lock_guard<std::mutex> lock(mutex_);
  const double stamp = odometry->header.stamp.toSec();
  const Status added = !pose      ? pose.status()
                       : navigator_ ? navigator_->addOdometry(stamp, *pose)
                                    : route_pipeline_->addOdometry(stamp, *pose);
  if (!added.isOk()) ROS_WARN_THROTTLE(5.0, "repeat_node: odometry rejected: %s", added.message().c_str());
}

void RepeatNode::onImage(const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& camera_info) {
  const double age_ms = 1e3 * (ros::Time::now() - image->header.stamp).toSec();
  const ros::WallTime started = ros::WallTime::now();
  // The odometry of this image's instant may still be on its way (odometry_subscriber.h).
  odometry_subscriber_->waitFor(image->header.stamp.toSec(), odometry_wait_);
  if (!mount_checked_) checkCameraMount(image->header.frame_id);
  std::lock_guard<std::mutex> lock(mutex_);
  last_image_arrival_ = ros::Time::now();
  const auto cv_image = ros_conversions::toCvImage(image);
  if (navigator_) {
    const auto localize = processMapFrame(image, cv_image, ros_conversions::toPinholeCamera(*camera_info));
    timing_.add(FrameTiming{1e3 * (ros::WallTime::now() - started).toSec(), age_ms, localize});
    return;
  }
  const RepeatFrameResult result = route_pipeline_->processFrame(image->header.stamp.toSec(), cv_image,
                                                                 ros_conversions::toPinholeCamera(*camera_info));
  publish(image, result, cv_image);
  if (recorder_ && cv_image) {
    if (const auto observation = observationOf(image->header.stamp.toSec(), *cv_image, result)) {
      recorder_->observe(*observation);
    }
  }
  FrameTiming timing;
  timing.processing_ms = 1e3 * (ros::WallTime::now() - started).toSec();
  timing.age_ms = age_ms;
  timing.localize = result.timing;
  timing_.add(timing);
}

void RepeatNode::checkCameraMount(const std::string& camera_frame) {
  mount_checked_ = true;
  // Any tilt up to 60°: the question is only whether it is the taught one.
  const auto mount = ros_conversions::lookupCameraMount(tf_buffer_, base_frame_, camera_frame, M_PI / 3.0);
  std::string warning;
  if (!mount) {
    ROS_WARN("repeat_node: the camera mount cannot be compared with the taught one (%s); the route's levelling is used",
             mount.status().message().c_str());
    return;
  }
  const double change = Eigen::AngleAxisd(taught_camera_to_level_ * mount->camera_to_level.transpose()).angle();
  if (change > max_mount_change_) {
    char text[240];
    std::snprintf(text, sizeof text,
                  "the camera mount is turned %.2f deg from the teach run's (tf %s -> %s): the route's levelling is used, "
                  "the difference is the tilt nuisance's (tilt_sigma) or re-teach",
                  change * 180.0 / M_PI, base_frame_.c_str(), camera_frame.c_str());
    warning = text;
    ROS_WARN("repeat_node: %s", text);
  }
  std::lock_guard<std::mutex> lock(mutex_);
  mount_warning_ = warning;
}

}  // namespace homography_teach_repeat
