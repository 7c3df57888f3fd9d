// RepeatNode's messages: the pose (and tf map -> odom), the heading correction, the integrity, the
// route markers and the debug image of each frame (docs/nodes/repeat_node.md, "Published topics").
#include "homography_teach_repeat/ros/repeat_node.h"

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>

#include <opencv2/imgproc.hpp>

#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/Integrity.h"
#include "homography_teach_repeat/ros/conversions.h"

namespace homography_teach_repeat {

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
  heading.mode = toString(pipeline()->options().localization.mode);
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
    heading.background = result.timing && result.timing->background;
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
    const auto reference = loadKeyframeImage(pipeline()->localizer().route(), static_cast<std::size_t>(estimate->keyframe));
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
  const RepeatPipeline* repeat = pipeline();
  if (repeat == nullptr) return;
  if (!navigator_) {
    marker_publisher_.publish(
        ros_conversions::routeMarkers(repeat->localizer().route(), current_keyframe, map_frame_, ros::Time::now()));
    return;
  }
  // The way's keyframes are in the frame of its first route: shown in the map frame.
  Route way = repeat->localizer().route();
  const std::vector<Pose2D> poses = navigator_->wayInMap();
  for (std::size_t k = 0; k < way.keyframes.size() && k < poses.size(); ++k) way.keyframes[k].pose = poses[k];
  visualization_msgs::MarkerArray markers = ros_conversions::routeMarkers(way, current_keyframe, map_frame_, ros::Time::now());
  visualization_msgs::Marker clear;  // the previous way's markers (a shorter way leaves some)
  clear.header.frame_id = map_frame_;
  clear.action = visualization_msgs::Marker::DELETEALL;
  markers.markers.insert(markers.markers.begin(), clear);
  marker_publisher_.publish(markers);
}

}  // namespace homography_teach_repeat
