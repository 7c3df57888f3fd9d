// The place index of a map of routes (docs/map_format.md, "Finding the place without a hint"):
// built from every route's keyframe features, each keyframe labelled "route:index", saved as
// <map>/place_index.yml. Built by `route_map index MAP`; a map edited afterwards needs it rebuilt
// (loading names the difference).
#pragma once

#include <string>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/network/place_index.h"
#include "homography_teach_repeat/network/route_map.h"

namespace homography_teach_repeat {

std::string mapPlaceIndexPath(const RouteMap& map);  // <map>/place_index.yml

// Reads every keyframe's features (taught views) and builds the index. kInvalidInput naming the
// keyframe whose features are missing or corrupt; PlaceIndex::build's errors.
Expected<PlaceIndex> buildMapPlaceIndex(const RouteMap& map, const PlaceIndexOptions& options = {});

// Loads <map>/place_index.yml and checks that it indexes exactly the map's keyframes, in order.
// kInvalidInput naming the file when it is missing, corrupt, or stale (the first keyframe that differs).
Expected<PlaceIndex> loadMapPlaceIndex(const RouteMap& map, const PlaceIndexOptions& options = {});

// The map keyframe a candidate stands for (from the index's labels).
KeyframeRef keyframeOf(const PlaceIndex& index, const PlaceCandidate& candidate);

}  // namespace homography_teach_repeat
