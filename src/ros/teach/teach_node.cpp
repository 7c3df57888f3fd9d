#include "homography_teach_repeat/ros/teach_node.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "homography_teach_repeat/TeachStatus.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"
#include "homography_teach_repeat/ros/teach_parameters.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {
TeachNode::TeachNode(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh)
    : nh_(nh),
      private_nh_(private_nh),
      map_directory_(readParameter<std::string>(private_nh, "map_directory", "")),
      options_(readTeachOptions(private_nh, !map_directory_.empty())),
      base_frame_(readParameter<std::string>(private_nh, "base_frame", "base_link")),
      max_camera_tilt_rad_(readParameter(private_nh, "max_camera_tilt", 0.05)),
      audit_(readAuditOptions(private_nh)),
      odometry_(readParameter(private_nh, "odometry_buffer_seconds", 5.0),
                readParameter(private_nh, "max_odometry_gap", 0.5)),
      tf_listener_(tf_buffer_),
      diagnostics_(nh, private_nh) {
  if (!map_directory_.empty()) prepareMap();
  status_publisher_ = private_nh_.advertise<TeachStatus>("status", 1, /*latch=*/true);
  publishStatus("waiting", "waiting for camera/image_raw, camera/camera_info and odom");
  odometry_wait_ = readOdometryWait(private_nh, odometry_wait_);
  odometry_subscriber_ = std::make_unique<OdometrySubscriber>(
      nh_, "odom", [this](const nav_msgs::OdometryConstPtr& odometry) { onOdometry(odometry); });
  camera_subscriber_ = std::make_unique<CameraSubscription>(
      nh_, private_nh_, "camera/image_raw", 2, "teach_node",
      [this](const sensor_msgs::ImageConstPtr& image, const sensor_msgs::CameraInfoConstPtr& info) { onImage(image, info); });
  finish_service_ = private_nh_.advertiseService("finish", &TeachNode::onFinish, this);
  diagnostics_.setHardwareID("teach_node");
  diagnostics_.add("teach", this, &TeachNode::produceDiagnostics);
  diagnostics_timer_ =
      nh_.createTimer(ros::Duration(1.0), [this](const ros::TimerEvent&) { diagnostics_.update(); });
  ROS_INFO("teach_node: recording %s (%s features, keyframe every %.2f m or %.2f rad)",
           map_directory_.empty() ? ("to '" + options_.route_directory + "'").c_str()
                                  : ("route '" + route_name_ + "' into the map '" + map_directory_ + "'").c_str(),
           toString(options_.features.type).c_str(), options_.keyframes.distance, options_.keyframes.angle);
}

TeachNode::~TeachNode() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (session() != nullptr && !finished_) {
    std::string summary;
    const Status status = finish(&summary);
    if (status.isOk()) {
      ROS_INFO("teach_node: route finished on shutdown: %s", summary.c_str());
    } else {
      ROS_ERROR("teach_node: finishing the route on shutdown failed: %s", status.toString().c_str());
    }
  }
}

void TeachNode::onOdometry(const nav_msgs::OdometryConstPtr& odometry) {
  const auto pose = ros_conversions::toPose2D(odometry->pose.pose);
  std::lock_guard<std::mutex> lock(mutex_);
  if (!pose) {
    last_error_ = Status(StatusCode::kInvalidInput, "odometry rejected: " + pose.status().message());
    ROS_WARN_THROTTLE(5.0, "teach_node: %s", last_error_.message().c_str());
    return;
  }
  const Status added = odometry_.add(odometry->header.stamp.toSec(), *pose);
  if (!added.isOk()) {
    last_error_ = added;
    ROS_WARN_THROTTLE(5.0, "teach_node: %s", added.message().c_str());
  }
}

