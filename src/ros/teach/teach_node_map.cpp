// TeachNode into a map of routes (docs/nodes/teach_node.md, "Teaching into a map"): MapTeach
// (network/map_teach.h) records the route, locates each keyframe in the map and commits the route
// with the junctions measured where it touches taught ground; this file reads the map at start-up
// and says what MapTeach finds.
#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>

#include "homography_teach_repeat/network/map_place_index.h"
#include "homography_teach_repeat/ros/parameters.h"
#include "homography_teach_repeat/ros/repeat_parameters.h"
#include "homography_teach_repeat/ros/teach_node.h"

namespace homography_teach_repeat {

void TeachNode::prepareMap() {
  if (!readParameter<std::string>(private_nh_, "route_directory", "").empty()) {
    throw std::runtime_error("route_directory and map_directory are both set: teach one route or into a map");
  }
  route_name_ = readRequiredParameter<std::string>(private_nh_, "route_name");
  if (!isValidRouteName(route_name_)) {
    throw invalidParameter(private_nh_, "route_name '" + route_name_ + "' is not a route name (1-64 of A-Z a-z 0-9 _ -)");
  }
  if (!options_.planes_from_odometry && !(options_.first_plane_distance > 0.0)) {
    throw invalidParameter(private_nh_, "a map needs the keyframes' planes (relocalization, junctions): set "
                                        "first_plane_distance > 0 or planes_from_odometry");
  }
  std::error_code error;
  std::filesystem::create_directories(map_directory_, error);
  if (error) throw std::runtime_error("map_directory '" + map_directory_ + "' cannot be created: " + error.message());
  // An existing map (or a single-route folder, migrated at the commit), or a new one.
  const std::filesystem::path folder(map_directory_);
  if (std::filesystem::exists(folder / "map.yaml") || std::filesystem::exists(folder / "route.yaml")) {
    auto loaded = loadRouteMap(map_directory_);
    if (!loaded) throw std::runtime_error(loaded.status().message());
    map_.emplace(std::move(*loaded));
  } else {
    map_.emplace();
    map_->directory = map_directory_;
  }
  // The folder the route will go to (new: newRouteDirectory) can be written; the probe's folder
  // is removed again, the session creates it at the first image.
  const std::filesystem::path probe = folder / newRouteDirectory(*map_, route_name_);
  std::filesystem::create_directories(probe.parent_path(), error);
  if (error) throw std::runtime_error("map_directory '" + map_directory_ + "': " + error.message());
  const Status writable = checkRouteDirectoryWritable(probe.string(), /*overwrite=*/false);
  std::filesystem::remove_all(probe, error);
  if (!writable.isOk()) throw std::runtime_error("map_directory '" + map_directory_ + "': " + writable.message());
  if (map_->find(route_name_) != nullptr) {
    ROS_WARN("teach_node: route '%s' is in the map already: it is taught again and replaces it at finish (its "
             "junctions are kept where their keyframes still exist)", route_name_.c_str());
  }
  if (!map_->routes.empty()) {
    auto index = loadMapPlaceIndex(*map_);
    if (!index) {
      ROS_WARN("teach_node: %s; building the place index now", index.status().message().c_str());
      index = buildMapPlaceIndex(*map_);
      if (!index) throw std::runtime_error(map_directory_ + ": the place index cannot be built: " + index.status().message());
    }
    map_index_.emplace(std::move(*index));
  }
  map_options_.name = route_name_;
  map_options_.teach = options_;
  map_options_.repeat.max_features = options_.features.max_features;
  map_options_.relocalization = readRelocalizationOptions(private_nh_);
}

Status TeachNode::startMapSession(const CameraCalibration& calibration, const Pose2D& mount) {
  auto started = MapTeach::start(*map_, std::move(map_index_), map_options_, calibration, mount);
  map_index_.reset();
  if (!started) return started.status();
  map_teach_.emplace(std::move(*started));
  if (!map_teach_->locating()) {
    ROS_INFO("teach_node: the map has no route yet: '%s' is its first (no junction to find)", route_name_.c_str());
  }
  return Status::ok();
}

std::string TeachNode::describeMapPlace() {
  if (!map_teach_->locating()) return "first route of the map";
  const auto& contacts = map_teach_->contacts();
  for (std::size_t c = map_contacts_; c < contacts.size(); ++c) {
    ROS_INFO("teach_node: keyframe %d is at %s of the map: a junction is measured there at finish",
             contacts[c].keyframe, toString(contacts[c].map_keyframe).c_str());
  }
  map_contacts_ = contacts.size();
  if (map_teach_->onMap()) return "on taught ground at " + toString(*map_teach_->onMap());
  const auto& location = map_teach_->lastLocation();
  return "new ground" + (location && location->state != RelocalizationState::kSearching
                             ? " (" + toString(location->state) + ")"
                             : std::string());
}

Status TeachNode::finishMap(std::string* summary) {
  const auto report = map_teach_->finish();
  if (!report) {
    publishStatus("finished", "the route was not added to the map: " + report.status().message());
    return report.status();
  }
  *summary = std::to_string(report->planes.keyframes) + " keyframes, " + std::to_string(report->planes.planes) +
             " with a plane; route '" + route_name_ + "' in the map " + map_directory_ + " (" +
             report->relative_directory + "), " + std::to_string(report->junctions.size()) + " junction(s)";
  if (options_.planes_from_odometry) *summary += "; " + describeKeyframeTilt(report->planes, options_.keyframe_tilt);
  for (const Junction& j : report->junctions) {
    *summary += "; " + toString(j.from) + " <-> " + toString(j.to) + " (" + std::to_string(j.inliers) + " inliers)";
  }
  for (const auto& p : report->problems) *summary += "; no junction " + p;
  for (const Junction& j : report->dropped) {
    *summary += "; junction " + toString(j.from) + " <-> " + toString(j.to) + " dropped (its keyframe is gone)";
  }
  if (!report->index_rebuilt) *summary += "; the place index was not rebuilt (route_map index)";
  publishStatus("finished", *summary);
  return Status::ok();
}

}  // namespace homography_teach_repeat
