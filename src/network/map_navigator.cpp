#include "homography_teach_repeat/network/map_navigator.h"

#include <Eigen/Geometry>

#include <cmath>
#include <stdexcept>
#include <utility>

namespace homography_teach_repeat {

void MapNavigatorOptions::validate() const {
  repeat.validate();
  relocalization.validate();
  if (!(std::isfinite(odometry_lag) && odometry_lag >= 0.0)) {
    throw std::invalid_argument("navigator: odometry_lag must be finite and >= 0 [s]");
  }
  if (!(std::isfinite(graph.turn_cost) && graph.turn_cost >= 0.0) || !(graph.closed_route_gap >= 0.0)) {
    throw std::invalid_argument("navigator: graph turn_cost and closed_route_gap must be >= 0");
  }
}

std::string toString(NavigatorMode mode) {
  switch (mode) {
    case NavigatorMode::kRelocalizing: return "relocalizing";
    case NavigatorMode::kPlaced: return "placed";
    case NavigatorMode::kFollowing: return "following";
  }
  return "unknown";
}

Expected<MapNavigator> MapNavigator::create(const RouteMap& map, std::optional<PlaceIndex> index,
                                            const MapNavigatorOptions& options) {
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  auto relocalizer = MapRelocalizer::create(map, std::move(index), options.repeat.localization, options.relocalization);
  if (!relocalizer) return relocalizer.status();
  return MapNavigator(std::move(*relocalizer), options);
}

void expressRepeatResultIn(const Pose2D& frame, RepeatFrameResult* result) {
  if (result->pose) result->pose = frame.compose(*result->pose);
  if (result->map_to_odom) result->map_to_odom = frame.compose(*result->map_to_odom);
  if (result->covariance) {
    Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
    rotation.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(frame.yaw).toRotationMatrix();
    result->covariance = rotation * *result->covariance * rotation.transpose();
  }
}

MapNavigator::MapNavigator(MapRelocalizer relocalizer, const MapNavigatorOptions& options)
    : relocalizer_(std::move(relocalizer)),
      options_(options),
      graph_(relocalizer_.map(), options.graph),
      route_frames_(routeFramesInMap(relocalizer_.map())) {}

std::vector<Pose2D> MapNavigator::wayInMap() const {
  std::vector<Pose2D> poses;
  if (!way_) return poses;
  for (const auto& keyframe : way_->route.keyframes) poses.push_back(way_in_map_.compose(keyframe.pose));
  return poses;
}

Status MapNavigator::reconfigure(const RepeatOptions& options) {
  if (pipeline_) {
    Status changed = pipeline_->reconfigure(options);
    if (!changed.isOk()) return changed;
  }
  options_.repeat.localization = options;
  return Status::ok();
}

Status MapNavigator::addOdometry(double stamp, const Pose2D& odom) {
  Status added = odometry_.add(stamp, odom);
  if (!added.isOk()) return added;
  return pipeline_ ? pipeline_->addOdometry(stamp, odom) : Status::ok();
}

NavigatorFrame MapNavigator::processFrame(double stamp, const Expected<cv::Mat>& image,
                                          const Expected<PinholeCamera>& camera) {
  NavigatorFrame frame;
  if (mode_ == NavigatorMode::kFollowing) {
    frame.repeat = pipeline_->processFrame(stamp, image, camera);
    expressRepeatResultIn(way_in_map_, &*frame.repeat);
    frame.mode = mode_;
    return frame;
  }
  frame.mode = mode_;
  if (!image) {
    frame.status = image.status();
    return frame;
  }
  if (!camera) {
    frame.status = camera.status();
    return frame;
  }
  const CameraCalibration& taught = map().routes.front().route.info.camera;
  if (image->cols != taught.width || image->rows != taught.height) {
    frame.status = Status(StatusCode::kInvalidInput, "the image is " + std::to_string(image->cols) + "x" +
                                                         std::to_string(image->rows) + ", the map's camera " +
                                                         std::to_string(taught.width) + "x" + std::to_string(taught.height));
    return frame;
  }
  const auto odom = odometry_.poseNear(stamp, options_.odometry_lag);
  if (!odom) {
    frame.status = Status(odom.status().code(), "no odometry for this image: " + odom.status().message());
    return frame;
  }
  auto relocalization = relocalizer_.update(*image, *odom);
  if (!relocalization) {
    frame.status = relocalization.status();
    return frame;
  }
  // A place is planned from only while the relocalizer stands by it.
  if (relocalization->state == RelocalizationState::kConfirmed) {
    placed_ = relocalization->place;
    mode_ = NavigatorMode::kPlaced;
  } else {
    placed_.reset();
    mode_ = NavigatorMode::kRelocalizing;
  }
  frame.relocalization = std::move(*relocalization);
  frame.mode = mode_;
  return frame;
}

std::optional<KeyframeRef> MapNavigator::place() const {
  if (mode_ == NavigatorMode::kPlaced && placed_) return placed_->keyframe;
  if (mode_ == NavigatorMode::kFollowing && pipeline_ && way_) {
    const int tracked = pipeline_->localizer().trackedKeyframe();
    if (tracked >= 0 && static_cast<std::size_t>(tracked) < way_->sources.size()) {
      return way_->sources[static_cast<std::size_t>(tracked)];
    }
  }
  return std::nullopt;
}

Expected<NetworkPath> MapNavigator::setDestination(const KeyframeRef& destination) {
  if (map().keyframePosition(destination) < 0) {
    return Status(StatusCode::kInvalidInput, "the destination " + toString(destination) + " is not in the map");
  }
  const auto from = place();
  if (!from) {
    return Status(StatusCode::kInvalidInput, "the robot's place is not known yet (relocalizing): no way can be planned");
  }
  const auto frame = route_frames_.find(from->route);
  if (frame == route_frames_.end()) {
    return Status(StatusCode::kInvalidInput, "the robot is on route '" + from->route + "', which no junction joins to '" +
                                                 map().routes.front().name +
                                                 "' (the map frame): its poses have no map frame; teach a junction");
  }
  auto path = graph_.shortestPath(*from, destination);
  if (!path) return path.status();
  auto way = composePathRoute(map(), *path, options_.graph);
  if (!way) return way.status();
  RepeatPipelineOptions options = options_.repeat;
  options.start_keyframe = 0;  // the way starts where the robot is
  auto pipeline = RepeatPipeline::create(way->route, options);
  if (!pipeline) return pipeline.status();
  // The newest odometry, so that the next image finds some.
  if (!odometry_.empty()) {
    const auto newest = odometry_.poseAt(odometry_.newestStamp());
    if (newest) (void)pipeline->addOdometry(odometry_.newestStamp(), *newest);
  }
  pipeline->warmUp();
  way_ = std::move(*way);
  way_in_map_ = frame->second;
  pipeline_.emplace(std::move(*pipeline));
  mode_ = NavigatorMode::kFollowing;
  return path;
}

Status MapNavigator::relocalize(const std::optional<PlaceHint>& hint) {
  relocalizer_.reset();
  if (hint) {
    Status set = relocalizer_.setHint(*hint);
    if (!set.isOk()) return set;
  }
  pipeline_.reset();
  way_.reset();
  placed_.reset();
  mode_ = NavigatorMode::kRelocalizing;
  return Status::ok();
}

}  // namespace homography_teach_repeat
