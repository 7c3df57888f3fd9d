// The `route_map` tool's commands (docs/map_format.md, "The route_map tool"):
//
//   route_map list MAP [--json]               routes, junctions, folders the index does not name
//   route_map migrate MAP [NAME]              writes map.yaml for a single-route folder
//   route_map rename MAP OLD NEW
//   route_map remove MAP NAME                 the route, its junctions and its folder
//   route_map remove-junctions MAP ROUTE[:KEYFRAME]
//   route_map plan MAP FROM_ROUTE:KEYFRAME TO_ROUTE:KEYFRAME [--json]
//   route_map junction MAP FROM_ROUTE:KEYFRAME TO_ROUTE:KEYFRAME   measures it from the images, adds it
//   route_map index MAP                       builds <map>/place_index.yml from every keyframe
//   route_map locate MAP IMAGE [--json]       the 10 keyframes the place index proposes for an image
//
// Exit status: 0 done; 2 bad usage or a map/route problem (the message names the file or the
// place); 3 for `plan` when the destination is not reachable.
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace homography_teach_repeat {

// Runs one command; `args` excludes the program name. Results to `out`, errors to `err`.
int runRouteMapCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace homography_teach_repeat
