// A route composed along a path through a map of routes (docs/map_format.md, "Going anywhere"), so
// that the repeat pipeline and the controller follow it like one taught route.
#pragma once

#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/network/route_graph.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

struct PathRoute {
  // The path's keyframes in order, indexed 0, 1, ...; their poses in one frame: the odometry
  // frame of the route the path starts on, the other routes' keyframes brought into it through
  // the junctions crossed (each junction's measured relative pose). Their files keep pointing into
  // their own routes (absolute paths); camera and feature type are the first route's. Nothing is
  // written: it is never saved as a route (learning views belongs to the source routes).
  Route route;
  std::vector<KeyframeRef> sources;  // per keyframe of `route`: the map keyframe it is
};

// kInvalidInput naming the step when the path is empty, names a keyframe the map does not have, or
// makes a step that is neither the next keyframe of a route (or a loop's wrap) nor a junction.
Expected<PathRoute> composePathRoute(const RouteMap& map, const NetworkPath& path,
                                     const RouteGraphOptions& options = {});

}  // namespace homography_teach_repeat
