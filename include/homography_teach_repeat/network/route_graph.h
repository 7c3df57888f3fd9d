// The graph of a map of routes for planning (docs/map_format.md, "Going anywhere"): a vertex per
// keyframe; an edge from each keyframe to the next in the taught direction (a camera that looks
// ahead can only repeat a route forwards), from a closed route's last keyframe to its first, and
// both ways across every junction. An edge costs the distance between the two base_link poses
// [m] plus `turn_cost` [m/rad] times the heading change, so that of two paths of one length the
// straighter wins. Shortest paths by Dijkstra (Boost Graph Library).
#pragma once

#include <cstddef>
#include <memory>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/network/route_map.h"

namespace homography_teach_repeat {

struct RouteGraphOptions {
  // A route is a loop when its last keyframe is within this of its first [m] (the repeat's and
  // the controller's closed_route_gap).
  double closed_route_gap = 1.0;
  // [m/rad] added per radian of heading change along an edge.
  double turn_cost = 0.2;
};

// A way through the map: keyframes in the order the robot meets them.
struct NetworkPath {
  std::vector<KeyframeRef> keyframes;
  double cost = 0.0;           // [m], the sum of the edges' costs
  double length_m = 0.0;       // [m], the distance between consecutive keyframes' poses
  int junctions_crossed = 0;   // steps from one route to another
};

class RouteGraph {
 public:
  // The graph of `map` (its routes' keyframe poses and its junctions).
  RouteGraph(const RouteMap& map, const RouteGraphOptions& options = {});
  ~RouteGraph();
  RouteGraph(RouteGraph&&) noexcept;
  RouteGraph& operator=(RouteGraph&&) noexcept;

  std::size_t vertexCount() const;
  std::size_t edgeCount() const;

  // The cheapest path from `from` to `to` (both included; a single keyframe when they are equal).
  // kInvalidInput naming the keyframe when either is not in the map; kNoConsensus ("not reachable")
  // when no path leads there (e.g. back up an open route with no junction to turn around on).
  Expected<NetworkPath> shortestPath(const KeyframeRef& from, const KeyframeRef& to) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace homography_teach_repeat
