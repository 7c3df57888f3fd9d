// RepeatNode in a map of routes (docs/nodes/repeat_node.md, "A map of routes"): MapNavigator
// (network/map_navigator.h) relocalizes and follows the way ~plan_way plans; this file converts
// its results into the node's messages, /initialpose into a hint, and the map into rviz markers.
#include "homography_teach_repeat/ros/repeat_node.h"

#include <nav_msgs/Path.h>
#include <std_srvs/Trigger.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/network/map_place_index.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"
#include "homography_teach_repeat/ros/repeat_parameters.h"

namespace homography_teach_repeat {
void RepeatNode::startMap(const std::string& directory, const RepeatPipelineOptions& options) {
  if (readParameter(private_nh_, "learn_experiences", false)) {
    throw std::runtime_error("learn_experiences works on one route (route_directory), not on a map (map_directory)");
  }
  const auto map = loadRouteMap(directory);
  if (!map) throw std::runtime_error(map.status().message());
  if (map->routes.empty()) throw std::runtime_error(directory + ": the map has no routes (teach one into it)");
  taught_camera_to_level_ = map->routes.front().route.info.camera.camera_to_level;
  std::optional<PlaceIndex> index;
  auto loaded = loadMapPlaceIndex(*map);
  if (loaded) {
    index.emplace(std::move(*loaded));
  } else {
    ROS_WARN("repeat_node: %s; building the place index now (to keep one: `rosrun homography_teach_repeat route_map "
             "index %s`)", loaded.status().message().c_str(), directory.c_str());
    const ros::WallTime started = ros::WallTime::now();
    auto built = buildMapPlaceIndex(*map);
    if (!built) throw std::runtime_error(directory + ": the place index cannot be built: " + built.status().message());
    index.emplace(std::move(*built));
    ROS_INFO("repeat_node: place index built in %.1f s", (ros::WallTime::now() - started).toSec());
  }
  MapNavigatorOptions navigator_options;
  navigator_options.repeat = options;
  navigator_options.relocalization = readRelocalizationOptions(private_nh_);
  auto navigator = MapNavigator::create(*map, std::move(index), navigator_options);
  if (!navigator) throw std::runtime_error(directory + ": " + navigator.status().message());
  navigator_.emplace(std::move(*navigator));
  navigator_->warmUp();

  way_publisher_ = private_nh_.advertise<nav_msgs::Path>("way", 1, /*latch=*/true);
  map_marker_publisher_ = private_nh_.advertise<visualization_msgs::MarkerArray>("map_markers", 1, /*latch=*/true);
  plan_way_service_ = private_nh_.advertiseService("plan_way", &RepeatNode::onPlanWay, this);
  relocalize_service_ = private_nh_.advertiseService<std_srvs::Trigger::Request, std_srvs::Trigger::Response>(
      "relocalize", [this](std_srvs::Trigger::Request&, std_srvs::Trigger::Response& response) {
        std::lock_guard<std::mutex> lock(mutex_);
        const Status started = navigator_->relocalize();
        response.success = started.isOk();
        response.message = started.isOk() ? "relocalizing from no hint (the place index)" : started.message();
        last_relocalization_.clear();
        nav_msgs::Path none;
        none.header.frame_id = map_frame_;
        way_publisher_.publish(none);
        ROS_INFO("repeat_node: %s", response.message.c_str());
        return true;
      });
  initial_pose_subscriber_ = nh_.subscribe("initialpose", 1, &RepeatNode::onInitialPose, this);
  std::size_t keyframes = 0;
  for (const MapRoute& r : map->routes) keyframes += r.route.keyframes.size();
  ROS_INFO("repeat_node: map '%s': %zu route(s), %zu keyframes, %zu junction(s), mode %s; relocalizing (from the "
           "place index, or around a 2D Pose Estimate on %s)",
           directory.c_str(), map->routes.size(), keyframes, map->junctions.size(),
           toString(options.localization.mode).c_str(), initial_pose_subscriber_.getTopic().c_str());
}

std::optional<LocalizeTiming> RepeatNode::processMapFrame(const sensor_msgs::ImageConstPtr& image,
                                                          const Expected<cv::Mat>& cv_image,
                                                          const Expected<PinholeCamera>& camera) {
  const NavigatorFrame frame = navigator_->processFrame(image->header.stamp.toSec(), cv_image, camera);
  if (frame.repeat) {
    publish(image, *frame.repeat, cv_image);
    return frame.repeat->timing;
  }
  publishRelocalization(image->header, frame);
  return std::nullopt;
}

void RepeatNode::publishRelocalization(const std_msgs::Header& header, const NavigatorFrame& frame) {
  IntegrityReport report;  // LOST until a place is confirmed
  std::string verdict;
  const std::optional<PlaceHypothesis> place = frame.relocalization ? frame.relocalization->place : std::nullopt;
  if (!frame.status.isOk()) {
    report.reason = "relocalizing: " + frame.status.message();
    verdict = "bad input";
  } else if (frame.mode == NavigatorMode::kPlaced && place) {
    report.level = IntegrityLevel::kOk;
    report.reason = "placed at " + toString(place->keyframe) +
                    ": waiting for a destination (~plan_way, or a repeat_route goal with a destination)";
    report.inliers = place->inliers;
    report.position_bound = positionBound95(place->covariance);
    report.heading_bound = headingBound95(place->covariance);
    verdict = "placed at " + toString(place->keyframe);
    const auto frame_in_map = navigator_->routeFrames().find(place->keyframe.route);
    if (frame_in_map != navigator_->routeFrames().end()) {
      RepeatFrameResult placed;
      placed.pose = place->base_pose;
      placed.covariance = place->covariance;
      expressRepeatResultIn(frame_in_map->second, &placed);
      geometry_msgs::PoseWithCovarianceStamped pose;
      pose.header.stamp = header.stamp;
      pose.header.frame_id = map_frame_;
      pose.pose = ros_conversions::toPoseWithCovariance(*placed.pose, &*placed.covariance, unobserved_variance_);
      pose_publisher_.publish(pose);  // no map -> odom tf until a way is followed
    }
  } else if (frame.relocalization) {
    const Relocalization& r = *frame.relocalization;
    report.reason = "relocalizing: " + toString(r.state) + (r.reason.empty() ? "" : ": " + r.reason);
    verdict = toString(r.state);
    for (const std::string& problem : r.problems) ROS_WARN_THROTTLE(10.0, "repeat_node: map: %s", problem.c_str());
  }
  if (verdict != last_relocalization_) {
    ROS_INFO("repeat_node: %s", report.reason.c_str());
    last_relocalization_ = verdict;
  }
  std_msgs::Header integrity_header = header;
  integrity_header.frame_id = map_frame_;
  publishIntegrity(integrity_header, report, "", /*camera_silent=*/false);
  HeadingCorrectionStamped heading;  // no route is followed: no estimate against one
  heading.header = header;
  heading.mode = toString(navigator_->options().repeat.localization.mode);
  heading.reference_index = -1;
  heading.ok = false;
  heading.status = report.reason;
  heading_publisher_.publish(heading);
}

bool RepeatNode::onPlanWay(PlanWay::Request& request, PlanWay::Response& response) {
  std::lock_guard<std::mutex> lock(mutex_);
  response.success = false;
  const auto refuse = [&](uint8_t outcome, const std::string& reason) {
    response.outcome = outcome;
    response.reason = reason;
    ROS_WARN("repeat_node: plan_way '%s' refused: %s", request.destination.c_str(), reason.c_str());
    return true;
  };
  const RouteMap& map = navigator_->map();
  KeyframeRef destination;
  if (request.destination.find(':') == std::string::npos) {
    const MapRoute* route = map.find(request.destination);
    if (route == nullptr || route->route.keyframes.empty()) {
      std::string routes;
      for (const MapRoute& r : map.routes) routes += (routes.empty() ? "" : ", ") + r.name;
      return refuse(PlanWay::Response::NOT_IN_MAP,
                    "no route '" + request.destination + "' in the map (its routes: " + routes + ")");
    }
    destination = KeyframeRef{route->name, route->route.keyframes.back().index};
  } else {
    const auto parsed = parseKeyframeRef(request.destination);
    if (!parsed) return refuse(PlanWay::Response::NOT_IN_MAP, parsed.status().message());
    if (map.keyframePosition(*parsed) < 0) {
      return refuse(PlanWay::Response::NOT_IN_MAP, "the destination " + toString(*parsed) + " is not in the map");
    }
    destination = *parsed;
  }
  if (!navigator_->place()) {
    return refuse(PlanWay::Response::NOT_PLACED, "the robot's place is not known yet (" + last_integrity_.reason + ")");
  }
  const KeyframeRef from = *navigator_->place();
  const auto path = navigator_->setDestination(destination);
  if (!path) {
    return refuse(path.status().code() == StatusCode::kNoConsensus ? PlanWay::Response::UNREACHABLE
                                                                    : PlanWay::Response::FAILED,
                  path.status().message());
  }
  response.outcome = PlanWay::Response::PLANNED;
  response.success = true;
  response.path.header.frame_id = map_frame_;
  response.path.header.stamp = ros::Time::now();
  for (const Pose2D& pose : navigator_->wayInMap()) {
    geometry_msgs::PoseStamped stamped;
    stamped.header = response.path.header;
    stamped.pose = ros_conversions::toPoseWithCovariance(pose, nullptr, 0.0).pose;
    response.path.poses.push_back(stamped);
  }
  for (const KeyframeRef& k : path->keyframes) response.keyframes.push_back(toString(k));
  response.junctions_crossed = path->junctions_crossed;
  response.length = path->length_m;
  char summary[240];
  std::snprintf(summary, sizeof summary, "way from %s to %s: %zu keyframes, %.1f m, %d junction(s)",
                toString(from).c_str(), toString(destination).c_str(), path->keyframes.size(), path->length_m,
                path->junctions_crossed);
  response.reason = summary;
  ROS_INFO("repeat_node: %s", summary);
  way_publisher_.publish(response.path);
  debug_keyframe_ = -1;  // the way's keyframe indices are new
  publishMarkers(0);
  return true;
}

void RepeatNode::onInitialPose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& pose) {
  if (!pose->header.frame_id.empty() && pose->header.frame_id != map_frame_) {
    ROS_WARN("repeat_node: %s in frame '%s', not map_frame '%s': ignored", initial_pose_subscriber_.getTopic().c_str(),
             pose->header.frame_id.c_str(), map_frame_.c_str());
    return;
  }
  const auto planar = ros_conversions::toPose2D(pose->pose.pose);
  if (!planar) {
    ROS_WARN("repeat_node: initial pose ignored: %s", planar.status().message().c_str());
    return;
  }
  std::lock_guard<std::mutex> lock(mutex_);
  const auto hint = placeHintFromMapPose(navigator_->map(), *planar);
  const Status started = navigator_->relocalize(hint);
  if (!started.isOk()) {
    ROS_WARN("repeat_node: initial pose ignored: %s", started.message().c_str());
    return;
  }
  last_relocalization_.clear();
  nav_msgs::Path none;
  none.header.frame_id = map_frame_;
  way_publisher_.publish(none);
  ROS_INFO("repeat_node: relocalizing around (%.2f, %.2f, %.0f deg) in %s: route '%s' within %.1f m", planar->x,
           planar->y, planar->yaw * 180.0 / M_PI, map_frame_.c_str(), hint ? hint->route.c_str() : "?",
           navigator_->options().relocalization.hint_radius);
}

