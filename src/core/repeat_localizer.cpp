#include "homography_teach_repeat/repeat_localizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <stdexcept>
#include <string>

#include <opencv2/video/tracking.hpp>

#include "homography_teach_repeat/fast_hd.h"
#include "homography_teach_repeat/heading_aided_odometry.h"
#include "homography_teach_repeat/homography.h"
#include "homography_teach_repeat/homography_decomposition.h"
#include "homography_teach_repeat/plane_estimation.h"

namespace homography_teach_repeat {
namespace {

// The teach run turned between two keyframes: their yaws differ by more than
// kTurnKeyframeAngle [rad] + kTurnKeyframeRate [rad/m] · their distance (driving a straight
// segment, the teach run's heading varies by a few degrees over the keyframe spacing).
constexpr double kTurnKeyframeAngle = 0.1;
constexpr double kTurnKeyframeRate = 1.0;

bool turnedBetween(const Pose2D& a, const Pose2D& b) {
  return std::abs(wrapToPi(b.yaw - a.yaw)) > kTurnKeyframeAngle + kTurnKeyframeRate * std::hypot(b.x - a.x, b.y - a.y);
}

// The reference keyframe's yaw rotates the relative covariance into the route frame.
Eigen::Matrix3d rotateCovariance(const Eigen::Matrix3d& covariance, double yaw) {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  R.topLeftCorner<2, 2>() << std::cos(yaw), -std::sin(yaw), std::sin(yaw), std::cos(yaw);
  const Eigen::Matrix3d rotated = R * covariance * R.transpose();
  return 0.5 * (rotated + rotated.transpose());  // exactly symmetric for the message
}

}  // namespace

RepeatMode repeatModeFromString(const std::string& name) {
  if (name == "fast_hd") return RepeatMode::kFastHd;
  if (name == "mu") return RepeatMode::kMu;
  if (name == "classic") return RepeatMode::kClassic;
  throw std::invalid_argument("unknown mode '" + name + "' (fast_hd, mu, classic)");
}

std::string toString(RepeatMode mode) {
  switch (mode) {
    case RepeatMode::kFastHd: return "fast_hd";
    case RepeatMode::kMu: return "mu";
    case RepeatMode::kClassic: return "classic";
  }
  return "unknown";
}

void RepeatOptions::validate() const {
  if (max_features < 1) throw std::invalid_argument("max_features must be >= 1");
  matching.validate();
  pose.validate();
  heading.validate();
  lines.validate();
  if (min_inliers < 4) throw std::invalid_argument("min_inliers must be >= 4");
  if (neighbour_search < 0) throw std::invalid_argument("neighbour_search must be >= 0");
  if (max_degraded_frames < 0) throw std::invalid_argument("max_degraded_frames must be >= 0");
  if (max_tracked_frames < 0) throw std::invalid_argument("max_tracked_frames must be >= 0");
  if (!(tracking_tolerance_px > 0.0 && std::isfinite(tracking_tolerance_px))) {
    throw std::invalid_argument("tracking_tolerance_px must be > 0");
  }
  if (!std::isfinite(max_plane_residual_px) || !(max_plane_residual_px > 0.0)) {
    throw std::invalid_argument("max_plane_residual_px must be > 0");
  }
  if (!(max_normal_angle > 0.0 && max_normal_angle <= M_PI) || !std::isfinite(min_normal_check_parallax) ||
      min_normal_check_parallax < 0.0) {
    throw std::invalid_argument("max_normal_angle must be in (0, pi], min_normal_check_parallax >= 0");
  }
  if (!std::isfinite(plane_feature_tolerance_px) || plane_feature_tolerance_px < 0.0) {
    throw std::invalid_argument("plane_feature_tolerance_px must be finite and >= 0");
  }
  if (!std::isfinite(closed_route_gap) || closed_route_gap < 0.0) {
    throw std::invalid_argument("closed_route_gap must be finite and >= 0");
  }
  if (!(mu_max_reference_angle > 0.0 && mu_max_reference_angle <= M_PI)) {
    throw std::invalid_argument("mu_max_reference_angle must be in (0, pi]");
  }
}

bool isClosedRoute(const Route& route, double max_gap) {
  std::vector<Pose2D> poses;
  for (const auto& k : route.keyframes) poses.push_back(k.pose);
  return isClosedLoop(poses, max_gap);
}

RepeatLocalizer::RepeatLocalizer(const Route& route, const RepeatOptions& options)
    : route_(route),
      options_(options),
      camera_(route.info.camera),
      mount_(route.info.camera_mount.x, route.info.camera_mount.y, route.info.camera_mount.yaw),
      extractor_(FeatureOptions{route.info.feature_type, options.max_features}),
      line_extractor_(options.lines),
      closed_(isClosedRoute(route, options.closed_route_gap)) {}

Expected<RepeatLocalizer> RepeatLocalizer::create(const Route& route, const RepeatOptions& options) {
  try {
    options.validate();
    if (route.keyframes.empty()) {
      return Status(StatusCode::kInvalidInput, "route '" + route.directory + "' has no keyframe");
    }
    RepeatLocalizer localizer(route, options);
    for (std::size_t k = 0; k < route.keyframes.size(); ++k) {
      Reference reference;
      reference.base_pose = route.keyframes[k].pose;
      reference.plane = route.keyframes[k].plane;
      if (options.mode == RepeatMode::kMu) {
        auto lines = loadKeyframeLines(route, k);
        if (!lines) return lines.status();
        reference.lines = std::move(*lines);
      } else {
        if (!reference.plane) {
          return Status(StatusCode::kInvalidInput,
                        "keyframe " + std::to_string(k) + " of '" + route.directory +
                            "' has no plane: " + toString(options.mode) +
                            " mode needs the plane estimation of the teach phase (or use mu)");
        }
        auto features = loadKeyframeFeatures(route, k);
        if (!features) return features.status();
        reference.features = std::move(*features);
      }
      if (k > 0) {
        // A corner keyframe: reached turning, or where the teach run started turning (its
        // heading is the straight segment's, but the walls of the corner are as near).
        reference.turn = turnedBetween(route.keyframes[k - 1].pose, route.keyframes[k].pose) ||
                         (k + 1 < route.keyframes.size() &&
                          turnedBetween(route.keyframes[k].pose, route.keyframes[k + 1].pose));
      }
      localizer.keyframes_.push_back(std::move(reference));
    }
    if (options.mode != RepeatMode::kMu && options.plane_feature_tolerance_px > 0.0) {
      localizer.restrictToPlaneFeatures();
    }
    return localizer;
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
}

void RepeatLocalizer::restrictToPlaneFeatures() {
  // Every vertical plane's homography under planar motion has the same form, and a side wall
  // close to the camera can out-vote the keyframe's wall in the robust fit: Fast-HD with the
  // keyframe's plane then gives a wrong pose that no residual reveals. So each keyframe keeps only
  // the features on its plane: those that move as that plane predicts to a neighbouring keyframe
  // (plane-induced homography of the taught relative pose).
  const int n = keyframeCount();
  if (n < 2) return;
  for (int k = 0; k < n; ++k) {
    Reference& reference = keyframes_[static_cast<std::size_t>(k)];
    const int j = k + 1 < n ? k + 1 : k - 1;
    const Reference& neighbour = keyframes_[static_cast<std::size_t>(j)];
    const PlanarPose relative = mount_.baseToCamera(reference.base_pose.inverse().compose(neighbour.base_pose));
    const Eigen::Matrix3d H = planeInducedHomography(camera_, relative, *reference.plane);
    const auto dmatches = matchFeatures(reference.features, neighbour.features, options_.matching);
    if (!dmatches) continue;
    std::vector<int> on_plane;
    for (const cv::DMatch& m : *dmatches) {
      const cv::Point2f& a = reference.features.keypoints[static_cast<std::size_t>(m.queryIdx)].pt;
      const cv::Point2f& b = neighbour.features.keypoints[static_cast<std::size_t>(m.trainIdx)].pt;
      const cv::Point2d ua = camera_.undistortPixel(a), ub = camera_.undistortPixel(b);
      const PointMatch match{Eigen::Vector2d(ua.x, ua.y), Eigen::Vector2d(ub.x, ub.y)};
      if (transferError(H, match) < options_.plane_feature_tolerance_px) on_plane.push_back(m.queryIdx);
    }
    // Too few: a pure rotation to the neighbour maps every feature alike, or the neighbour shows
    // little of this plane; keep every feature then.
    if (static_cast<int>(on_plane.size()) < 2 * options_.min_inliers) continue;
    ImageFeatures subset;
    subset.type = reference.features.type;
    for (const int i : on_plane) {
      subset.keypoints.push_back(reference.features.keypoints[static_cast<std::size_t>(i)]);
      subset.descriptors.push_back(reference.features.descriptors.row(i));
    }
    reference.features = std::move(subset);
  }
}

void RepeatLocalizer::setTrackedKeyframe(int keyframe) {
  tracked_ = std::clamp(keyframe, 0, keyframeCount() - 1);
  track_.reset();
}

Status RepeatLocalizer::checkPlaneNormal(const Eigen::Matrix3d& H, const ScenePlane& plane,
                                         const PointMatches& matches, const std::vector<int>& inliers) const {
  const auto solutions = decomposeHomographyClassic(H, camera_);
  if (!solutions) return Status::ok();  // nothing to check against; the residual test stands
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(inliers.size());
  for (const int i : inliers) pixels.push_back(matches[static_cast<std::size_t>(i)].reference);
  const auto visible = filterByPositiveDepth(*solutions, camera_, pixels);
  if (visible.empty()) return Status::ok();
  double parallax = 0.0, best_cos = -1.0;
  for (const auto& d : visible) {
    parallax = std::max(parallax, d.translation_over_distance.norm());
    best_cos = std::max(best_cos, d.normal.dot(plane.normal));
  }
  if (parallax < options_.min_normal_check_parallax) return Status::ok();  // normal not observable
  const double angle = std::acos(std::clamp(best_cos, -1.0, 1.0));
  if (angle > options_.max_normal_angle) {
    return Status(StatusCode::kNoConsensus,
                  "the dominant plane in view is not the keyframe's (normal " +
                      std::to_string(angle * 180.0 / M_PI) + " deg away): another wall in view?");
  }
  return Status::ok();
}

Expected<RepeatEstimate> RepeatLocalizer::localizeAgainst(const Reference& reference, int keyframe,
                                                          const ImageFeatures& features,
                                                          const std::vector<VerticalLine>& lines,
                                                          const std::optional<Pose2D>& predicted_pose) const {
  RepeatEstimate estimate;
  estimate.mode = options_.mode;
  estimate.keyframe = keyframe;
  if (options_.mode == RepeatMode::kMu) {
    const HeadingCorrector corrector(options_.heading, LineCamera{camera_.fx(), camera_.cx()});
    const bool prior = predicted_pose && predicted_pose->isFinite();
    // Guided matching: the keyframe's wall at the predicted pose moves the lines by the offset
    // and depth change as well as the rotation; a reference without a wall (the temporary one of
    // this mode has no plane, nor has a keyframe on the floor) by the rotation only.
    std::optional<Eigen::Matrix2d> wall_guide;
    if (prior) {
      if (const auto wall = muWallOf(reference.base_pose, reference.plane, route_.info.camera_mount, camera_.fx(),
                                     keyframe)) {
        const auto H = wallHomography1dAt(*wall, *predicted_pose);
        if (H) wall_guide = *H;
      }
    }
    const double reference_yaw = route_.keyframes[static_cast<std::size_t>(keyframe)].pose.yaw + reference.heading_offset;
    const auto correction =
        wall_guide ? corrector.estimate(reference.lines, lines, *wall_guide)
                   : corrector.estimate(reference.lines, lines, prior ? wrapToPi(predicted_pose->yaw - reference_yaw) : 0.0);
    if (!correction) return correction.status();
    estimate.matches = correction->line_matches;
    estimate.inliers = correction->inliers;
    estimate.mu = correction->mu;
    estimate.heading_correction = wrapToPi(reference.heading_offset + correction->theta);
    return estimate;
  }
  const auto dmatches = matchFeatures(reference.features, features, options_.matching);
  if (!dmatches) return dmatches.status();
  return estimateFromMatches(reference, keyframe, toPointMatches(reference.features, features, *dmatches));
}

Expected<RepeatEstimate> RepeatLocalizer::estimateFromMatches(const Reference& reference, int keyframe,
                                                              const PointMatches& measured) const {
  RepeatEstimate estimate;
  estimate.mode = options_.mode;
  estimate.keyframe = keyframe;
  PointMatches matches = measured;
  if (camera_.hasDistortion()) {
    for (auto& m : matches) {
      const cv::Point2d a = camera_.undistortPixel({m.reference.x(), m.reference.y()});
      const cv::Point2d b = camera_.undistortPixel({m.current.x(), m.current.y()});
      m.reference = Eigen::Vector2d(a.x, a.y);
      m.current = Eigen::Vector2d(b.x, b.y);
    }
  }
  estimate.matches = static_cast<int>(matches.size());
  PlanarPose camera_relative;
  if (options_.mode == RepeatMode::kFastHd) {
    const auto pose = estimatePlanarPose(matches, camera_, *reference.plane, options_.pose);
    if (!pose) return pose.status();
    estimate.inliers = static_cast<int>(pose->inliers.size());
    for (const int i : pose->inliers) estimate.inlier_matches.push_back(measured[static_cast<std::size_t>(i)]);
    camera_relative = pose->pose;
    // The pose must explain the matches through the keyframe's plane. Any homography gives a
    // Fast-HD pose, so a view dominated by another wall (a corner) gives a wrong pose with a
    // small DLT residual; the plane-induced homography of that pose does not fit it.
    const Eigen::Matrix3d H_model = planeInducedHomography(camera_, camera_relative, *reference.plane);
    double sum = 0.0;
    for (const int i : pose->inliers) {
      const double e = transferError(H_model, matches[static_cast<std::size_t>(i)]);
      sum += e * e;
    }
    const double rms = std::sqrt(sum / static_cast<double>(std::max<std::size_t>(1, pose->inliers.size())));
    if (!(rms <= options_.max_plane_residual_px)) {
      return Status(StatusCode::kNoConsensus,
                    "the matches do not fit the keyframe's plane (RMS " + std::to_string(rms) +
                        " px > max_plane_residual " + std::to_string(options_.max_plane_residual_px) +
                        " px): another wall in view?");
    }
    // Every vertical plane's homography under planar motion has the same form, so the residual
    // above cannot tell the keyframe's wall from a side wall. The plane normal can: with enough
    // parallax the classic decomposition's normals (positive depth) must include one near the
    // keyframe plane's normal (MATH.md §1.8: the other solution is the spurious one).
    const Status same_wall = checkPlaneNormal(pose->H, *reference.plane, matches, pose->inliers);
    if (!same_wall.isOk()) return same_wall;
    const Eigen::Matrix3d J = mount_.cameraToBaseJacobian(camera_relative);
    estimate.covariance =
        rotateCovariance(J * pose->covariance * J.transpose(), reference.base_pose.yaw);
    estimate.covariance_known = true;
  } else {
    const auto robust = estimateHomographyRobust(matches, options_.pose.robust);
    if (!robust) return robust.status();
    estimate.inliers = static_cast<int>(robust->inliers.size());
    std::vector<Eigen::Vector2d> pixels;
    for (const int i : robust->inliers) {
      pixels.push_back(matches[i].reference);
      estimate.inlier_matches.push_back(measured[static_cast<std::size_t>(i)]);
    }
    const auto all = decomposeHomographyClassic(robust->H, camera_);
    if (!all) return all.status();
    const auto visible = filterByPositiveDepth(*all, camera_, pixels);
    if (visible.empty()) {
      return Status(StatusCode::kDegenerate, "classic decomposition: no solution in front");
    }
    const HomographyDecomposition* best = &visible.front();
    for (const auto& d : visible) {
      if (d.normal.dot(reference.plane->normal) > best->normal.dot(reference.plane->normal)) best = &d;
    }
    camera_relative = best->planarPose(reference.plane->distance);
    estimate.covariance = Eigen::Matrix3d::Identity() * 1e6;  // no covariance model
  }
  if (estimate.inliers < options_.min_inliers) {
    return Status(StatusCode::kNoConsensus,
                  std::to_string(estimate.inliers) + " inliers against keyframe " +
                      std::to_string(keyframe) + ", need " + std::to_string(options_.min_inliers));
  }
  estimate.has_pose = true;
  estimate.camera_relative = camera_relative;
  estimate.base_pose = reference.base_pose.compose(mount_.cameraToBase(camera_relative));
  estimate.heading_correction = wrapToPi(estimate.base_pose.yaw - route_.keyframes[keyframe].pose.yaw);
  return estimate;
}

void RepeatLocalizer::advanceTracking(const RepeatEstimate& estimate) {
  tracked_ = estimate.keyframe;
  if (estimate.has_pose) advanceTrackingTo(estimate.base_pose);
}

void RepeatLocalizer::advanceTrackingTo(const Pose2D& robot) {
  if (!std::isfinite(robot.x) || !std::isfinite(robot.y)) return;
  // Move on while the robot is closer to the next keyframe than to the tracked one (on a closed
  // route the keyframe after the last is the first; at most one lap per call). "Closer" weighs
  // the heading too (kHeadingWeight metres per radian): where the teach run turned in place the
  // keyframes share a position, and tracking must follow the turn (in the simulator, μ against a
  // corner keyframe 60-90° away from the robot's heading gave fixes 90° off).
  constexpr double kHeadingWeight = 0.5;
  auto distance = [&](const Pose2D& keyframe) {
    return std::hypot(keyframe.x - robot.x, keyframe.y - robot.y) +
           (std::isfinite(robot.yaw) ? kHeadingWeight * std::abs(wrapToPi(keyframe.yaw - robot.yaw)) : 0.0);
  };
  const int n = keyframeCount();
  for (int steps = 0; steps < n; ++steps) {
    if (!closed_ && tracked_ + 1 >= n) break;
    const int following = (tracked_ + 1) % n;
    const Pose2D& here = keyframes_[static_cast<std::size_t>(tracked_)].base_pose;
    const Pose2D& next = keyframes_[static_cast<std::size_t>(following)].base_pose;
    if (distance(next) >= distance(here)) break;
    tracked_ = following;
  }
}

bool RepeatLocalizer::isTurnKeyframe(int keyframe) const {
  return keyframe >= 0 && keyframe < keyframeCount() && keyframes_[static_cast<std::size_t>(keyframe)].turn;
}

bool RepeatLocalizer::usableForMu(const Reference& reference, int keyframe,
                                  const std::optional<Pose2D>& predicted_pose) const {
  if (options_.mu_skip_turn_keyframes && reference.turn) return false;
  if (!predicted_pose || !std::isfinite(predicted_pose->yaw)) return true;
  const double reference_yaw =
      route_.keyframes[static_cast<std::size_t>(keyframe)].pose.yaw + reference.heading_offset;
  return std::abs(wrapToPi(reference_yaw - predicted_pose->yaw)) <= options_.mu_max_reference_angle;
}

namespace {

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

Expected<RepeatEstimate> RepeatLocalizer::localize(const cv::Mat& image, std::optional<Pose2D> predicted_pose) {
  timing_ = LocalizeTiming();
  const auto extraction_start = std::chrono::steady_clock::now();
  if (image.empty()) return Status(StatusCode::kInvalidInput, "image is empty");
  if (image.cols != camera_.width() || image.rows != camera_.height()) {
    return Status(StatusCode::kInvalidInput,
                  "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                      ", the route's camera is " + std::to_string(camera_.width()) + "x" +
                      std::to_string(camera_.height()));
  }
  ImageFeatures features;
  std::vector<VerticalLine> lines;
  cv::Mat gray;  // fast_hd/classic: the grey image, kept for tracking
  if (options_.mode == RepeatMode::kMu) {
    auto extracted = line_extractor_.extract(image, &camera_);
    if (!extracted) return extracted.status();
    lines = std::move(*extracted);
  } else {
    auto converted = toGray8(image);
    if (!converted) return converted.status();
    gray = std::move(*converted);
    if (track_ && track_->keyframe == tracked_ && track_->frames_tracked < options_.max_tracked_frames) {
      auto estimate = localizeByTracking(gray);
      if (estimate) {
        timing_.tracked = true;
        degraded_frames_ = 0;
        rememberForTracking(*estimate, gray, track_->frames_tracked + 1);
        advanceTracking(*estimate);
        return estimate;
      }
      // Detect afresh (the time spent on tracking counts as extraction).
    }
    track_.reset();
    auto extracted = extractor_.extract(gray);
    if (!extracted) return extracted.status();
    features = std::move(*extracted);
  }
  timing_.extraction_ms = millisecondsSince(extraction_start);
  const auto references_start = std::chrono::steady_clock::now();
  // Against one reference, counted and timed.
  auto localizeAgainstTimed = [&](const Reference& reference, int keyframe) {
    ++timing_.references_tried;
    auto estimate = localizeAgainst(reference, keyframe, features, lines, predicted_pose);
    timing_.references_ms = millisecondsSince(references_start);
    return estimate;
  };
  // A closed route (a loop: its last keyframe near its first) wraps around, so that lap 2 goes on
  // from the last keyframe to the first ones.
  const int n = keyframeCount();
  std::vector<int> candidates{tracked_};
  for (int offset = 1; offset <= options_.neighbour_search && offset < n; ++offset) {
    if (closed_) {
      candidates.push_back((tracked_ + offset) % n);
      const int behind = ((tracked_ - offset) % n + n) % n;
      if (behind != (tracked_ + offset) % n) candidates.push_back(behind);
    } else {
      if (tracked_ + offset < n) candidates.push_back(tracked_ + offset);
      if (tracked_ - offset >= 0) candidates.push_back(tracked_ - offset);
    }
  }
  Status last_failure(StatusCode::kNoConsensus, "no reference keyframe tried");
  if (options_.mode == RepeatMode::kMu) {
    const auto unusable = [&](int k) {
      return !usableForMu(keyframes_[static_cast<std::size_t>(k)], k, predicted_pose);
    };
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(), unusable), candidates.end());
    if (candidates.empty()) {
      last_failure = Status(StatusCode::kNoConsensus,
                            "mu: no keyframe near " + std::to_string(tracked_) +
                                " gives a heading fix here (turned in place, or facing more than " +
                                std::to_string(options_.mu_max_reference_angle) + " rad away)");
    }
  }
  for (const int k : candidates) {
    auto estimate = localizeAgainstTimed(keyframes_[static_cast<std::size_t>(k)], k);
    if (!estimate) {
      last_failure = Status(estimate.status().code(),
                            "keyframe " + std::to_string(k) + ": " + estimate.status().message());
      continue;
    }
    // This frame becomes the temporary reference for when tracking is lost.
    Reference current;
    current.features = std::move(features);
    current.lines = std::move(lines);
    if (estimate->has_pose) {
      current.base_pose = estimate->base_pose;
      const auto plane = transferPlane(*keyframes_[static_cast<std::size_t>(k)].plane,
                                       estimate->camera_relative);
      if (plane) current.plane = *plane;
    } else {
      current.heading_offset = estimate->heading_correction;
    }
    if (!estimate->has_pose || current.plane) {
      temporary_ = std::move(current);
      temporary_keyframe_ = k;
    }
    degraded_frames_ = 0;
    rememberForTracking(*estimate, gray, 0);
    advanceTracking(*estimate);
    return estimate;
  }
  const bool temporary_usable =
      temporary_ && (options_.mode != RepeatMode::kMu || usableForMu(*temporary_, temporary_keyframe_, predicted_pose));
  if (temporary_usable && degraded_frames_ < options_.max_degraded_frames) {
    auto estimate = localizeAgainstTimed(*temporary_, temporary_keyframe_);
    if (estimate) {
      estimate->degraded = true;
      ++degraded_frames_;
      if (estimate->has_pose) {
        // Chain: this frame is the next temporary reference (paper 000, outdoor experiment).
        Reference current;
        current.features = std::move(features);
        current.base_pose = estimate->base_pose;
        const auto plane = transferPlane(*temporary_->plane, estimate->camera_relative);
        if (plane) {
          current.plane = *plane;
          temporary_ = std::move(current);
        }
        estimate->heading_correction = wrapToPi(
            estimate->base_pose.yaw - route_.keyframes[static_cast<std::size_t>(temporary_keyframe_)].pose.yaw);
      }
      return estimate;
    }
    last_failure = Status(estimate.status().code(),
                          "temporary reference: " + estimate.status().message() + "; " +
                              last_failure.message());
  }
  return last_failure;
}

void RepeatLocalizer::rememberForTracking(const RepeatEstimate& estimate, const cv::Mat& gray, int frames_tracked) {
  track_.reset();
  if (options_.max_tracked_frames == 0 || gray.empty() || !estimate.has_pose || estimate.degraded ||
      estimate.keyframe < 0) {
    return;
  }
  TrackedMatches track;
  track.image = gray.clone();  // the caller's image may be a view of a buffer it reuses
  track.keyframe = estimate.keyframe;
  track.frames_tracked = frames_tracked;
  track.reference.reserve(estimate.inlier_matches.size());
  track.current.reserve(estimate.inlier_matches.size());
  for (const PointMatch& m : estimate.inlier_matches) {
    track.reference.emplace_back(static_cast<float>(m.reference.x()), static_cast<float>(m.reference.y()));
    track.current.emplace_back(static_cast<float>(m.current.x()), static_cast<float>(m.current.y()));
  }
  track_ = std::move(track);
}

Expected<RepeatEstimate> RepeatLocalizer::localizeByTracking(const cv::Mat& gray) {
  const auto start = std::chrono::steady_clock::now();
  // OpenCV's defaults for the window, pyramid and stopping rule: a 21x21 px window over 4 levels
  // (maxLevel 3) follows motions of tens of pixels between frames (a robot turning at 0.5 rad/s
  // moves the image ~8 px per frame at 30 Hz with f = 500 px).
  const cv::Size window(21, 21);
  constexpr int kPyramidLevels = 3;
  const cv::TermCriteria stop(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
  std::vector<cv::Point2f> forward, backward;
  std::vector<unsigned char> forward_found, backward_found;
  std::vector<float> error;
  try {
    cv::calcOpticalFlowPyrLK(track_->image, gray, track_->current, forward, forward_found, error, window,
                             kPyramidLevels, stop);
    cv::calcOpticalFlowPyrLK(gray, track_->image, forward, backward, backward_found, error, window,
                             kPyramidLevels, stop);
  } catch (const cv::Exception& e) {
    return Status(StatusCode::kInvalidInput, std::string("optical flow: ") + e.what());
  }
  PointMatches measured;
  const auto inside = [&](const cv::Point2f& p) {
    return p.x >= 0.0F && p.y >= 0.0F && p.x <= static_cast<float>(gray.cols - 1) &&
           p.y <= static_cast<float>(gray.rows - 1);
  };
  for (std::size_t i = 0; i < forward.size(); ++i) {
    if (!forward_found[i] || !backward_found[i] || !inside(forward[i])) continue;
    if (cv::norm(backward[i] - track_->current[i]) > options_.tracking_tolerance_px) continue;
    measured.push_back({Eigen::Vector2d(track_->reference[i].x, track_->reference[i].y),
                        Eigen::Vector2d(forward[i].x, forward[i].y)});
  }
  timing_.extraction_ms = millisecondsSince(start);
  if (static_cast<int>(measured.size()) < options_.min_inliers) {
    return Status(StatusCode::kNoConsensus, "tracking: " + std::to_string(measured.size()) + " of " +
                                                std::to_string(track_->current.size()) +
                                                " points followed, need " + std::to_string(options_.min_inliers));
  }
  const auto references_start = std::chrono::steady_clock::now();
  ++timing_.references_tried;
  auto estimate = estimateFromMatches(keyframes_[static_cast<std::size_t>(track_->keyframe)], track_->keyframe, measured);
  timing_.references_ms = millisecondsSince(references_start);
  if (estimate) estimate->tracked = true;
  return estimate;
}

Expected<RepeatEstimate> RepeatLocalizer::initializeGlobally(const cv::Mat& image) {
  int best_keyframe = -1, best_inliers = -1;
  for (int k = 0; k < keyframeCount(); ++k) {
    setTrackedKeyframe(k);
    const int neighbour_search = options_.neighbour_search;
    options_.neighbour_search = 0;
    const int degraded = options_.max_degraded_frames;
    options_.max_degraded_frames = 0;
    const auto estimate = localize(image);
    options_.neighbour_search = neighbour_search;
    options_.max_degraded_frames = degraded;
    if (estimate && estimate->inliers > best_inliers) {
      best_inliers = estimate->inliers;
      best_keyframe = k;
    }
  }
  if (best_keyframe < 0) {
    return Status(StatusCode::kNoConsensus, "the image matches no keyframe of the route");
  }
  setTrackedKeyframe(best_keyframe);
  return localize(image);
}

}  // namespace homography_teach_repeat
