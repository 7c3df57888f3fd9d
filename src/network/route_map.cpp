#include "homography_teach_repeat/network/route_map.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <set>
#include <stdexcept>
#include <system_error>

#include "homography_teach_repeat/common/atomic_file.h"
#include "homography_teach_repeat/teach_repeat/route_files.h"

namespace homography_teach_repeat {
namespace fs = std::filesystem;
using route_files::Reader;

namespace {

const char* const kMapIndexName = "map.yaml";
const char* const kRoutesFolder = "routes";

Status invalid(const std::string& message) { return Status(StatusCode::kInvalidInput, message); }

std::string badRouteName(const std::string& name) { return "route name '" + name + "' is not 1 to 64 of [A-Za-z0-9_-]"; }

std::string indexPath(const std::string& directory) { return directory + "/" + kMapIndexName; }

// A route directory must stay inside the map: relative, no "..".
bool isInsideMap(const std::string& relative) {
  if (relative.empty()) return false;
  const fs::path path(relative);
  if (path.is_absolute()) return false;
  return std::none_of(path.begin(), path.end(), [](const fs::path& part) { return part == ".."; });
}

Expected<Route> loadMapRoute(const std::string& map_directory, const MapRoute& entry) {
  const std::string directory =
      entry.directory == "." ? map_directory : (fs::path(map_directory) / entry.directory).string();
  auto route = loadRoute(directory);
  if (!route) return invalid("route '" + entry.name + "': " + route.status().message());
  return route;
}

// The checks loadRouteMap and writeRouteMapIndex share; `where` names the file for messages.
Status validate(const RouteMap& map, const std::string& where) {
  std::set<std::string> names;
  for (const MapRoute& r : map.routes) {
    if (!isValidRouteName(r.name)) {
      return invalid(where + ": " + badRouteName(r.name));
    }
    if (!names.insert(r.name).second) return invalid(where + ": route '" + r.name + "' is listed twice");
    if (!isInsideMap(r.directory)) {
      return invalid(where + ": route '" + r.name + "' has directory '" + r.directory +
                     "' outside the map (it must be relative, without '..')");
    }
    const RouteInfo& first = map.routes.front().route.info;
    const RouteInfo& info = r.route.info;
    if (info.feature_type != first.feature_type) {
      return invalid(where + ": route '" + r.name + "' has feature type " + toString(info.feature_type) +
                     ", route '" + map.routes.front().name + "' " + toString(first.feature_type) +
                     " (a map holds routes of one camera and feature type)");
    }
    if (info.camera.width != first.camera.width || info.camera.height != first.camera.height) {
      return invalid(where + ": route '" + r.name + "' has " + std::to_string(info.camera.width) + "x" +
                     std::to_string(info.camera.height) + " images, route '" + map.routes.front().name + "' " +
                     std::to_string(first.camera.width) + "x" + std::to_string(first.camera.height));
    }
  }
  for (std::size_t j = 0; j < map.junctions.size(); ++j) {
    const Junction& junction = map.junctions[j];
    const std::string label = where + ": junction " + std::to_string(j + 1) + " (" + toString(junction.from) +
                              " -> " + toString(junction.to) + ")";
    for (const KeyframeRef* ref : {&junction.from, &junction.to}) {
      if (map.find(ref->route) == nullptr) return invalid(label + ": no route '" + ref->route + "' in the map");
      if (map.keyframePosition(*ref) < 0) {
        return invalid(label + ": route '" + ref->route + "' has no keyframe " + std::to_string(ref->keyframe));
      }
    }
    if (junction.from == junction.to) return invalid(label + ": joins a keyframe to itself");
    if (!junction.to_in_from.isFinite() || !junction.covariance.allFinite()) {
      return invalid(label + ": pose or covariance is not finite");
    }
    if (junction.inliers < 0) return invalid(label + ": negative inliers");
  }
  return Status::ok();
}

KeyframeRef readRef(const Reader& reader, const YAML::Node& node, const std::string& key) {
  const YAML::Node child = node[key];
  if (!child || !child.IsMap()) throw reader.error(node, "missing map '" + key + "' ({route, keyframe})");
  KeyframeRef ref;
  ref.route = reader.get<std::string>(child, "route");
  ref.keyframe = reader.get<int>(child, "keyframe");
  return ref;
}

void emitRef(YAML::Emitter& out, const KeyframeRef& ref) {
  out << YAML::Flow << YAML::BeginMap << YAML::Key << "route" << YAML::Value << ref.route << YAML::Key
      << "keyframe" << YAML::Value << ref.keyframe << YAML::EndMap;
}

std::string emitIndex(const RouteMap& map) {
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "format_version" << YAML::Value << kRouteMapFormatVersion;
  out << YAML::Key << "routes" << YAML::Value << YAML::BeginSeq;
  for (const MapRoute& r : map.routes) {
    out << YAML::Flow << YAML::BeginMap << YAML::Key << "name" << YAML::Value << r.name << YAML::Key
        << "directory" << YAML::Value << r.directory << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::Key << "junctions" << YAML::Value << YAML::BeginSeq;
  for (const Junction& j : map.junctions) {
    out << YAML::BeginMap;
    out << YAML::Key << "from" << YAML::Value;
    emitRef(out, j.from);
    out << YAML::Key << "to" << YAML::Value;
    emitRef(out, j.to);
    out << YAML::Key << "pose" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x" << YAML::Value
        << j.to_in_from.x << YAML::Key << "y" << YAML::Value << j.to_in_from.y << YAML::Key << "yaw"
        << YAML::Value << j.to_in_from.yaw << YAML::EndMap;
    std::vector<double> covariance;
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) covariance.push_back(j.covariance(r, c));
    out << YAML::Key << "covariance" << YAML::Value << YAML::Flow << covariance;
    out << YAML::Key << "inliers" << YAML::Value << j.inliers;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq;
  out << YAML::EndMap;
  return std::string(out.c_str()) + "\n";
}

Expected<RouteMap> loadSingleRouteFolder(const std::string& directory) {
  auto route = loadRoute(directory);
  if (!route) return route.status();
  RouteMap map;
  map.directory = directory;
  map.loaded_format_version = route->loaded_format_version;
  map.routes.push_back(MapRoute{"route", ".", std::move(*route)});
  return map;
}

}  // namespace

std::string toString(const KeyframeRef& ref) { return ref.route + ":" + std::to_string(ref.keyframe); }

Expected<KeyframeRef> parseKeyframeRef(const std::string& text) {
  const auto colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0) {
    return Status(StatusCode::kInvalidInput, "'" + text + "' is not ROUTE:KEYFRAME");
  }
  KeyframeRef ref{text.substr(0, colon), -1};
  const std::string number = text.substr(colon + 1);
  std::size_t used = 0;
  try {
    ref.keyframe = std::stoi(number, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  if (used == 0 || used != number.size() || ref.keyframe < 0) {
    return Status(StatusCode::kInvalidInput, "'" + text + "': keyframe '" + number + "' is not a number >= 0");
  }
  return ref;
}

const MapRoute* RouteMap::find(const std::string& name) const {
  for (const MapRoute& r : routes) {
    if (r.name == name) return &r;
  }
  return nullptr;
}

int RouteMap::keyframePosition(const KeyframeRef& ref) const {
  const MapRoute* r = find(ref.route);
  if (r == nullptr) return -1;
  const auto& keyframes = r->route.keyframes;
  for (std::size_t k = 0; k < keyframes.size(); ++k) {
    if (keyframes[k].index == ref.keyframe) return static_cast<int>(k);
  }
  return -1;
}

std::optional<Pose2D> RouteMap::keyframePose(const KeyframeRef& ref) const {
  const int position = keyframePosition(ref);
  if (position < 0) return std::nullopt;
  return find(ref.route)->route.keyframes[static_cast<std::size_t>(position)].pose;
}

bool isValidRouteName(const std::string& name) {
  if (name.empty() || name.size() > 64) return false;
  return std::all_of(name.begin(), name.end(), [](char c) {
    return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '_' || c == '-';
  });
}

Expected<RouteMap> loadRouteMap(const std::string& directory) {
  const std::string index = indexPath(directory);
  std::error_code error;
  if (!fs::is_regular_file(index, error)) {
    if (fs::is_regular_file(directory + "/route.yaml", error)) return loadSingleRouteFolder(directory);
    return invalid("no map at '" + directory + "': neither " + kMapIndexName + " nor route.yaml found");
  }
  RouteMap map;
  map.directory = directory;
  const Reader reader(index);
  try {
    const YAML::Node root = YAML::LoadFile(index);
    if (!root.IsMap()) throw reader.error(root, "not a YAML map (empty or truncated file?)");
    const int version = reader.get<int>(root, "format_version");
    if (version != kRouteMapFormatVersion) {
      throw reader.error(root["format_version"], "unknown format_version " + std::to_string(version) +
                                                     " (this build reads map format " +
                                                     std::to_string(kRouteMapFormatVersion) + ")");
    }
    const YAML::Node routes = root["routes"];
    if (!routes || !routes.IsSequence()) throw reader.error(root, "missing list 'routes'");
    if (routes.size() == 0) throw reader.error(routes, "the map lists no route");
    for (const YAML::Node& node : routes) {
      MapRoute entry;
      entry.name = reader.get<std::string>(node, "name");
      entry.directory = reader.get<std::string>(node, "directory");
      if (!isValidRouteName(entry.name)) throw reader.error(node, badRouteName(entry.name));
      if (!isInsideMap(entry.directory)) {
        throw reader.error(node, "route '" + entry.name + "' has directory '" + entry.directory +
                                     "' outside the map (it must be relative, without '..')");
      }
      auto route = loadMapRoute(directory, entry);
      if (!route) throw reader.error(node, route.status().message());
      entry.route = std::move(*route);
      map.routes.push_back(std::move(entry));
    }
    if (const YAML::Node junctions = root["junctions"]) {
      if (!junctions.IsSequence()) throw reader.error(junctions, "'junctions' must be a list");
      for (const YAML::Node& node : junctions) {
        Junction junction;
        junction.from = readRef(reader, node, "from");
        junction.to = readRef(reader, node, "to");
        junction.to_in_from = reader.pose(node, "pose");
        const auto covariance = reader.get<std::vector<double>>(node, "covariance");
        if (covariance.size() != 9) throw reader.error(node, "field 'covariance' needs 9 numbers (row-major)");
        for (std::size_t i = 0; i < 9; ++i) {
          if (!std::isfinite(covariance[i])) throw reader.error(node, "field 'covariance' is not finite");
          junction.covariance(static_cast<int>(i / 3), static_cast<int>(i % 3)) = covariance[i];
        }
        junction.inliers = reader.get<int>(node, "inliers");
        map.junctions.push_back(junction);
      }
    }
  } catch (const YAML::Exception& e) {
    return invalid(index + ": " + e.what());
  } catch (const std::runtime_error& e) {
    return invalid(e.what());
  }
  Status valid = validate(map, index);
  if (!valid.isOk()) return valid;
  return map;
}

Status writeRouteMapIndex(const RouteMap& map) {
  if (map.routes.empty()) return invalid(indexPath(map.directory) + ": a map needs at least one route");
  Status valid = validate(map, indexPath(map.directory));
  if (!valid.isOk()) return valid;
  return writeFileAtomically(indexPath(map.directory), emitIndex(map));
}

Status migrateToRouteMap(const std::string& directory, const std::string& route_name) {
  std::error_code error;
  if (fs::is_regular_file(indexPath(directory), error)) return Status::ok();
  if (!isValidRouteName(route_name)) return invalid(badRouteName(route_name));
  auto map = loadSingleRouteFolder(directory);
  if (!map) return map.status();
  map->routes.front().name = route_name;
  return writeRouteMapIndex(*map);
}

std::string newRouteDirectory(const RouteMap& map, const std::string& name) {
  std::string base = std::string(kRoutesFolder) + "/" + name;
  auto taken = [&](const std::string& relative) {
    std::error_code error;
    if (fs::exists(fs::path(map.directory) / relative, error)) return true;
    return std::any_of(map.routes.begin(), map.routes.end(), [&](const MapRoute& r) { return r.directory == relative; });
  };
  if (!taken(base)) return base;
  for (int n = 2;; ++n) {
    std::string candidate = base + "." + std::to_string(n);
    if (!taken(candidate)) return candidate;
  }
}

namespace {

// Deletes a route's folder when it lies under routes/ (never the map folder itself).
void deleteRouteFolder(const RouteMap& map, const std::string& relative) {
  const fs::path path(relative);
  if (path.empty() || *path.begin() != kRoutesFolder || !isInsideMap(relative)) return;
  std::error_code error;
  fs::remove_all(fs::path(map.directory) / path, error);
}

}  // namespace

Status commitMapRoute(RouteMap& map, const std::string& name, const std::string& relative_directory,
                      std::vector<Junction>* dropped) {
  if (!isValidRouteName(name)) return invalid(badRouteName(name));
  if (!isInsideMap(relative_directory)) {
    return invalid("route directory '" + relative_directory + "' is outside the map");
  }
  MapRoute entry{name, relative_directory, Route{}};
  auto route = loadMapRoute(map.directory, entry);
  if (!route) return route.status();
  entry.route = std::move(*route);

  RouteMap updated = map;
  std::string replaced_directory;
  auto existing = std::find_if(updated.routes.begin(), updated.routes.end(),
                               [&](const MapRoute& r) { return r.name == name; });
  if (existing != updated.routes.end()) {
    replaced_directory = existing->directory;
    *existing = std::move(entry);
    std::vector<Junction> kept;
    for (const Junction& j : updated.junctions) {
      if (updated.keyframePosition(j.from) >= 0 && updated.keyframePosition(j.to) >= 0) {
        kept.push_back(j);
      } else if (dropped != nullptr) {
        dropped->push_back(j);
      }
    }
    updated.junctions = std::move(kept);
  } else {
    updated.routes.push_back(std::move(entry));
  }
  Status written = writeRouteMapIndex(updated);
  if (!written.isOk()) return written;
  map = std::move(updated);
  map.loaded_format_version = kRouteMapFormatVersion;
  if (!replaced_directory.empty() && replaced_directory != relative_directory) deleteRouteFolder(map, replaced_directory);
  return Status::ok();
}

Status renameMapRoute(RouteMap& map, const std::string& from, const std::string& to) {
  if (map.find(from) == nullptr) return invalid("no route '" + from + "' in the map at '" + map.directory + "'");
  if (!isValidRouteName(to)) return invalid(badRouteName(to));
  if (from == to) return Status::ok();
  if (map.find(to) != nullptr) return invalid("the map already has a route '" + to + "'");
  RouteMap updated = map;
  for (MapRoute& r : updated.routes) {
    if (r.name == from) r.name = to;
  }
  for (Junction& j : updated.junctions) {
    if (j.from.route == from) j.from.route = to;
    if (j.to.route == from) j.to.route = to;
  }
  Status written = writeRouteMapIndex(updated);
  if (!written.isOk()) return written;
  map = std::move(updated);
  return Status::ok();
}

Status removeMapRoute(RouteMap& map, const std::string& name) {
  const MapRoute* route = map.find(name);
  if (route == nullptr) return invalid("no route '" + name + "' in the map at '" + map.directory + "'");
  if (map.routes.size() == 1) return invalid("'" + name + "' is the map's only route (remove the folder instead)");
  const std::string directory = route->directory;
  RouteMap updated = map;
  updated.routes.erase(std::remove_if(updated.routes.begin(), updated.routes.end(),
                                      [&](const MapRoute& r) { return r.name == name; }),
                       updated.routes.end());
  updated.junctions.erase(std::remove_if(updated.junctions.begin(), updated.junctions.end(),
                                         [&](const Junction& j) { return j.from.route == name || j.to.route == name; }),
                          updated.junctions.end());
  Status written = writeRouteMapIndex(updated);
  if (!written.isOk()) return written;
  map = std::move(updated);
  deleteRouteFolder(map, directory);
  return Status::ok();
}

Status addJunction(RouteMap& map, const Junction& junction) {
  RouteMap updated = map;
  auto same = [&](const Junction& j) {
    return (j.from == junction.from && j.to == junction.to) || (j.from == junction.to && j.to == junction.from);
  };
  updated.junctions.erase(std::remove_if(updated.junctions.begin(), updated.junctions.end(), same),
                          updated.junctions.end());
  updated.junctions.push_back(junction);
  Status written = writeRouteMapIndex(updated);
  if (!written.isOk()) return written;
  map = std::move(updated);
  return Status::ok();
}

Expected<int> removeJunctions(RouteMap& map, const KeyframeRef& ref) {
  if (map.find(ref.route) == nullptr) return invalid("no route '" + ref.route + "' in the map at '" + map.directory + "'");
  auto touches = [&](const KeyframeRef& end) {
    return end.route == ref.route && (ref.keyframe < 0 || end.keyframe == ref.keyframe);
  };
  RouteMap updated = map;
  const auto before = updated.junctions.size();
  updated.junctions.erase(std::remove_if(updated.junctions.begin(), updated.junctions.end(),
                                         [&](const Junction& j) { return touches(j.from) || touches(j.to); }),
                          updated.junctions.end());
  const int removed = static_cast<int>(before - updated.junctions.size());
  if (removed == 0) return 0;
  Status written = writeRouteMapIndex(updated);
  if (!written.isOk()) return written;
  map = std::move(updated);
  return removed;
}

std::vector<std::string> listRouteMapOrphans(const RouteMap& map) {
  std::vector<std::string> orphans;
  std::error_code error;
  const fs::path routes = fs::path(map.directory) / kRoutesFolder;
  if (!fs::is_directory(routes, error)) return orphans;
  for (const auto& entry : fs::directory_iterator(routes, error)) {
    if (!entry.is_directory(error)) continue;
    const std::string relative = std::string(kRoutesFolder) + "/" + entry.path().filename().string();
    const bool named = std::any_of(map.routes.begin(), map.routes.end(),
                                   [&](const MapRoute& r) { return fs::path(r.directory).lexically_normal() == fs::path(relative); });
    if (!named) orphans.push_back(relative);
  }
  std::sort(orphans.begin(), orphans.end());
  return orphans;
}

Expected<Pose2D> junctionRouteTransform(const RouteMap& map, const Junction& junction) {
  const auto from_pose = map.keyframePose(junction.from);
  const auto to_pose = map.keyframePose(junction.to);
  if (!from_pose || !to_pose) {
    return Status(StatusCode::kInvalidInput, "junction " + toString(junction.from) + " -> " + toString(junction.to) +
                                                 ": " + toString(!from_pose ? junction.from : junction.to) +
                                                 " is not in the map");
  }
  return from_pose->compose(junction.to_in_from).compose(to_pose->inverse());
}

std::map<std::string, Pose2D> routeFramesInMap(const RouteMap& map, const std::string& root) {
  std::map<std::string, Pose2D> frames;
  if (map.routes.empty()) return frames;
  const std::string start = root.empty() ? map.routes.front().name : root;
  if (map.find(start) == nullptr) return frames;
  frames[start] = Pose2D();
  std::vector<std::string> frontier{start};
  while (!frontier.empty()) {
    std::vector<std::string> next;
    for (const std::string& route : frontier) {
      for (const Junction& j : map.junctions) {
        const bool forwards = j.from.route == route && frames.count(j.to.route) == 0;
        const bool backwards = j.to.route == route && frames.count(j.from.route) == 0;
        if (!forwards && !backwards) continue;
        const auto transform = junctionRouteTransform(map, j);
        if (!transform) continue;
        const std::string& other = forwards ? j.to.route : j.from.route;
        frames[other] = frames[route].compose(forwards ? *transform : transform->inverse());
        next.push_back(other);
      }
    }
    frontier = std::move(next);
  }
  return frames;
}

}  // namespace homography_teach_repeat
