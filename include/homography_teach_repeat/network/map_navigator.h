// Going anywhere in a map of routes, without ROS (docs/map_format.md, "Going anywhere"): where the
// robot is (relocalization from no hint or a hint, map_relocalizer.h), the way from there to a
// destination (the graph, route_graph.h), and the repeat along it (a RepeatPipeline on the route
// composed along the way, path_route.h). A node converts messages and publishes what it returns.
//
//  - kRelocalizing: every frame goes to the relocalizer; no pose. Once a place is confirmed the
//    navigator is kPlaced (it knows the keyframe and the pose in that route's frame).
//  - setDestination(): from the confirmed place (or, while following, from the keyframe the repeat
//    tracks) the shortest way to the destination is planned and composed into one route, whose
//    first keyframe is where the robot is; a RepeatPipeline starts on it (kFollowing) and every
//    frame goes to it: its pose, covariance and map_to_odom are given in the map frame (the frame
//    of the map's first route, routeFramesInMap), like the way's poses (wayInMap).
//  - relocalize(): back to kRelocalizing (the robot was carried elsewhere; a new hint).
// The pipeline's odometry gate, integrity monitor and search behave as on a single route.
#pragma once

#include <opencv2/core.hpp>

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/odometry_buffer.h"
#include "homography_teach_repeat/network/map_relocalizer.h"
#include "homography_teach_repeat/network/path_route.h"
#include "homography_teach_repeat/network/route_graph.h"
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"

namespace homography_teach_repeat {

struct MapNavigatorOptions {
  RepeatPipelineOptions repeat;  // start_keyframe is the navigator's (the way's first keyframe)
  RelocalizationOptions relocalization;
  RouteGraphOptions graph;
  double odometry_lag = 0.1;     // [s] an image's odometry may be this much older than the image

  void validate() const;  // throws std::invalid_argument naming the bad field
};

enum class NavigatorMode { kRelocalizing, kPlaced, kFollowing };
std::string toString(NavigatorMode mode);  // "relocalizing", "placed", "following"

struct NavigatorFrame {
  NavigatorMode mode = NavigatorMode::kRelocalizing;  // after this frame
  Status status = Status::ok();                 // bad input (image, camera, odometry)
  std::optional<Relocalization> relocalization;  // the frame went to the relocalizer
  std::optional<RepeatFrameResult> repeat;        // the frame went to the repeat along the way
};

// Re-expresses a frame's pose, covariance (x, y, yaw) and map_to_odom, given in a frame F, in the
// frame in which F is at `frame` (a rotation of the covariance's x, y block by frame.yaw).
void expressRepeatResultIn(const Pose2D& frame, RepeatFrameResult* result);

class MapNavigator {
 public:
  // kInvalidInput for bad options or what MapRelocalizer::create refuses.
  static Expected<MapNavigator> create(const RouteMap& map, std::optional<PlaceIndex> index,
                                       const MapNavigatorOptions& options = {});

  // An odometry sample (odometry frame); kInvalidInput for a non-finite pose.
  Status addOdometry(double stamp, const Pose2D& odom);
  NavigatorFrame processFrame(double stamp, const Expected<cv::Mat>& image, const Expected<PinholeCamera>& camera);

  // Plans the way from where the robot is to `destination` and follows it from the next frame.
  // kInvalidInput when the destination is not in the map, or the robot's place is not known yet
  // (still relocalizing), or the way starts on a route no junction joins to the map frame's route
  // (its poses have no map frame); kNoConsensus ("not reachable") when no way leads there; the
  // composed route's or the pipeline's errors.
  Expected<NetworkPath> setDestination(const KeyframeRef& destination);
  // Forgets the place and relocalizes, around `hint` when given (kInvalidInput for a bad hint).
  Status relocalize(const std::optional<PlaceHint>& hint = std::nullopt);

  // Before the first frame: the relocalizer's first feature detection (MapRelocalizer::warmUp).
  void warmUp() { relocalizer_.warmUp(); }

  NavigatorMode mode() const { return mode_; }
  // The map keyframe the robot is at: the confirmed place, or while following the keyframe of the
  // way the repeat tracks. Empty while relocalizing.
  std::optional<KeyframeRef> place() const;
  const std::optional<PathRoute>& way() const { return way_; }
  // The way's keyframe poses (base_link) in the map frame; empty when not following.
  std::vector<Pose2D> wayInMap() const;
  // Where each route's odometry frame is in the map frame (routeFramesInMap of the map's first route).
  const std::map<std::string, Pose2D>& routeFrames() const { return route_frames_; }
  // New localization options (dynamic_reconfigure) for the way followed now and the next ones;
  // the pipeline's refusal leaves both as they were.
  Status reconfigure(const RepeatOptions& options);
  const RepeatPipeline* pipeline() const { return pipeline_ ? &*pipeline_ : nullptr; }
  RepeatPipeline* pipeline() { return pipeline_ ? &*pipeline_ : nullptr; }
  const MapNavigatorOptions& options() const { return options_; }
  const MapRelocalizer& relocalizer() const { return relocalizer_; }
  const RouteMap& map() const { return relocalizer_.map(); }

 private:
  MapNavigator(MapRelocalizer relocalizer, const MapNavigatorOptions& options);

  MapRelocalizer relocalizer_;
  MapNavigatorOptions options_;
  RouteGraph graph_;
  std::map<std::string, Pose2D> route_frames_;
  Pose2D way_in_map_;  // the way's frame (its first route's) in the map frame
  OdometryBuffer odometry_;
  NavigatorMode mode_ = NavigatorMode::kRelocalizing;
  std::optional<PlaceHypothesis> placed_;
  std::optional<PathRoute> way_;
  std::optional<RepeatPipeline> pipeline_;
};

}  // namespace homography_teach_repeat
