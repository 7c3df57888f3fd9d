#include "homography_teach_repeat/teach_repeat/teach_session.h"

#include "homography_teach_repeat/homography/image_registration.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/fast_hd/plane_estimation.h"
#include "homography_teach_repeat/teach_repeat/keyframe_store.h"

namespace homography_teach_repeat {

void KeyframePolicy::validate() const {
  if (!std::isfinite(distance) || !(distance > 0.0)) {
    throw std::invalid_argument("keyframe_distance must be finite and > 0");
  }
  if (!std::isfinite(angle) || !(angle > 0.0)) {
    throw std::invalid_argument("keyframe_angle must be finite and > 0");
  }
}

bool KeyframePolicy::shouldStore(const std::optional<Pose2D>& last_keyframe,
                                 const Pose2D& current) const {
  if (!last_keyframe) return true;
  return std::hypot(current.x - last_keyframe->x, current.y - last_keyframe->y) >= distance ||
         std::abs(wrapToPi(current.yaw - last_keyframe->yaw)) >= angle;
}

KeyframeTilt keyframeTiltFromString(const std::string& name) {
  if (name == "auto") return KeyframeTilt::kAuto;
  if (name == "true") return KeyframeTilt::kEstimate;
  if (name == "false") return KeyframeTilt::kLevel;
  throw std::invalid_argument("estimate_keyframe_tilt must be auto, true or false, got '" + name + "'");
}

std::string toString(KeyframeTilt mode) {
  switch (mode) {
    case KeyframeTilt::kEstimate:
      return "true";
    case KeyframeTilt::kLevel:
      return "false";
    case KeyframeTilt::kAuto:
      break;
  }
  return "auto";
}

bool estimatesKeyframeTilt(KeyframeTilt mode, const std::optional<double>& measured_tilt_sigma) {
  if (mode == KeyframeTilt::kEstimate) return true;
  if (mode == KeyframeTilt::kLevel) return false;
  return measured_tilt_sigma && *measured_tilt_sigma > kTiltedBodySigma;
}

std::string describeKeyframeTilt(const PlaneEstimationReport& report, KeyframeTilt mode) {
  char measured[96] = "not measured";
  if (report.measured_tilt_rad) {
    std::snprintf(measured, sizeof(measured), "%.4f rad", *report.measured_tilt_rad);
  }
  const std::string state = report.keyframe_tilt_estimated ? "estimated with the planes" : "not estimated";
  if (mode != KeyframeTilt::kAuto) {
    return "keyframe tilt " + state + ": estimate_keyframe_tilt " + toString(mode) + " (the pairs' relative tilt " +
           measured + ")";
  }
  char threshold[32];
  std::snprintf(threshold, sizeof(threshold), "%.3f rad", kTiltedBodySigma);
  return "keyframe tilt " + state + ": estimate_keyframe_tilt auto, the pairs' relative tilt " + measured +
         (report.keyframe_tilt_estimated ? " is above " : " is not above ") + threshold;
}

void TeachOptions::validate() const {
  if (route_directory.empty()) throw std::invalid_argument("route_directory must be set");
  features.validate();
  matching.validate();
  robust.validate();
  lines.validate();
  keyframes.validate();
  plane_measurement.validate();
  if (!std::isfinite(first_plane_distance) || first_plane_distance < 0.0) {
    throw std::invalid_argument("first_plane_distance must be finite and >= 0 (0: no planes)");
  }
  if (!std::isfinite(closed_route_gap) || closed_route_gap < 0.0) {
    throw std::invalid_argument("closed_route_gap must be finite and >= 0 (0: no route is a loop)");
  }
}

TeachSession::TeachSession(const TeachOptions& options, const CameraCalibration& calibration)
    : options_(options),
      camera_(calibration),
      features_(options.features),
      lines_(options.lines) {}

Expected<TeachSession> TeachSession::start(const TeachOptions& options,
                                           const CameraCalibration& calibration,
                                           const Pose2D& camera_mount) {
  try {
    options.validate();
    TeachSession session(options, calibration);
    RouteInfo info;
    info.feature_type = options.features.type;
    info.camera = calibration;
    info.camera_mount = camera_mount;
    info.first_plane_distance = options.first_plane_distance;
    auto writer = RouteWriter::create(options.route_directory, info, options.overwrite);
    if (!writer) return writer.status();
    session.writer_.emplace(std::move(*writer));
    return session;
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
}

Expected<bool> TeachSession::offer(const cv::Mat& image, const Pose2D& odometry_pose,
                                   double stamp) {
  if (!std::isfinite(odometry_pose.x) || !std::isfinite(odometry_pose.y) ||
      !std::isfinite(odometry_pose.yaw) || !std::isfinite(stamp)) {
    return Status(StatusCode::kInvalidInput, "odometry pose or stamp is not finite");
  }
  if (image.cols != camera_.width() || image.rows != camera_.height()) {
    return Status(StatusCode::kInvalidInput,
                  "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                      ", the route's camera is " + std::to_string(camera_.width()) + "x" +
                      std::to_string(camera_.height()));
  }
  if (!options_.keyframes.shouldStore(last_keyframe_pose_, odometry_pose)) return false;
  auto features = features_.extract(image);
  if (!features) return features.status();
  auto lines = lines_.extract(image, &camera_);
  if (!lines) return lines.status();
  const Status written = writer_->addKeyframe(image, *features, *lines, odometry_pose, stamp);
  if (!written.isOk()) return written;
  last_stored_ = StoredCounts{static_cast<int>(features->keypoints.size()), static_cast<int>(lines->size())};
  keyframe_features_.push_back(std::move(*features));
  last_keyframe_pose_ = odometry_pose;
  return true;
}

Expected<PlaneEstimationReport> TeachSession::finish() {
  PlaneEstimationReport report;
  const Route& route = writer_->route();
  report.keyframes = static_cast<int>(route.keyframes.size());
  if (route.keyframes.size() < 2) {
    return Status(StatusCode::kTooFewPoints, "plane estimation needs at least 2 keyframes, have " +
                                                 std::to_string(route.keyframes.size()));
  }
  if (!options_.planes_from_odometry && !(options_.first_plane_distance > 0.0)) {
    return Status(StatusCode::kInvalidInput,
                  "first_plane_distance is not set: planes cannot be given a metric scale");
  }
  const CameraMount mount(route.info.camera_mount.x, route.info.camera_mount.y,
                          route.info.camera_mount.yaw);
  // Consecutive pairs until the first failure: the propagation (docs/math.md §2.2) needs every link.
  std::vector<ReferencePair> pairs;
  std::vector<std::optional<MatchResidual>> residuals(route.keyframes.size());
  std::vector<std::optional<PairTilt>> tilts(route.keyframes.size());
  for (std::size_t k = 0; k + 1 < route.keyframes.size(); ++k) {
    const auto registered = registerFeatures(keyframe_features_[k], keyframe_features_[k + 1], options_.matching,
                                             options_.robust, &camera_);
    ReferencePair pair;
    pair.has_odometry = true;
    pair.odometry_motion =
        mount.baseToCamera(route.keyframes[k].pose.inverse().compose(route.keyframes[k + 1].pose));
    if (!registered) {
      report.messages.push_back("pair " + std::to_string(k) + ": " + registered.status().toString());
      if (!options_.planes_from_odometry) break;
      pair.has_homography = false;
      pairs.push_back(pair);
      continue;
    }
    residuals[k] = matchResidualOf(*registered);
    tilts[k] = pairTiltOf(*registered, camera_, pair.odometry_motion);
    pair.H_next_from_current = registered->homography.H;
    for (const int i : registered->homography.inliers) {
      pair.reference_pixels.push_back(registered->matches[static_cast<std::size_t>(i)].reference);
    }
    pairs.push_back(pair);
  }
  const Status measured = writer_->setMeasuredNoise(residuals, tilts);  // written with the planes below
  if (!measured.isOk()) return measured;
  report.measured_tilt_rad = routeTiltSigma(route);  // the tilts just measured
  report.keyframe_tilt_estimated = estimatesKeyframeTilt(options_.keyframe_tilt, report.measured_tilt_rad);
  std::vector<std::optional<ScenePlane>> planes(route.keyframes.size());
  OdometryPlaneOptions plane_options;
  plane_options.estimate_tilt = report.keyframe_tilt_estimated;
  if (isClosedRoute(route, options_.closed_route_gap)) {
    plane_options.closing_motion =
        mount.baseToCamera(route.keyframes.back().pose.inverse().compose(route.keyframes.front().pose));
  }
  if (!pairs.empty()) {
    const auto estimated = options_.planes_from_odometry
                               ? estimatePlanesFromOdometry(pairs, camera_, plane_options)
                               : estimatePlanesAlongRoute(pairs, camera_, options_.first_plane_distance);
    if (estimated) {
      for (std::size_t k = 0; k < estimated->planes.size(); ++k) planes[k] = estimated->planes[k];
      report.planes = static_cast<int>(estimated->planes.size());
    } else {
      report.messages.push_back("plane estimation: " + estimated.status().toString());
    }
  }
  const Status written = writer_->setPlanes(planes, options_.first_plane_distance);
  if (!written.isOk()) return written;
  if (report.planes > 0) {
    Route measured = route;
    const Status uncertainty = measurePlaneUncertainty(measured, options_.plane_measurement);
    std::vector<std::optional<PlaneUncertainty>> uncertainties;
    for (const RouteKeyframe& keyframe : measured.keyframes) uncertainties.push_back(keyframe.plane_uncertainty);
    const Status stored = uncertainty.isOk() ? writer_->setPlaneUncertainties(uncertainties) : uncertainty;
    if (!stored.isOk()) report.messages.push_back("plane uncertainty: " + stored.message());
  }
  return report;
}

std::optional<MatchResidual> matchResidualOf(const RegistrationResult& registered) {
  const MatchResidual residual{registered.homography.rms_transfer_error_px,
                               static_cast<int>(registered.homography.inliers.size())};
  if (residual.inliers < 4 || !std::isfinite(residual.rms_px) || !(residual.rms_px > 0.0)) return std::nullopt;
  return residual;
}

std::optional<PairTilt> pairTiltOf(const RegistrationResult& registered, const PinholeCamera& camera,
                                   const PlanarPose& camera_motion) {
  if (registered.homography.inliers.size() < 4) return std::nullopt;
  const OdometryPlaneOptions plausible;  // the plane estimation's limits (baseline, distance)
  const auto estimated = planeAndTiltFromHomographyAndMotion(registered.homography.H, camera, camera_motion,
                                                             plausible.min_baseline, kMaxPairTilt);
  // A pair that shows no wall in front (a floor, the plane behind or too far) says nothing of the tilt.
  if (!estimated || !isPlausibleWall(estimated->plane, plausible)) return std::nullopt;
  return PairTilt{estimated->pitch, estimated->roll};
}

PairMeasurement measureViewPair(const ImageFeatures& first, const ImageFeatures& second, const Pose2D& first_pose,
                                const Pose2D& second_pose, const PinholeCamera& camera, const CameraMount& mount,
                                const MatchOptions& matching, const RobustHomographyOptions& robust) {
  PairMeasurement measured;
  const auto registered = registerFeatures(first, second, matching, robust, &camera);
  if (!registered) return measured;
  measured.match_residual = matchResidualOf(*registered);
  measured.tilt_to_next =
      pairTiltOf(*registered, camera, mount.baseToCamera(first_pose.inverse().compose(second_pose)));
  return measured;
}

Status measureRouteNoise(Route& route, const MatchOptions& matching, const RobustHomographyOptions& robust) {
  const PinholeCamera camera(route.info.camera);
  const CameraMount mount(route.info.camera_mount.x, route.info.camera_mount.y, route.info.camera_mount.yaw);
  for (RouteKeyframe& keyframe : route.keyframes) {
    keyframe.match_residual.reset();
    keyframe.tilt_to_next.reset();
  }
  ImageFeatures current;
  for (std::size_t k = 0; k < route.keyframes.size(); ++k) {
    auto loaded = loadKeyframeFeatures(route, k);
    if (!loaded) return loaded.status();
    if (k > 0) {
      RouteKeyframe& previous = route.keyframes[k - 1];
      const PairMeasurement pair =
          measureViewPair(current, *loaded, previous.pose, route.keyframes[k].pose, camera, mount, matching, robust);
      previous.match_residual = pair.match_residual;
      previous.tilt_to_next = pair.tilt_to_next;
    }
    current = std::move(*loaded);
  }
  route.info.match_noise_measured = true;
  route.info.tilt_measured = true;
  return Status::ok();
}

Status measurePlaneUncertainty(Route& route, const RepeatOptions& options) {
  Route unmeasured = route;  // the store reads stored values: this measures afresh
  for (RouteKeyframe& keyframe : unmeasured.keyframes) keyframe.plane_uncertainty.reset();
  RepeatOptions measuring = withMeasuredNoise(options, route);
  measuring.mode = RepeatMode::kFastHd;
  measuring.require_planes = false;
  measuring.use_experiences = false;
  measuring.plane_sigma_from_neighbours = true;
  const auto store = KeyframeStore::load(unmeasured, measuring);
  if (!store) return store.status();
  for (int k = 0; k < store->size(); ++k) route.keyframes[static_cast<std::size_t>(k)].plane_uncertainty = store->planeUncertainty(k);
  route.info.plane_uncertainty_method = kPlaneUncertaintyMethod;
  return Status::ok();
}

Status migrateRoute(const std::string& directory) {
  auto route = loadRoute(directory);
  if (!route) return route.status();
  if (!route->info.match_noise_measured || !route->info.tilt_measured) {
    Status measured = measureRouteNoise(*route);
    if (!measured.isOk()) return measured;
  }
  if (planeUncertaintyMissing(*route)) {
    Status measured = measurePlaneUncertainty(*route);
    if (!measured.isOk()) return measured;
  }
  return writeRouteIndex(*route);
}

}  // namespace homography_teach_repeat
