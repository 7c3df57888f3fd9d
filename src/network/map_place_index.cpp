#include "homography_teach_repeat/network/map_place_index.h"

#include <vector>

namespace homography_teach_repeat {
namespace {

std::vector<std::string> mapLabels(const RouteMap& map) {
  std::vector<std::string> labels;
  for (const MapRoute& r : map.routes) {
    for (const RouteKeyframe& k : r.route.keyframes) labels.push_back(toString(KeyframeRef{r.name, k.index}));
  }
  return labels;
}

}  // namespace

std::string mapPlaceIndexPath(const RouteMap& map) { return map.directory + "/place_index.yml"; }

Expected<PlaceIndex> buildMapPlaceIndex(const RouteMap& map, const PlaceIndexOptions& options) {
  std::vector<cv::Mat> descriptors;
  for (const MapRoute& r : map.routes) {
    for (std::size_t k = 0; k < r.route.keyframes.size(); ++k) {
      auto features = loadKeyframeFeatures(r.route, k);
      if (!features) {
        return Status(StatusCode::kInvalidInput, toString(KeyframeRef{r.name, r.route.keyframes[k].index}) + ": " +
                                                     features.status().message());
      }
      descriptors.push_back(features->descriptors);
    }
  }
  auto index = PlaceIndex::build(descriptors, options);
  if (!index) return index.status();
  const Status labelled = index->setLabels(mapLabels(map));
  if (!labelled.isOk()) return labelled;
  return index;
}

Expected<PlaceIndex> loadMapPlaceIndex(const RouteMap& map, const PlaceIndexOptions& options) {
  const std::string path = mapPlaceIndexPath(map);
  auto index = PlaceIndex::load(path, options);
  if (!index) return index.status();
  const std::vector<std::string> expected = mapLabels(map);
  const std::vector<std::string>& found = index->labels();
  std::size_t differs = 0;
  while (differs < expected.size() && differs < found.size() && expected[differs] == found[differs]) ++differs;
  if (differs == expected.size() && differs == found.size()) return index;
  std::string message = path;
  message += ": stale place index (keyframe " + std::to_string(differs + 1) + " is ";
  message += differs < found.size() ? found[differs] : "nothing";
  message += " in the index, ";
  message += differs < expected.size() ? expected[differs] : "nothing";
  message += " in the map): rebuild it with `route_map index " + map.directory + "`";
  return Status(StatusCode::kInvalidInput, message);
}

KeyframeRef keyframeOf(const PlaceIndex& index, const PlaceCandidate& candidate) {
  const std::string& label = index.labels().at(candidate.place);
  const auto colon = label.rfind(':');
  return KeyframeRef{label.substr(0, colon), std::stoi(label.substr(colon + 1))};
}

}  // namespace homography_teach_repeat
