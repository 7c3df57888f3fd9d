#include "homography_teach_repeat/network/path_route.h"

#include <Eigen/Geometry>

#include <filesystem>
#include <optional>
#include <string>

namespace homography_teach_repeat {
namespace {

std::string absoluteFile(const std::string& route_directory, const std::string& file) {
  if (file.empty()) return file;
  return std::filesystem::absolute(routeFilePath(route_directory, file)).lexically_normal().string();
}

// The pose of `to`'s keyframe in `from`'s keyframe frame, from a junction either way round.
std::optional<Pose2D> junctionBetween(const RouteMap& map, const KeyframeRef& from, const KeyframeRef& to) {
  for (const Junction& j : map.junctions) {
    if (j.from == from && j.to == to) return j.to_in_from;
    if (j.from == to && j.to == from) return j.to_in_from.inverse();
  }
  return std::nullopt;
}

}  // namespace

Expected<PathRoute> composePathRoute(const RouteMap& map, const NetworkPath& path, const RouteGraphOptions& options) {
  if (path.keyframes.empty()) return Status(StatusCode::kInvalidInput, "the path has no keyframe");
  PathRoute composed;
  const MapRoute* first = map.find(path.keyframes.front().route);
  if (first == nullptr) {
    return Status(StatusCode::kInvalidInput, "path keyframe " + toString(path.keyframes.front()) + " is not in the map");
  }
  composed.route.directory = map.directory;
  composed.route.info = first->route.info;
  Pose2D route_frame;  // the current route's odometry frame in the path's frame
  int previous_position = -1;  // of the previous step's keyframe in its route
  for (std::size_t i = 0; i < path.keyframes.size(); ++i) {
    const KeyframeRef& ref = path.keyframes[i];
    const MapRoute* source = map.find(ref.route);
    const int position = map.keyframePosition(ref);
    if (source == nullptr || position < 0) {
      return Status(StatusCode::kInvalidInput,
                    "path step " + std::to_string(i + 1) + ": keyframe " + toString(ref) + " is not in the map");
    }
    const RouteKeyframe& keyframe = source->route.keyframes[static_cast<std::size_t>(position)];
    if (i > 0) {
      const KeyframeRef& previous = path.keyframes[i - 1];
      const auto count = static_cast<int>(source->route.keyframes.size());
      const bool next_on_route =
          previous.route == ref.route &&
          (position == previous_position + 1 ||
           (position == 0 && previous_position == count - 1 && isClosedRoute(source->route, options.closed_route_gap)));
      if (!next_on_route) {
        const auto across = junctionBetween(map, previous, ref);
        if (!across) {
          return Status(StatusCode::kInvalidInput, "path step " + std::to_string(i + 1) + ": from " +
                                                       toString(previous) + " to " + toString(ref) +
                                                       " is neither the route's next keyframe nor a junction");
        }
        // This keyframe's pose in the path frame, then its route's odometry frame in the path frame.
        const Pose2D in_path = composed.route.keyframes.back().pose.compose(*across);
        route_frame = in_path.compose(keyframe.pose.inverse());
      }
    }
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // of (x, y, yaw) into the path frame
    rotation.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(route_frame.yaw).toRotationMatrix();
    RouteKeyframe copy = keyframe;
    copy.index = static_cast<int>(i);
    copy.pose = route_frame.compose(keyframe.pose);
    copy.image_file = absoluteFile(source->route.directory, keyframe.image_file);
    copy.features_file = absoluteFile(source->route.directory, keyframe.features_file);
    copy.lines_file = absoluteFile(source->route.directory, keyframe.lines_file);
    for (RouteExperience& e : copy.experiences) {
      e.pose = route_frame.compose(e.pose);
      e.pose_covariance = rotation * e.pose_covariance * rotation.transpose();
      e.image_file = absoluteFile(source->route.directory, e.image_file);
      e.features_file = absoluteFile(source->route.directory, e.features_file);
    }
    composed.route.keyframes.push_back(std::move(copy));
    composed.sources.push_back(ref);
    previous_position = position;
  }
  return composed;
}

}  // namespace homography_teach_repeat
