#include "homography_teach_repeat/network/map_teach.h"

#include <cmath>
#include <filesystem>
#include <utility>

#include "homography_teach_repeat/common/text.h"
#include "homography_teach_repeat/network/junction_measurement.h"
#include "homography_teach_repeat/network/map_place_index.h"

namespace homography_teach_repeat {

Expected<MapTeach> MapTeach::start(const RouteMap& map, std::optional<PlaceIndex> index, const MapTeachOptions& options,
                                   const CameraCalibration& calibration, const Pose2D& camera_mount) {
  if (!isValidRouteName(options.name)) {
    return Status(StatusCode::kInvalidInput, "'" + options.name + "' is not a route name ([A-Za-z0-9_-]+)");
  }
  const std::string relative = newRouteDirectory(map, options.name);
  TeachOptions teach = options.teach;
  teach.route_directory = (std::filesystem::path(map.directory) / relative).string();
  teach.overwrite = false;
  // A new map has no routes/ yet (the session creates only the route's own folder).
  std::error_code error;
  std::filesystem::create_directories(std::filesystem::path(teach.route_directory).parent_path(), error);
  if (error) {
    return Status(StatusCode::kInvalidInput, "cannot create '" +
                                                 std::filesystem::path(teach.route_directory).parent_path().string() +
                                                 "': " + error.message());
  }
  auto session = TeachSession::start(teach, calibration, camera_mount);
  if (!session) return session.status();
  std::optional<MapRelocalizer> relocalizer;
  if (index && !map.routes.empty()) {
    // The relocalizer sees the stored keyframes only (0.5 m or 0.35 rad apart): a keyframe that
    // failed while the robot turned is tried again at the next one, not 5 keyframes (2.5 m) later
    // (the network demo's south branch rejoined the trunk over 1.6 m and was found on it only at
    // its last keyframe, tentative: the trunk keyframes there had failed during the turn before).
    RelocalizationOptions relocalization = options.relocalization;
    relocalization.retry_after_frames = 0;
    auto created = MapRelocalizer::create(map, std::move(index), options.repeat, relocalization);
    if (!created) return created.status();
    relocalizer.emplace(std::move(*created));
  }
  return MapTeach(map, std::move(*session), std::move(relocalizer), options, relative);
}

MapTeach::MapTeach(RouteMap map, TeachSession session, std::optional<MapRelocalizer> relocalizer,
                   MapTeachOptions options, std::string relative_directory)
    : map_(std::move(map)),
      session_(std::move(session)),
      relocalizer_(std::move(relocalizer)),
      options_(std::move(options)),
      relative_directory_(std::move(relative_directory)) {}

Expected<bool> MapTeach::offer(const cv::Mat& image, const Pose2D& odometry_pose, double stamp) {
  auto stored = session_.offer(image, odometry_pose, stamp);
  if (!stored || !*stored || !relocalizer_) return stored;
  const int keyframe = session_.route().keyframes.back().index;
  auto location = relocalizer_->update(image, odometry_pose);
  if (!location) {  // (the session accepted the image and the pose: not expected)
    last_location_.reset();
    return stored;
  }
  if (location->state == RelocalizationState::kConfirmed && nearItsKeyframe(*location->place)) {
    const MapContact contact{keyframe, location->place->keyframe};
    if (!stretch_last_) contacts_.push_back(contact);  // a stretch over taught ground begins
    stretch_last_ = contact;
    on_map_ = contact.map_keyframe;
  } else {
    closeStretch();
    on_map_.reset();
  }
  last_location_ = std::move(*location);
  return stored;
}

bool MapTeach::nearItsKeyframe(const PlaceHypothesis& place) const {
  const auto keyframe = map_.keyframePose(place.keyframe);
  return keyframe && withinContact(keyframe->inverse().compose(place.base_pose));
}

bool MapTeach::withinContact(const Pose2D& relative) const {
  return std::hypot(relative.x, relative.y) <= options_.contact_distance &&
         std::abs(wrapToPi(relative.yaw)) <= options_.contact_angle;
}

void MapTeach::closeStretch() {
  if (stretch_last_ && !(contacts_.back().keyframe == stretch_last_->keyframe)) contacts_.push_back(*stretch_last_);
  stretch_last_.reset();
}

std::optional<MapContact> MapTeach::tentativeEndContact() const {
  if (!last_location_ || last_location_->state != RelocalizationState::kTentative || last_location_->hypotheses.empty() ||
      session_.route().keyframes.empty()) {
    return std::nullopt;
  }
  const int last = session_.route().keyframes.back().index;
  if (!contacts_.empty() && contacts_.back().keyframe == last) return std::nullopt;
  const PlaceHypothesis& place = last_location_->hypotheses.front();
  if (!nearItsKeyframe(place)) return std::nullopt;
  return MapContact{last, place.keyframe};
}

Expected<MapTeachReport> MapTeach::finish() {
  closeStretch();
  const std::optional<MapContact> tentative_end = tentativeEndContact();
  if (tentative_end) contacts_.push_back(*tentative_end);
  MapTeachReport report;
  report.relative_directory = relative_directory_;
  auto planes = session_.finish();
  if (!planes) return planes.status();
  report.planes = *planes;
  const Route taught = session_.route();
  if (taught.keyframes.empty()) return Status(StatusCode::kInvalidInput, "the route has no keyframe: nothing to commit");
  // The junctions, measured against the map with the new route in it (nothing written yet).
  RouteMap with_route = map_;
  MapRoute added{options_.name, relative_directory_, taught};
  bool replaced = false;
  for (MapRoute& r : with_route.routes) {
    if (r.name == options_.name) {
      r = added;
      replaced = true;
    }
  }
  if (!replaced) with_route.routes.push_back(added);
  std::vector<Junction> junctions;
  for (const MapContact& c : contacts_) {
    // The route being taught again is replaced: its old keyframes are no junction partners.
    if (c.map_keyframe.route == options_.name) continue;
    const KeyframeRef here{options_.name, c.keyframe};
    auto junction = measureJunction(with_route, c.map_keyframe, here, options_.repeat);
    const bool unconfirmed = tentative_end && c.keyframe == tentative_end->keyframe;
    if (junction && unconfirmed && !withinContact(junction->to_in_from)) {
      const Pose2D& apart = junction->to_in_from;
      report.problems.push_back(toString(c.map_keyframe) + " -> " + toString(here) +
                                ": the route's last keyframe, its place tentative, measured " +
                                formatFixed(std::hypot(apart.x, apart.y), 2) + " m and " +
                                formatFixed(std::abs(wrapToPi(apart.yaw)), 2) + " rad from it: no junction");
    } else if (junction) {
      junctions.push_back(*junction);
    } else {
      report.problems.push_back(toString(c.map_keyframe) + " -> " + toString(here) + ": " + junction.status().message());
    }
  }
  const Status committed = commitMapRoute(map_, options_.name, relative_directory_, &report.dropped);
  if (!committed.isOk()) return committed;
  for (const Junction& j : junctions) {
    const Status added_junction = addJunction(map_, j);
    if (added_junction.isOk()) {
      report.junctions.push_back(j);
    } else {
      report.problems.push_back(toString(j.from) + " -> " + toString(j.to) + ": " + added_junction.message());
    }
  }
  if (options_.rebuild_index) {
    const auto index = buildMapPlaceIndex(map_);
    if (index && index->save(mapPlaceIndexPath(map_)).isOk()) {
      report.index_rebuilt = true;
    } else {
      report.problems.push_back("the place index was not rebuilt (" +
                                (index ? std::string("cannot write it") : index.status().message()) +
                                "): run route_map index " + map_.directory);
    }
  }
  return report;
}

}  // namespace homography_teach_repeat
