// teach_node's parameters (config/teach_node.yaml documents each).
#include "homography_teach_repeat/ros/teach_parameters.h"

#include <stdexcept>
#include <string>

#include "homography_teach_repeat/ros/parameters.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {
namespace {

// estimate_keyframe_tilt: auto (a string), or true / false (a bool).
KeyframeTilt readKeyframeTilt(const ros::NodeHandle& nh, KeyframeTilt default_value) {
  const std::string name = "estimate_keyframe_tilt";
  recordParameterDefault(nh, name, toString(default_value));
  if (!nh.hasParam(name)) return default_value;
  bool estimate = false;
  if (nh.getParam(name, estimate)) return estimate ? KeyframeTilt::kEstimate : KeyframeTilt::kLevel;
  std::string text;
  if (nh.getParam(name, text)) return keyframeTiltFromString(text);  // std::invalid_argument naming it
  throw std::invalid_argument("estimate_keyframe_tilt must be auto, true or false");
}

}  // namespace

TeachOptions readTeachOptions(const ros::NodeHandle& nh, bool into_map) {
  TeachOptions options;
  readParameters(nh, [&] {
    // Into a map the route's folder is chosen under the map's routes/ (map_teach.h).
    if (!into_map) {
      options.route_directory = readParameter<std::string>(nh, "route_directory", "");
      if (options.route_directory.empty()) {
        throw std::invalid_argument("route_directory is not set (the route's folder; or map_directory and "
                                    "route_name to teach into a map of routes)");
      }
    }
    options.overwrite = readParameter(nh, "overwrite", options.overwrite);
    options.features.type = featureTypeFromString(
        readParameter<std::string>(nh, "feature_type", toString(options.features.type)));
    if (!isFeatureTypeAvailable(options.features.type)) {
      throw std::invalid_argument("feature_type '" + toString(options.features.type) +
                                  "' is not available in this OpenCV build; available: " +
                                  availableFeatureTypes());
    }
    options.features.max_features = readParameter(nh, "max_features", options.features.max_features);
    options.keyframes.distance = readParameter(nh, "keyframe_distance", options.keyframes.distance);
    options.keyframes.angle = readParameter(nh, "keyframe_angle", options.keyframes.angle);
    options.first_plane_distance =
        readParameter(nh, "first_plane_distance", options.first_plane_distance);
    // A tape-measured first plane asks for the paper's single plane; without one, planes from odometry.
    options.planes_from_odometry = readParameter(nh, "planes_from_odometry", !(options.first_plane_distance > 0.0));
    options.keyframe_tilt = readKeyframeTilt(nh, options.keyframe_tilt);
    options.closed_route_gap = readParameter(nh, "closed_route_gap", options.closed_route_gap);
    options.lines.max_angle_deg =
        readParameter(nh, "line_max_angle_deg", options.lines.max_angle_deg);
    options.lines.min_length_px = readParameter(nh, "line_min_length_px", options.lines.min_length_px);
    TeachOptions checked = options;
    if (into_map) checked.route_directory = "routes/";  // MapTeach sets the folder it chooses
    checked.validate();
  });
  if (into_map) return options;
  // A directory the route cannot be written to stops the node now, not at the first keyframe.
  const Status writable = checkRouteDirectoryWritable(options.route_directory, options.overwrite);
  if (!writable.isOk()) {
    throw std::runtime_error("route_directory (" + nh.getNamespace() + "): " + writable.message());
  }
  return options;
}

// The thresholds of the teach node's warnings (the rest of the audit keeps its defaults).
RouteAuditOptions readAuditOptions(const ros::NodeHandle& nh) {
  RouteAuditOptions audit;
  readParameters(nh, [&] {
    audit.min_plane_features = readParameter(nh, "audit_min_features", audit.min_plane_features);
    audit.min_lines = readParameter(nh, "audit_min_lines", audit.min_lines);
    audit.validate();
  });
  return audit;
}

}  // namespace homography_teach_repeat