void RepeatNode::publishMapMarkers() {
  const RouteMap& map = navigator_->map();
  for (const MapRoute& r : map.routes) {
    if (navigator_->routeFrames().count(r.name) == 0) {
      ROS_WARN("repeat_node: route '%s' has no junction to '%s' (the map frame): not shown, and no way from the "
               "map frame leads to it (route_info --route %s names the groups)",
               r.name.c_str(), map.routes.front().name.c_str(), map.directory.c_str());
    }
  }
  map_marker_publisher_.publish(
      ros_conversions::networkMarkers(map, navigator_->routeFrames(), map_frame_, ros::Time::now()));
}

void RepeatNode::addMapDiagnostics(diagnostic_updater::DiagnosticStatusWrapper& stat) {
  const RouteMap& map = navigator_->map();
  stat.addf("map", "%s (%zu routes, %zu junctions)", map.directory.c_str(), map.routes.size(), map.junctions.size());
  stat.add("map mode", toString(navigator_->mode()));
  const auto place = navigator_->place();
  stat.add("place", place ? toString(*place) : std::string("unknown"));
  if (const auto& way = navigator_->way(); way && !way->sources.empty()) {
    stat.addf("way", "%s to %s (%zu keyframes)", toString(way->sources.front()).c_str(),
              toString(way->sources.back()).c_str(), way->sources.size());
  }
}

}  // namespace homography_teach_repeat
