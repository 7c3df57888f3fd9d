// A map of routes: one folder holding any number of taught routes and the junctions between them
// (docs/map_format.md).
//
//   <map>/map.yaml                 the index (format_version 3), written atomically, last
//   <map>/routes/<name>/route.yaml  one taught route each (docs/route_format.md, version 2)
//
// map.yaml:
//   format_version: 3
//   routes:
//     - {name: corridor, directory: routes/corridor}    # directory relative to the map folder
//   junctions:                                           # where a route leaves or rejoins another
//     - {from: {route: corridor, keyframe: 12},           # keyframes by their `index` in route.yaml
//        to: {route: room_a, keyframe: 0},
//        pose: {x, y, yaw},           # base_link of `to`'s keyframe in base_link of `from`'s [m, rad]
//        covariance: [9 numbers],     # of that pose (x, y, yaw), row-major
//        inliers: 143}                # image matches that measured it; 0 = odometry only
//
// A folder that holds a route.yaml and no map.yaml (every route taught before maps existed, format
// 1 or 2) loads as a map of that one route, named "route", at directory "." (nothing is moved);
// migrateToRouteMap writes its map.yaml. The single-route workflow (teach_node route:=DIR,
// repeat_node route:=DIR) keeps working on both.
//
// Crash safety: the index is the only file that says what the map holds, and it is replaced by one
// atomic rename. A new or re-taught route is written to a folder the index does not name yet, then
// committed by rewriting the index; a removed route's files are deleted after the index no longer
// names them. A crash at any moment leaves a map that loads: the previous one or the new one
// (at worst with an unnamed folder under routes/, which listRouteMapOrphans reports).
#pragma once

#include <Eigen/Core>

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

constexpr int kRouteMapFormatVersion = 3;

// A keyframe of a route of a map: the route's name and the keyframe's `index` in its route.yaml.
struct KeyframeRef {
  std::string route;
  int keyframe = 0;
  bool operator==(const KeyframeRef& other) const { return route == other.route && keyframe == other.keyframe; }
  bool operator!=(const KeyframeRef& other) const { return !(*this == other); }
};
std::string toString(const KeyframeRef& ref);  // "corridor:12"
// "corridor:12" back into a reference; kInvalidInput naming the text when it is not ROUTE:KEYFRAME
// with a keyframe number >= 0 (whether the map has it is keyframePosition's question).
Expected<KeyframeRef> parseKeyframeRef(const std::string& text);

// Where two routes' keyframes see the same place: the relative pose of their base_link frames as
// measured from the images (or from odometry while teaching, with `inliers` 0), both ways usable.
struct Junction {
  KeyframeRef from;
  KeyframeRef to;
  Pose2D to_in_from;  // base_link of `to`'s keyframe in base_link of `from`'s keyframe [m, rad]
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // of to_in_from (x, y, yaw)
  int inliers = 0;
};

struct MapRoute {
  std::string name;       // [A-Za-z0-9_-]+, unique in the map
  std::string directory;  // relative to the map folder, as in map.yaml ("." for a migrated route)
  Route route;            // its route.yaml, loaded and validated (not the per-keyframe files)
};

struct RouteMap {
  std::string directory;
  std::vector<MapRoute> routes;
  std::vector<Junction> junctions;
  // As found on disk: 3 for a map; 1 or 2 for a single-route folder without map.yaml.
  int loaded_format_version = kRouteMapFormatVersion;

  const MapRoute* find(const std::string& name) const;
  // The position of keyframe `ref` in its route's keyframes; -1 when the route or keyframe is not there.
  int keyframePosition(const KeyframeRef& ref) const;
  // The base_link pose of keyframe `ref` in its route's odometry frame; nullopt when not in the map.
  std::optional<Pose2D> keyframePose(const KeyframeRef& ref) const;
};

// Loads map.yaml and every route it names (or a single-route folder, see above). kInvalidInput
// naming the file and the problem: no map.yaml nor route.yaml, YAML errors (with line), an unknown
// format_version, missing or ill-typed fields, non-finite numbers, a bad or duplicate route name,
// a route directory outside the map or without a valid route.yaml (its own error), two routes
// with different feature types or image sizes, a junction naming a route or keyframe the map does
// not have, a junction from a keyframe to itself.
Expected<RouteMap> loadRouteMap(const std::string& directory);

// Validates `map` as loadRouteMap would and writes map.yaml atomically. kInvalidInput on an
// invalid map (nothing is written) or a write failure (the previous index is intact).
Status writeRouteMapIndex(const RouteMap& map);

// Writes map.yaml for a single-route folder (its route named `route_name`, at "."); a folder
// that already has a map.yaml is left as it is. kInvalidInput when the folder holds no valid route.
Status migrateToRouteMap(const std::string& directory, const std::string& route_name = "route");

// Whether `name` may name a route: 1 to 64 of [A-Za-z0-9_-].
bool isValidRouteName(const std::string& name);

// The folder, relative to the map, where a route called `name` is (re)taught before it is
// committed with commitMapRoute: routes/<name>, or routes/<name>.<n> with the smallest n >= 2
// that does not exist yet (a re-teach never writes into the folder the index still names).
std::string newRouteDirectory(const RouteMap& map, const std::string& name);

// Commits the route taught in `relative_directory` under `name` and rewrites the index. A new name
// adds a route. An existing name is replaced: its junctions are kept where their keyframe index
// is still in the new route (the others are dropped and listed in `dropped`, if given), and the
// old folder is deleted once the index names the new one. kInvalidInput on a bad name, a folder
// without a valid route, a route that does not fit the map (feature type, image size), or a write
// failure (the map on disk is unchanged).
Status commitMapRoute(RouteMap& map, const std::string& name, const std::string& relative_directory,
                      std::vector<Junction>* dropped = nullptr);

// Renames a route (its junctions follow). kInvalidInput for an unknown `from`, an invalid or taken `to`.
Status renameMapRoute(RouteMap& map, const std::string& from, const std::string& to);

// Removes a route and its junctions from the index, then deletes its folder when the folder is
// under routes/ (a migrated route at "." keeps its files). kInvalidInput for an unknown name.
Status removeMapRoute(RouteMap& map, const std::string& name);

// Adds a junction and rewrites the index (a junction between the same two keyframes is replaced).
// kInvalidInput when it names a route or keyframe the map does not have, or a value is not finite.
Status addJunction(RouteMap& map, const Junction& junction);

// Removes the junctions touching keyframe `ref` (all of `ref.route`'s when ref.keyframe < 0) and
// rewrites the index; the number removed, or kInvalidInput for an unknown route.
Expected<int> removeJunctions(RouteMap& map, const KeyframeRef& ref);

// Folders under routes/ that the index does not name (left by a crash during a teach or a removal).
std::vector<std::string> listRouteMapOrphans(const RouteMap& map);

// The odometry frame of the junction's `to` route in that of its `from` route: the `from`
// keyframe's pose ∘ to_in_from ∘ the `to` keyframe's pose⁻¹. kInvalidInput when either keyframe is
// not in the map.
Expected<Pose2D> junctionRouteTransform(const RouteMap& map, const Junction& junction);

// Every route's odometry frame in one map frame: that of `root` (empty: the first route), the others
// carried through the junctions, fewest junctions first. Routes no junction joins to the root are
// absent (they have no common frame with it).
std::map<std::string, Pose2D> routeFramesInMap(const RouteMap& map, const std::string& root = "");

}  // namespace homography_teach_repeat