Status TeachNode::startSession(const sensor_msgs::CameraInfo& camera_info) {
  const auto camera = ros_conversions::toPinholeCamera(camera_info);
  if (!camera) return camera.status();
  const auto mount = ros_conversions::lookupCameraMount(tf_buffer_, base_frame_, camera_info.header.frame_id,
                                                       max_camera_tilt_rad_);
  if (!mount) return mount.status();
  const Pose2D mount_pose = mount->mount.forwardFrame();
  // A tilted mount: every measured ray is levelled before anything sees it (docs/math.md §1.1);
  // the route keeps the rotation, so the repeat levels its images the same way.
  CameraCalibration calibration = camera->calibration();
  calibration.camera_to_level = mount->camera_to_level;
  if (mount->tilt_rad > 1e-4) {
    ROS_INFO("teach_node: the camera is tilted %.2f deg from level (tf %s -> %s): its images are levelled",
             mount->tilt_rad * 180.0 / M_PI, base_frame_.c_str(), camera_info.header.frame_id.c_str());
  }
  if (!map_directory_.empty()) return startMapSession(calibration, mount_pose);
  auto session = TeachSession::start(options_, calibration, mount_pose);
  if (!session) return session.status();
  session_.emplace(std::move(*session));
  return Status::ok();
}

const TeachSession* TeachNode::session() const {
  if (map_teach_) return &map_teach_->session();
  return session_ ? &*session_ : nullptr;
}

void TeachNode::onImage(const sensor_msgs::ImageConstPtr& image,
                        const sensor_msgs::CameraInfoConstPtr& camera_info) {
  // The odometry of this image's instant may still be on its way (odometry_subscriber.h).
  odometry_subscriber_->waitFor(image->header.stamp.toSec(), odometry_wait_);
  std::lock_guard<std::mutex> lock(mutex_);
  ++images_;
  if (finished_) return;
  if (session() == nullptr) {
    const Status started = startSession(*camera_info);
    if (!started.isOk()) {
      last_error_ = started;
      publishStatus("error", started.message());
      ROS_ERROR_THROTTLE(5.0, "teach_node: cannot start the route: %s", started.toString().c_str());
      return;
    }
    publishStatus("teaching", "recording");
  }
  const auto cv_image = ros_conversions::toCvImage(image);
  if (!cv_image) {
    ++dropped_;
    last_error_ = cv_image.status();
    ROS_WARN_THROTTLE(5.0, "teach_node: image dropped: %s", cv_image.status().toString().c_str());
    return;
  }
  const double stamp = image->header.stamp.toSec();
  const auto pose = odometry_.poseAt(stamp);
  if (!pose) {
    ++dropped_;
    last_error_ = pose.status();
    ROS_WARN_THROTTLE(5.0, "teach_node: image at %.3f dropped: %s", stamp,
                      pose.status().toString().c_str());
    return;
  }
  const auto stored = map_teach_ ? map_teach_->offer(*cv_image, *pose, stamp) : session_->offer(*cv_image, *pose, stamp);
  if (!stored) {
    ++dropped_;
    last_error_ = stored.status();
    ROS_ERROR_THROTTLE(2.0, "teach_node: keyframe not stored: %s", stored.status().toString().c_str());
    publishStatus("teaching", stored.status().message());
    return;
  }
  if (*stored) {
    const auto& k = session()->route().keyframes.back();
    const std::string where = map_teach_ ? "; " + describeMapPlace() : "";
    ROS_INFO("teach_node: keyframe %d at (%.2f, %.2f, %.1f deg), t = %.3f%s", k.index, k.pose.x,
             k.pose.y, k.pose.yaw * 180.0 / M_PI, stamp, where.c_str());
    // A keyframe the repeat will find little in: said now, while the driver can still slow down,
    // turn the camera towards texture or re-drive the stretch (docs/route_audit.md).
    std::string weak;
    const auto& counts = session()->lastStored();
    for (const auto& w : storedKeyframeWeaknesses(counts.features, counts.lines, audit_)) {
      weak += (weak.empty() ? "" : "; ") + w;
    }
    if (weak.empty()) {
      publishStatus("teaching", "keyframe " + std::to_string(k.index) + " stored" + where);
    } else {
      ++weak_keyframes_;
      char position[96];
      std::snprintf(position, sizeof(position), "keyframe %d at (%.2f, %.2f) is weak: ", k.index, k.pose.x, k.pose.y);
      last_weak_ = position + weak;
      ROS_WARN("teach_node: %s (slow down, face more texture or re-drive this stretch)", last_weak_.c_str());
      publishStatus("teaching", "keyframe " + std::to_string(k.index) + " stored; " + last_weak_ + where);
    }
  }
}

