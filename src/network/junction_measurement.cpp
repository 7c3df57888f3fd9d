#include "homography_teach_repeat/network/junction_measurement.h"

#include <Eigen/Geometry>

#include "homography_teach_repeat/teach_repeat/keyframe_estimators.h"
#include "homography_teach_repeat/teach_repeat/keyframe_store.h"

namespace homography_teach_repeat {

Expected<Junction> measureJunction(const RouteMap& map, const KeyframeRef& from, const KeyframeRef& to,
                                   const RepeatOptions& options) {
  const int from_position = map.keyframePosition(from);
  const int to_position = map.keyframePosition(to);
  if (from_position < 0) return Status(StatusCode::kInvalidInput, "junction: " + toString(from) + " is not in the map");
  if (to_position < 0) return Status(StatusCode::kInvalidInput, "junction: " + toString(to) + " is not in the map");
  const Route& from_route = map.find(from.route)->route;
  const Route& to_route = map.find(to.route)->route;

  // `from` alone as a route, so that its reference is prepared as the repeat prepares keyframes.
  Route single;
  single.directory = from_route.directory;
  single.info = from_route.info;
  single.keyframes.push_back(from_route.keyframes[static_cast<std::size_t>(from_position)]);
  single.keyframes.back().experiences.clear();
  RepeatOptions fast_hd = options;
  fast_hd.mode = RepeatMode::kFastHd;
  fast_hd.require_planes = true;
  fast_hd.use_experiences = false;
  fast_hd.plane_sigma_from_neighbours = false;  // one keyframe has no neighbours
  auto store = KeyframeStore::load(single, fast_hd);
  if (!store) return Status(StatusCode::kInvalidInput, "junction " + toString(from) + ": " + store.status().message());
  auto features = loadKeyframeFeatures(to_route, static_cast<std::size_t>(to_position));
  if (!features) return Status(StatusCode::kInvalidInput, "junction " + toString(to) + ": " + features.status().message());

  const EstimatorContext context{PinholeCamera(from_route.info.camera), from_route.info.feature_type,
                                 from_route.info.camera_mount, {single.keyframes.front().pose}, fast_hd};
  const auto estimator = makeKeyframeEstimator(context);
  FrameObservations frame;
  frame.features = std::move(*features);
  const auto estimate = estimator->estimate(store->at(0), 0, frame, std::nullopt);
  if (!estimate) return estimate.status();
  if (!estimate->has_pose || !estimate->covariance_known) {
    return Status(StatusCode::kDegenerate, "junction " + toString(from) + " -> " + toString(to) + ": no pose with covariance");
  }
  const Pose2D& keyframe_pose = single.keyframes.front().pose;
  Junction junction;
  junction.from = from;
  junction.to = to;
  junction.to_in_from = keyframe_pose.inverse().compose(estimate->base_pose);
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();  // route frame -> `from`'s keyframe frame
  rotation.topLeftCorner<2, 2>() = Eigen::Rotation2Dd(-keyframe_pose.yaw).toRotationMatrix();
  junction.covariance = rotation * estimate->covariance * rotation.transpose();
  junction.inliers = estimate->inliers;
  return junction;
}

}  // namespace homography_teach_repeat
