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
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"
#include "homography_teach_repeat/ros/repeat_parameters.h"

namespace homography_teach_repeat {

RepeatNode::RepeatNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh), private_nh_(private_nh), image_transport_(nh), diagnostics_(nh, private_nh) {
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
  const std::string directory = readRequiredParameter<std::string>(private_nh, "route_directory");
  const RepeatPipelineOptions options = readRepeatPipelineOptions(private_nh);
  const auto route = loadRoute(directory);
  if (!route) throw std::runtime_error(route.status().message());
  taught_camera_to_level_ = route->info.camera.camera_to_level;
  auto pipeline = RepeatPipeline::create(*route, options);
  if (!pipeline) throw std::runtime_error(directory + ": " + pipeline.status().message());
  pipeline_.emplace(std::move(*pipeline));
  // Routes that learn (docs/route_format.md, "Experiences").
  if (const auto learning = readExperienceLearningOptions(private_nh)) {
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
  if (pipeline_->localizer().experienceCount() > 0) {
    ROS_INFO("repeat_node: the route has %d learned views (experiences) besides its keyframes",
             pipeline_->localizer().experienceCount());
  }

  pose_publisher_ = private_nh_.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", 5);
  heading_publisher_ = private_nh_.advertise<HeadingCorrectionStamped>("heading_correction", 5);
  integrity_publisher_ = private_nh_.advertise<Integrity>("integrity", 5);
  marker_publisher_ = private_nh_.advertise<visualization_msgs::MarkerArray>("route_markers", 1, /*latch=*/true);
  publishMarkers(pipeline_->localizer().trackedKeyframe());
  image_transport::ImageTransport private_transport(private_nh_);
  debug_publisher_ = private_transport.advertise("debug_image", 1);
  odometry_wait_ = readCheckedParameter(private_nh, "odometry_wait", odometry_wait_,
                                        [](double v) { return std::isfinite(v) && v >= 0.0 && v <= 5.0; },
                                        "must be in [0, 5] s");
  odometry_subscriber_ = std::make_unique<OdometrySubscriber>(
      nh_, "odom", [this](const nav_msgs::OdometryConstPtr& odometry) { onOdometry(odometry); });
  camera_subscriber_ = image_transport_.subscribeCamera("camera/image_raw", 1, &RepeatNode::onImage, this);
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
                          camera_subscriber_.getTopic().c_str(), silence);
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
  ROS_INFO("repeat_node: route '%s' with %d keyframes, mode %s", directory.c_str(),
           pipeline_->localizer().keyframeCount(), toString(options.localization.mode).c_str());
  if (!pipeline_->hybridNotes().empty()) {
    ROS_WARN("repeat_node: hybrid mode runs on what the route has: %s", pipeline_->hybridNotes().c_str());
  }
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
  const RepeatOptions current = pipeline_->options().localization;
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
    changed = pipeline_->reconfigure(options);  // a mode change loads other keyframe data
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
  const Status added = pose ? pipeline_->addOdometry(odometry->header.stamp.toSec(), *pose) : pose.status();
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
  const RepeatFrameResult result =
      pipeline_->processFrame(image->header.stamp.toSec(), cv_image, ros_conversions::toPinholeCamera(*camera_info));
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

void RepeatNode::publish(const sensor_msgs::ImageConstPtr& image, const RepeatFrameResult& result,
                         const Expected<cv::Mat>& cv_image) {
  // The pose first: a subscriber that hears of a frame without a fix before its (bridged) pose
  // would stop for nothing.
  if (result.pose) publishPose(image->header.stamp, result);
  std_msgs::Header integrity_header = image->header;
  integrity_header.frame_id = map_frame_;
  publishIntegrity(integrity_header, result.integrity, result.fixes, /*camera_silent=*/false);
  HeadingCorrectionStamped heading;
  heading.header = image->header;
  heading.mode = toString(pipeline_->options().localization.mode);
  heading.reference_index = -1;
  heading.ok = result.estimate.has_value();
  heading.status = heading.ok ? "ok" : result.status.toString();
  if (const auto& e = result.estimate) {
    heading.theta = e->heading_correction;
    heading.mu = e->mu;
    heading.inliers = static_cast<uint32_t>(e->inliers);
    heading.matches = static_cast<uint32_t>(e->matches);
    heading.reference_index = e->keyframe;
    heading.degraded = e->degraded;
    heading.tracked = e->tracked;
    if (e->keyframe != marked_keyframe_) publishMarkers(e->keyframe);
  } else {
    ROS_WARN_THROTTLE(2.0, "repeat_node: no estimate: %s", result.status.toString().c_str());
  }
  heading_publisher_.publish(heading);
  if (!result.warning.empty()) ROS_WARN_THROTTLE(5.0, "repeat_node: %s", result.warning.c_str());
  if (debug_publisher_.getNumSubscribers() > 0 && cv_image) publishDebugImage(image, *cv_image, result);
}

void RepeatNode::publishPose(const ros::Time& stamp, const RepeatFrameResult& result) {
  geometry_msgs::PoseWithCovarianceStamped pose;
  pose.header.stamp = stamp;
  pose.header.frame_id = map_frame_;
  pose.pose = ros_conversions::toPoseWithCovariance(*result.pose, result.covariance ? &*result.covariance : nullptr,
                                                    unobserved_variance_);
  pose_publisher_.publish(pose);
  if (!publish_tf_) return;
  if (!result.map_to_odom) {
    ROS_WARN_THROTTLE(5.0, "repeat_node: no map -> odom tf: no odometry at the image stamp");
    return;
  }
  geometry_msgs::TransformStamped t;
  t.header.stamp = stamp;
  t.header.frame_id = map_frame_;
  t.child_frame_id = odom_frame_;
  t.transform.translation.x = result.map_to_odom->x;
  t.transform.translation.y = result.map_to_odom->y;
  t.transform.rotation = ros_conversions::yawQuaternion(result.map_to_odom->yaw);
  tf_broadcaster_.sendTransform(t);
}

void RepeatNode::publishDebugImage(const sensor_msgs::ImageConstPtr& image, const cv::Mat& current,
                                   const RepeatFrameResult& result) {
  const RepeatEstimate* estimate = result.estimate ? &*result.estimate : nullptr;
  if (estimate != nullptr && estimate->keyframe >= 0 && estimate->keyframe != debug_keyframe_) {
    debug_keyframe_ = estimate->keyframe;
    debug_reference_ = cv::Mat();
    const auto reference = loadKeyframeImage(pipeline_->localizer().route(), static_cast<std::size_t>(estimate->keyframe));
    if (!reference) {
      ROS_WARN_THROTTLE(10.0, "repeat_node: debug_image without its reference keyframe: %s",
                        reference.status().toString().c_str());
    } else if (reference->channels() == 1) {
      cv::cvtColor(*reference, debug_reference_, cv::COLOR_GRAY2BGR);
    } else {
      debug_reference_ = reference->clone();
    }
  }
  const cv::Mat canvas = drawRepeatMatches(debug_reference_, current, estimate, result.status.toString());
  debug_publisher_.publish(cv_bridge::CvImage(image->header, "bgr8", canvas).toImageMsg());
}

void RepeatNode::publishIntegrity(const std_msgs::Header& header, const IntegrityReport& report,
                                  const std::string& fixes, bool camera_silent) {
  if (report.level != last_integrity_.level) {
    if (report.level == IntegrityLevel::kOk) {
      ROS_INFO("repeat_node: integrity OK");
    } else {
      ROS_WARN("repeat_node: integrity %s: %s", toString(report.level).c_str(), report.reason.c_str());
    }
  }
  last_integrity_ = report;
  Integrity message;
  message.header = header;
  message.level = static_cast<uint8_t>(report.level);
  message.level_name = toString(report.level);
  message.reason = report.reason;
  message.fixes = fixes;
  message.position_bound = report.position_bound;
  message.heading_bound = report.heading_bound;
  message.nis_per_dof = report.nis_per_dof;
  message.refused_in_a_row = report.refused_in_a_row;
  message.time_without_fix = report.time_without_fix;
  message.distance_without_fix = report.distance_without_fix;
  message.inliers = report.inliers;
  message.camera_silent = camera_silent;
  integrity_publisher_.publish(message);
}

void RepeatNode::publishMarkers(int current_keyframe) {
  marked_keyframe_ = current_keyframe;
  marker_publisher_.publish(
      ros_conversions::routeMarkers(pipeline_->localizer().route(), current_keyframe, map_frame_, ros::Time::now()));
}

double RepeatNode::cameraSilence() const {
  const bool images = pipeline_->statistics().frames > 0;
  if (!images && start_time_.isZero()) return 0.0;  // simulated clock not started yet
  return (ros::Time::now() - (images ? last_image_arrival_ : start_time_)).toSec();
}

void RepeatNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  const RepeatStatistics& s = pipeline_->statistics();
  const double silence = cameraSilence();
  if (silence > image_timeout_) {
    // A camera that stops is an error: no pose is published and the controller stops the robot.
    char text[160];
    std::snprintf(text, sizeof text, "%s: no image for %.1f s (image_timeout %.1f s)",
                  s.frames > 0 ? "camera stopped" : "waiting for the camera", silence, image_timeout_);
    stat.summary(s.frames > 0 ? diagnostic_msgs::DiagnosticStatus::ERROR : diagnostic_msgs::DiagnosticStatus::WARN, text);
  } else if (!s.last_status.isOk()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, s.last_status.toString());
  } else if (s.last_degraded) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, "degraded: localized against the temporary reference (route keyframes fail)");
  } else if (last_integrity_.level != IntegrityLevel::kOk) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN,
                 "integrity " + toString(last_integrity_.level) + ": " + last_integrity_.reason);
  } else if (!mount_warning_.empty()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, mount_warning_);
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, "localized");
  }
  stat.add("frames", s.frames);
  if (!mount_warning_.empty()) stat.add("camera mount", mount_warning_);
  stat.add("seconds since the last image", s.frames > 0 ? silence : -1.0);
  stat.add("integrity", toString(last_integrity_.level) +
                            (last_integrity_.reason.empty() ? "" : ": " + last_integrity_.reason));
  stat.addf("integrity 95 % bounds [m, deg]", "%.3f, %.2f", last_integrity_.position_bound,
            last_integrity_.heading_bound * 180.0 / M_PI);
  stat.addf("integrity NIS per dof (fixes)", "%.2f (%d)", last_integrity_.nis_per_dof, last_integrity_.nis_count);
  stat.addf("integrity time / distance without a fix [s, m]", "%.1f, %.2f", last_integrity_.time_without_fix,
            last_integrity_.distance_without_fix);
  if (!pipeline_->hybridNotes().empty()) stat.add("hybrid: missing from the route", pipeline_->hybridNotes());
  stat.add("failures", s.failures);
  stat.add("degraded frames", s.degraded);
  stat.add("poses refused by the odometry gate", s.gated);
  stat.add("failed frames in a row", s.failures_in_a_row);
  stat.addf("whole-route searches (found a pose)", "%u (%u)", s.searches_all, s.found_by_search_all);
  // Median and maximum over the last frames (the latency an image sees is its age + processing).
  using Figure = std::optional<double>;
  stat.add("processing time median / max [ms]", timing_.medianAndMax([](const FrameTiming& t) { return Figure(t.processing_ms); }));
  stat.add("image age at processing start median / max [ms]", timing_.medianAndMax([](const FrameTiming& t) { return Figure(t.age_ms); }));
  stat.add("feature extraction median / max [ms]", timing_.medianAndMax([](const FrameTiming& t) {
             return t.localize ? Figure(t.localize->extraction_ms) : std::nullopt;
           }));
  stat.add("matching and estimation median / max [ms]", timing_.medianAndMax([](const FrameTiming& t) {
             return t.localize ? Figure(t.localize->references_ms) : std::nullopt;
           }));
  stat.add("references tried per frame median / max", timing_.medianAndMax([](const FrameTiming& t) {
             return t.localize ? Figure(t.localize->references_tried) : std::nullopt;
           }));
  stat.addf("frames tracked by optical flow", "%zu of the last %zu", timing_.trackedFrames(), timing_.size());
  stat.add("last inliers", s.last_inliers);
  stat.add("reference keyframe", s.last_keyframe);
  stat.add("tracked keyframe", pipeline_->localizer().trackedKeyframe());
}

}  // namespace homography_teach_repeat
