#include "homography_teach_repeat/teach_repeat/route_audit.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

#include "homography_teach_repeat/common/median.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/teach_repeat/keyframe_estimators.h"
#include "homography_teach_repeat/teach_repeat/keyframe_store.h"

namespace homography_teach_repeat {
namespace {

constexpr double kDegreesPerRadian = 180.0 / M_PI;

std::string format(const char* pattern, double a, double b = 0.0, double c = 0.0, double d = 0.0) {
  char text[240];
  std::snprintf(text, sizeof(text), pattern, a, b, c, d);
  return text;
}

// The covariance of a Fast-HD fix from the keyframe's plane features seen by a camera
// `offset` to the right (exact matches: the covariance is the model's, not a sample's), with the
// repeat's pixel σ times the keyframe's own scale (KeyframeReference::pixel_noise_scale, the
// repeat's: keyframePixelNoiseScale).
// In base_link of the robot (x forward, y left, yaw); covariance = model + the keyframe image's
// pixel noise (reference_noise) + the current image's (current_noise), all with every feature in
// view matched. The pixel σ is also scaled by how much the probe's view stretches the features
// (stretch_noise_scale, RouteAuditOptions::stretch_noise_gain), and the stretch makes them
// rarer to match (match_chance_scale, RouteAuditOptions::match_stretch_decay).
struct PredictedFix {
  Eigen::Matrix3d covariance;
  Eigen::Matrix3d model;
  Eigen::Matrix3d reference_noise;
  Eigen::Matrix3d current_noise;
  int matches = 0;
  double stretch_noise_scale = 1.0;
  double match_chance_scale = 1.0;
};

// The keyframe's plane features another camera sees, as exact matches through H, the plane's
// homography from the keyframe to it (undistorted keyframe pixel, pixel in that camera).
PointMatches planeFeaturesInView(const KeyframeReference& reference, const PinholeCamera& camera,
                                 const Eigen::Matrix3d& H) {
  PointMatches matches;
  for (const cv::KeyPoint& keypoint : reference.features.keypoints) {
    const cv::Point2d undistorted = camera.undistortPixel(cv::Point2d(keypoint.pt.x, keypoint.pt.y));
    const Eigen::Vector3d moved = H * Eigen::Vector3d(undistorted.x, undistorted.y, 1.0);
    if (!(moved.z() > 0.0)) continue;
    const Eigen::Vector2d current = moved.hnormalized();
    if (!camera.isInside(cv::Point2d(current.x(), current.y()))) continue;
    matches.push_back(PointMatch{Eigen::Vector2d(undistorted.x, undistorted.y), current});
  }
  return matches;
}

Expected<PredictedFix> predictFix(const KeyframeReference& reference, const PinholeCamera& camera,
                                  const CameraMount& mount, const RouteAuditOptions& options) {
  const PlanarPose probe(options.probe_offset_m, 0.0, 0.0);
  const Eigen::Matrix3d H = planeInducedHomography(camera, probe, *reference.plane);
  const PointMatches matches = planeFeaturesInView(reference, camera, H);
  std::vector<Eigen::Vector2d> seen;  // the keyframe pixels of `matches`
  for (const PointMatch& match : matches) seen.push_back(match.reference);
  const double stretch = matchStretchNoiseScale(H, seen, options.stretch_noise_gain);
  // The plane's disagreement with its neighbours (or their fixes' error) enters the prediction
  // only where it enters the repeat's covariance (plane_sigma_from_neighbours; docs/math.md §3.6,
  // §3.10, docs/route_audit.md).
  KeyframeReference as_repeated;
  as_repeated.pixel_noise_scale = reference.pixel_noise_scale;
  if (options.repeat.plane_sigma_from_neighbours) {
    as_repeated.plane_normal_sigma_rad = reference.plane_normal_sigma_rad;
    as_repeated.plane_distance_sigma = reference.plane_distance_sigma;
    as_repeated.neighbour_fix_error_per_m2 = reference.neighbour_fix_error_per_m2;
    as_repeated.neighbour_fix_heading_floor_rad = reference.neighbour_fix_heading_floor_rad;
  }
  PlanarPoseEstimatorOptions pose_options = fixPoseOptions(as_repeated, options.repeat.pose);
  pose_options.pixel_sigma_px *= stretch;
  auto estimate = estimatePlanarPoseFromInliers(matches, camera, *reference.plane, pose_options);
  if (!estimate) return estimate.status();
  const Eigen::Matrix3d measured = neighbourFixCovariance(as_repeated, estimate->pose);
  estimate->covariance += measured;
  estimate->model_covariance += measured;
  const Eigen::Matrix3d J = mount.cameraToBaseJacobian(estimate->pose);
  const auto toBase = [&J](const Eigen::Matrix3d& camera_covariance) {
    const Eigen::Matrix3d base = J * camera_covariance * J.transpose();
    return Eigen::Matrix3d(0.5 * (base + base.transpose()));
  };
  return PredictedFix{toBase(estimate->covariance), toBase(estimate->model_covariance),
                      toBase(estimate->reference_noise_covariance),
                      toBase(estimate->covariance - estimate->model_covariance - estimate->reference_noise_covariance),
                      static_cast<int>(matches.size()), stretch,
                      matchChanceScale(H, seen, options.match_stretch_decay)};
}

// Keyframe `current` localized against keyframe `reference` as the repeat would: the robust
// homography's inliers and, where the reference has a plane, the base pose it gives.
struct Relocalization {
  int inliers = 0;
  std::optional<Pose2D> relative;  // current's base in reference's base frame
};

Relocalization relocalize(const KeyframeReference& reference, const ImageFeatures& current, const PinholeCamera& camera,
                          const CameraMount& mount, const RepeatOptions& repeat) {
  Relocalization result;
  if (reference.plane) {
    // What matches, as the audit has always counted it (the repeat's checks left to the repeat).
    const auto pose = localizeAgainstPlane(reference, current, camera, repeat, /*check_on_plane=*/false);
    if (pose) {
      result.inliers = static_cast<int>(pose->inliers.size());
      result.relative = mount.cameraToBase(pose->pose);
    }
    return result;
  }
  const auto matches = matchFeatures(reference.features, current, repeat.matching);
  if (!matches || matches->size() < 4) return result;
  const PointMatches points = undistortMatches(camera, toPointMatches(reference.features, current, *matches));
  const auto homography = estimateHomographyRobust(points, repeat.pose.robust);
  if (homography) result.inliers = static_cast<int>(homography->inliers.size());
  return result;
}

}  // namespace

void RouteAuditOptions::validate() const {
  repeat.validate();
  if (!(probe_offset_m > 0.0) || !std::isfinite(probe_offset_m)) {
    throw std::invalid_argument("route audit: probe_offset_m must be finite and > 0");
  }
  if (!(stretch_noise_gain >= 0.0 && stretch_noise_gain <= 10.0)) {
    throw std::invalid_argument("route audit: stretch_noise_gain must be in [0, 10]");
  }
  if (!(match_stretch_decay >= 0.0 && match_stretch_decay <= 10.0)) {
    throw std::invalid_argument("route audit: match_stretch_decay must be in [0, 10]");
  }
  if (same_place_keyframes < 1) throw std::invalid_argument("route audit: same_place_keyframes must be >= 1");
  if (min_plane_features < 0 || min_lines < 0) {
    throw std::invalid_argument("route audit: min_plane_features and min_lines must be >= 0");
  }
  for (const double value : {max_position_sigma_m, max_heading_sigma_rad, max_alias_ratio, alias_position_tolerance_m,
                             alias_heading_tolerance_rad}) {
    if (!(value > 0.0) || !std::isfinite(value)) {
      throw std::invalid_argument(
          "route audit: max_position_sigma_m, max_heading_sigma_rad, max_alias_ratio and the alias tolerances must be "
          "finite and > 0");
    }
  }
}

Expected<RouteAudit> auditRoute(const Route& route, const RouteAuditOptions& configured) {
  RouteAuditOptions options = configured;
  options.repeat = withMeasuredNoise(configured.repeat, route);  // the σ the repeat will use
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  if (route.keyframes.empty()) return Status(StatusCode::kInvalidInput, "route '" + route.directory + "' has no keyframe");
  const PinholeCamera camera(route.info.camera);
  const Pose2D& m = route.info.camera_mount;
  const CameraMount mount(m.x, m.y, m.yaw);
  const int n = static_cast<int>(route.keyframes.size());

  // What the μ mode has: the lines and their landmarks.
  RepeatOptions lines_options = options.repeat;
  lines_options.mode = RepeatMode::kMu;
  lines_options.mu_line_landmarks = true;
  auto lines = KeyframeStore::load(route, lines_options);
  if (!lines) return lines.status();
  // What fast_hd has: the features on each plane with the plane's own uncertainty; with a keyframe
  // without a plane the store refuses the route, so each keyframe's stored features instead.
  RepeatOptions points_options = options.repeat;
  points_options.mode = RepeatMode::kFastHd;
  points_options.plane_sigma_from_neighbours = true;
  RouteAudit audit;
  bool every_plane = true;
  for (const RouteKeyframe& keyframe : route.keyframes) every_plane = every_plane && keyframe.plane.has_value();
  // Every keyframe's stored features: what its image offers as a current image.
  std::vector<ImageFeatures> stored;
  for (int k = 0; k < n; ++k) {
    auto features = loadKeyframeFeatures(route, static_cast<std::size_t>(k));
    if (!features) return features.status();
    stored.push_back(std::move(*features));
  }
  std::vector<KeyframeReference> references;
  if (every_plane) {
    auto store = KeyframeStore::load(route, points_options);
    if (!store) return store.status();
    for (int k = 0; k < n; ++k) references.push_back(store->at(k));
  } else {
    audit.notes.push_back("not every keyframe has a plane: features are not restricted to the planes and "
                          "the planes' own uncertainty is not measured");
    const std::optional<double> route_residual = routeMatchResidual(route);  // once: a median over the route
    for (int k = 0; k < n; ++k) {
      KeyframeReference reference;
      reference.features = stored[static_cast<std::size_t>(k)];
      reference.plane = route.keyframes[static_cast<std::size_t>(k)].plane;
      reference.base_pose = route.keyframes[static_cast<std::size_t>(k)].pose;
      if (options.repeat.pixel_noise_per_keyframe) {
        reference.pixel_noise_scale = keyframePixelNoiseScale(route, static_cast<std::size_t>(k), route_residual);
      }
      references.push_back(std::move(reference));
    }
  }

  // How much of each keyframe the repeat matches from a nearby view: the better of its two
  // neighbours' inliers against it (where the teach run turned in place one neighbour faces
  // another wall; also without the aliasing search).
  std::vector<int> neighbour_inliers(static_cast<std::size_t>(n), -1);
  // The part of its plane features in a neighbour's view that the neighbour matched: the better
  // neighbour's (one that sees at least min_inliers of them). Where the teach run turned in place
  // the neighbour sees only a corner of this keyframe's wall, and its inliers over all the plane
  // features would say the wall matches badly where only few features were in view.
  // It matched them at its own view's stretch (match_stretch_decay): the keyframe's own part is
  // the fraction over the neighbour's chance scale, and the better neighbour is the one whose
  // own part is larger. Only a neighbour whose camera stood elsewhere (kSameViewpointM) counts:
  // one turned in place sees the same picture re-projected and matches more of it than any view
  // from elsewhere (docs/route_audit.md: in the room 92-95 % against 65-84 %).
  struct NeighbourPart {
    double fraction = -1.0;  // inliers / in_view; -1: no neighbour sees min_inliers of them
    int in_view = -1;
    double match_chance_scale = 1.0;  // matchChanceScale of the neighbour's view
    double unstretched() const { return fraction / match_chance_scale; }
  };
  std::vector<NeighbourPart> neighbour_part(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const auto i = static_cast<std::size_t>(k);
    for (const int neighbour : {k - 1, k + 1}) {
      if (neighbour < 0 || neighbour >= n) continue;
      // The neighbour's image as the repeat sees a current image: all its features against this
      // keyframe's plane features (the neighbour's own plane features would count only what both
      // keyframes kept on their planes).
      const Relocalization found =
          relocalize(references[i], stored[static_cast<std::size_t>(neighbour)], camera, mount, options.repeat);
      neighbour_inliers[i] = std::max(neighbour_inliers[i], found.inliers);
      const Pose2D relative = route.keyframes[i].pose.inverse().compose(route.keyframes[static_cast<std::size_t>(neighbour)].pose);
      const PlanarPose camera_relative = mount.baseToCamera(relative);
      // Its part counts only if it stood elsewhere: the same picture re-projected matches more
      // than a view from elsewhere. A keyframe without one keeps the route's part (below).
      if (std::hypot(camera_relative.x, camera_relative.z) < kSameViewpointM) continue;
      if (references[i].plane) {
        const Eigen::Matrix3d H = planeInducedHomography(camera, camera_relative, *references[i].plane);
        std::vector<Eigen::Vector2d> seen;  // this keyframe's pixels of its plane features in the neighbour's view
        for (const PointMatch& match : planeFeaturesInView(references[i], camera, H)) seen.push_back(match.reference);
        const int in_view = static_cast<int>(seen.size());
        const NeighbourPart part{static_cast<double>(found.inliers) / std::max(in_view, 1), in_view,
                                 matchChanceScale(H, seen, options.match_stretch_decay)};
        if (in_view >= options.repeat.min_inliers &&
            (neighbour_part[i].fraction < 0.0 || part.unstretched() > neighbour_part[i].unstretched())) {
          neighbour_part[i] = part;
        }
      }
    }
  }

  // Where no neighbour stood elsewhere (every keyframe around it turned in place), the route's
  // own part: the median over the keyframes that have one, unstretched.
  std::vector<double> route_parts;
  for (const NeighbourPart& part : neighbour_part) {
    if (part.fraction >= 0.0) route_parts.push_back(part.unstretched());
  }
  const std::optional<double> route_part = upperMedian(std::move(route_parts));

  for (int k = 0; k < n; ++k) {
    const KeyframeReference& reference = references[static_cast<std::size_t>(k)];
    KeyframeAudit a;
    a.keyframe = k;
    a.pose = route.keyframes[static_cast<std::size_t>(k)].pose;
    a.features = static_cast<int>(stored[static_cast<std::size_t>(k)].keypoints.size());
    a.has_plane = reference.plane.has_value();
    a.plane_features = a.has_plane ? static_cast<int>(reference.features.keypoints.size()) : 0;
    a.lines = static_cast<int>(lines->at(k).lines.size());
    a.line_landmarks = static_cast<int>(lines->at(k).line_landmarks.size());
    a.neighbour_inliers = neighbour_inliers[static_cast<std::size_t>(k)];
    a.pixel_noise_scale = reference.pixel_noise_scale;
    if (a.has_plane) {
      a.plane_distance_m = reference.plane->distance;
      a.plane_normal_sigma_rad = reference.plane_normal_sigma_rad;
      a.plane_distance_sigma = reference.plane_distance_sigma;
      if (reference.neighbour_fix_error_per_m2) {
        a.neighbour_fix_error_per_m = Eigen::Vector3d(reference.neighbour_fix_error_per_m2->diagonal().cwiseSqrt());
        a.neighbour_fix_heading_floor_rad = reference.neighbour_fix_heading_floor_rad;
      }
      const auto predicted = predictFix(reference, camera, mount, options);
      if (!predicted) {
        a.prediction_problem = predicted.status().toString();
      } else {
        a.predicted_matches = predicted->matches;
        a.stretch_noise_scale = predicted->stretch_noise_scale;
        // The fix sees predicted_matches plane features but matches only part of them (the
        // descriptors of a view from elsewhere): as large a part as the neighbour matched, less
        // for how much more the probe's view stretches them than the neighbour's did. The
        // covariance of n matches goes as 1/n (docs/route_audit.md: the simulator's room, fixes
        // 0.3 m off the path kept 17-78 % of the features in view).
        const NeighbourPart& part = neighbour_part[static_cast<std::size_t>(k)];
        a.neighbour_plane_features_in_view = part.in_view;
        a.neighbour_match_fraction = part.fraction;
        if (part.fraction >= 0.0) {
          a.match_stretch_scale = predicted->match_chance_scale / part.match_chance_scale;
          a.expected_match_fraction = std::min(1.0, part.fraction * a.match_stretch_scale);
        } else if (route_part) {
          a.match_stretch_scale = predicted->match_chance_scale;
          a.expected_match_fraction = std::min(1.0, *route_part * a.match_stretch_scale);
        } else {
          a.expected_match_fraction = a.neighbour_inliers >= 0 && a.plane_features > 0
                                          ? std::min(1.0, static_cast<double>(a.neighbour_inliers) / a.plane_features)
                                          : 1.0;
        }
        const double expected_matches = a.expected_match_fraction * a.predicted_matches;
        if (expected_matches < options.repeat.min_inliers) {
          a.prediction_problem = format("about %.0f of the %.0f plane features in view would match (min_inliers %.0f)",
                                        expected_matches, a.predicted_matches, options.repeat.min_inliers);
        } else {
          // Only the pixel noise's part averages over the matches; the plane's error and the
          // heading floor (the model part) do not depend on how many match.
          const Eigen::Matrix3d pixel_noise = predicted->covariance - predicted->model;
          a.predicted_covariance = Eigen::Matrix3d(predicted->model + pixel_noise / a.expected_match_fraction);
          // From fix to fix: the current image's noise, and the keyframe image's over the part
          // of its keypoints not matched in common. Each fix matches a part p of the plane
          // features, not the same part each time; two fixes whose matched parts are drawn
          // independently share p of each other's keypoints, so of the keyframe noise's
          // covariance over the pN matched, p is common to all fixes and 1 − p differs
          // (docs/math.md §3.4).
          const double p = a.expected_match_fraction;
          a.predicted_fix_to_fix_covariance =
              Eigen::Matrix3d((predicted->current_noise + (1.0 - p) * predicted->reference_noise) / p);
        }
      }
    } else {
      a.prediction_problem = "no plane";
    }
    if (!a.has_plane) {
      a.fast_hd_weaknesses.push_back("no plane: fast_hd cannot localize here (the odometry, or mu, must carry the robot)");
    } else {
      if (a.plane_features < options.min_plane_features) {
        a.fast_hd_weaknesses.push_back(format("%.0f features on its plane (min_plane_features %.0f)", a.plane_features,
                                              options.min_plane_features));
      }
      if (!a.predicted_covariance) {
        a.fast_hd_weaknesses.push_back("no fix predicted " + format("%.2f m", options.probe_offset_m) +
                                       " to the side: " + a.prediction_problem);
      } else {
        const Eigen::Matrix3d& c = *a.predicted_covariance;
        const double position = std::sqrt(std::max(c(0, 0), c(1, 1)));
        const double heading = std::sqrt(c(2, 2));
        if (position > options.max_position_sigma_m || heading > options.max_heading_sigma_rad) {
          a.fast_hd_weaknesses.push_back(
              format("a fix %.2f m to the side would be known to %.3f m / %.2f deg (max %.3f m", options.probe_offset_m,
                     position, heading * kDegreesPerRadian, options.max_position_sigma_m) +
              format(" / %.2f deg)", options.max_heading_sigma_rad * kDegreesPerRadian));
        }
      }
    }
    if (a.lines < options.min_lines) {
      a.mu_weaknesses.push_back(format("%.0f vertical lines (min_lines %.0f): mu has too few to match here", a.lines,
                                       options.min_lines));
    }
    audit.keyframes.push_back(std::move(a));
  }

  if (options.aliasing && n >= 2) {
    // Another keyframe is an alias of this one when it matches and the pose it gives for this one
    // is not where the teach run put it: the repeat could take that pose. One that matches and
    // agrees (the same facades seen from further along a street) is the same place seen again.
    for (int k = 0; k < n; ++k) {
      KeyframeAudit& a = audit.keyframes[static_cast<std::size_t>(k)];
      const ImageFeatures& mine = references[static_cast<std::size_t>(k)].features;
      for (int j = 0; j < n; ++j) {
        if (std::abs(j - k) <= options.same_place_keyframes) continue;
        const Relocalization other = relocalize(references[static_cast<std::size_t>(j)], mine, camera, mount, options.repeat);
        if (other.inliers < options.repeat.min_inliers || other.inliers <= a.alias_inliers) continue;
        if (other.relative) {
          const Pose2D taught = route.keyframes[static_cast<std::size_t>(j)].pose.inverse().compose(
              route.keyframes[static_cast<std::size_t>(k)].pose);
          const Pose2D& found = *other.relative;
          if (std::hypot(found.x - taught.x, found.y - taught.y) <= options.alias_position_tolerance_m &&
              std::abs(wrapToPi(found.yaw - taught.yaw)) <= options.alias_heading_tolerance_rad) {
            continue;
          }
        }
        a.alias_inliers = other.inliers;
        a.alias_keyframe = j;
      }
      if (a.alias_keyframe >= 0 && a.alias_inliers >= options.max_alias_ratio * std::max(a.neighbour_inliers, 1)) {
        a.fast_hd_weaknesses.push_back(format("looks like keyframe %.0f (%.0f inliers against %.0f with its neighbour, "
                                              "a pose that is not the taught one)",
                                              a.alias_keyframe, a.alias_inliers, a.neighbour_inliers));
      }
    }
  }
  for (const KeyframeAudit& a : audit.keyframes) {
    if (!a.fast_hd_weaknesses.empty()) ++audit.weak_for_fast_hd;
    if (!a.mu_weaknesses.empty()) ++audit.weak_for_mu;
  }
  if (!every_plane) {
    bool any_plane = false;
    for (const KeyframeAudit& a : audit.keyframes) any_plane = any_plane || a.has_plane;
    if (!any_plane) audit.notes.push_back("no keyframe has a plane: fast_hd cannot repeat this route, use mu");
  }
  return audit;
}

std::vector<std::string> storedKeyframeWeaknesses(int features, int lines, const RouteAuditOptions& options) {
  std::vector<std::string> weaknesses;
  if (features < options.min_plane_features) {
    weaknesses.push_back(format("fast_hd: %.0f features (min_plane_features %.0f)", features, options.min_plane_features));
  }
  if (lines < options.min_lines) {
    weaknesses.push_back(format("mu: %.0f vertical lines (min_lines %.0f)", lines, options.min_lines));
  }
  return weaknesses;
}

std::string weakKeyframeSummary(const RouteAudit& audit) {
  std::string fast_hd, mu;
  for (const KeyframeAudit& a : audit.keyframes) {
    if (!a.fast_hd_weaknesses.empty()) fast_hd += (fast_hd.empty() ? "" : ", ") + std::to_string(a.keyframe);
    if (!a.mu_weaknesses.empty()) mu += (mu.empty() ? "" : ", ") + std::to_string(a.keyframe);
  }
  std::string summary;
  if (!fast_hd.empty()) summary += "weak for fast_hd: keyframes " + fast_hd;
  if (!mu.empty()) summary += std::string(summary.empty() ? "" : "; ") + "weak for mu: keyframes " + mu;
  return summary;
}

}  // namespace homography_teach_repeat