Status TeachNode::finish(std::string* summary) {
  if (session() == nullptr) return Status(StatusCode::kInvalidInput, "no keyframe recorded: nothing to finish");
  finished_ = true;
  if (map_teach_) return finishMap(summary);
  if (!options_.planes_from_odometry && !(options_.first_plane_distance > 0.0)) {
    *summary = std::to_string(session_->keyframeCount()) +
               " keyframes; no planes (first_plane_distance is 0)";
    publishStatus("finished", *summary);
    return Status::ok();
  }
  const auto report = session_->finish();
  if (!report) {
    publishStatus("finished", "planes not estimated: " + report.status().message());
    return report.status();
  }
  *summary = std::to_string(report->keyframes) + " keyframes, " + std::to_string(report->planes) +
             " with a plane";
  for (const auto& m : report->messages) *summary += "; " + m;
  if (options_.planes_from_odometry) *summary += "; " + describeKeyframeTilt(*report, options_.keyframe_tilt);
  // The audit of the finished route (without the n² aliasing check: route_info has it).
  RouteAuditOptions audit = audit_;
  audit.aliasing = false;
  const auto audited = auditRoute(session()->route(), audit);
  if (!audited) {
    ROS_WARN("teach_node: route audit failed: %s", audited.status().toString().c_str());
  } else {
    const std::string weak = weakKeyframeSummary(*audited);
    if (!weak.empty()) {
      *summary += "; " + weak + " (rosrun homography_teach_repeat route_info for the reasons)";
      for (const KeyframeAudit& a : audited->keyframes) {
        for (const auto& w : a.fast_hd_weaknesses) ROS_WARN("teach_node: keyframe %d, fast_hd: %s", a.keyframe, w.c_str());
      }
    }
  }
  publishStatus("finished", *summary);
  return Status::ok();
}

bool TeachNode::onFinish(std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (finished_) {
    response.success = true;
    response.message = "already finished: " + last_message_;
    return true;
  }
  std::string summary;
  const Status status = finish(&summary);
  response.success = status.isOk();
  response.message = status.isOk() ? summary : status.toString();
  if (status.isOk()) {
    ROS_INFO("teach_node: route finished: %s", summary.c_str());
  } else {
    ROS_ERROR("teach_node: finish: %s", status.toString().c_str());
  }
  return true;
}

void TeachNode::publishStatus(const std::string& state, const std::string& message) {
  state_ = state;
  last_message_ = message;
  TeachStatus status;
  status.header.stamp = ros::Time::now();
  status.route_directory = session() != nullptr ? session()->route().directory : options_.route_directory;
  status.keyframes = session() != nullptr ? static_cast<uint32_t>(session()->keyframeCount()) : 0;
  if (map_teach_ && map_teach_->onMap()) status.map_place = toString(*map_teach_->onMap());
  status.map_contacts = static_cast<uint32_t>(map_contacts_);
  status.state = state;
  status.message = message;
  status_publisher_.publish(status);
}

void TeachNode::produceDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_ == "error") {
    stat.summary(diagnostic_msgs::DiagnosticStatus::ERROR, last_message_);
  } else if (!last_error_.isOk()) {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, last_error_.toString());
  } else if (!last_weak_.empty() && state_ == "teaching") {
    stat.summary(diagnostic_msgs::DiagnosticStatus::WARN, last_weak_);
  } else {
    stat.summary(diagnostic_msgs::DiagnosticStatus::OK, state_ + ": " + last_message_);
  }
  if (camera_subscriber_) camera_subscriber_->addDiagnostics(stat);
  stat.add("state", state_);
  stat.add("keyframes", session() != nullptr ? session()->keyframeCount() : 0);
  stat.add("images", images_);
  stat.add("dropped images", dropped_);
  stat.add("route", map_directory_.empty() ? options_.route_directory : route_name_ + " in the map " + map_directory_);
  if (map_teach_) {
    stat.add("on the map at", map_teach_->onMap() ? toString(*map_teach_->onMap()) : std::string("new ground"));
    stat.add("contacts with taught ground", map_contacts_);
  }
  stat.add("last problem", last_error_.isOk() ? std::string("none") : last_error_.toString());
  stat.add("weak keyframes", weak_keyframes_);
  stat.add("last weak keyframe", last_weak_.empty() ? std::string("none") : last_weak_);
}

}  // namespace homography_teach_repeat
