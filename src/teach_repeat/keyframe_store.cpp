#include "homography_teach_repeat/teach_repeat/keyframe_store.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "homography_teach_repeat/common/median.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/fast_hd/plane_estimation.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/teach_repeat/keyframe_estimators.h"

namespace homography_teach_repeat {
namespace {
constexpr double kTurnKeyframeAngle = 0.1;  // [rad]
constexpr double kTurnKeyframeRate = 1.0;   // [rad/m]

// measurePlaneAgreement's last step. One or two differences make a noisy variance: two planes that
// agree by chance (χ² with one degree of freedom is below 0.01 of its mean one time in twelve) are
// no evidence of an exact plane. The route's median variance counts as kPriorDegrees differences
// more; a keyframe whose neighbours disagree more keeps its own (KITTI 07: keyframes 28-30 agreed
// to 0.2° and 0.4 % and their fixes were 1-3 cm off claiming 4-5 mm; docs/math.md §3.6). A plane
// that no neighbour could be compared with (the keyframes beside it have no plane) takes the route's.
// `degrees[k]`: the neighbours keyframe k was compared with (0: no measured σ).
void keepAtLeastTheRoutesPlaneVariance(const std::vector<int>& degrees, std::vector<KeyframeReference>* keyframes) {
  constexpr double kPriorDegrees = 2.0;
  std::vector<double> normal_variances, distance_variances;
  for (std::size_t k = 0; k < keyframes->size(); ++k) {
    if (degrees[k] == 0) continue;
    normal_variances.push_back(std::pow((*keyframes)[k].plane_normal_sigma_rad, 2));
    distance_variances.push_back(std::pow((*keyframes)[k].plane_distance_sigma, 2));
  }
  if (normal_variances.empty()) return;
  const double route_normal = *upperMedian(std::move(normal_variances));
  const double route_distance = *upperMedian(std::move(distance_variances));
  const auto atLeastPooled = [](double sigma, int counted, double route_variance) {
    const double own = sigma * sigma;
    const double pooled = (counted * own + kPriorDegrees * route_variance) / (counted + kPriorDegrees);
    return std::sqrt(std::max(own, pooled));
  };
  for (std::size_t k = 0; k < keyframes->size(); ++k) {
    KeyframeReference& reference = (*keyframes)[k];
    if (!reference.plane) continue;
    reference.plane_normal_sigma_rad = atLeastPooled(reference.plane_normal_sigma_rad, degrees[k], route_normal);
    reference.plane_distance_sigma = atLeastPooled(reference.plane_distance_sigma, degrees[k], route_distance);
  }
}
}  // namespace

bool turnedBetween(const Pose2D& a, const Pose2D& b) {
  return std::abs(wrapToPi(b.yaw - a.yaw)) > kTurnKeyframeAngle + kTurnKeyframeRate * std::hypot(b.x - a.x, b.y - a.y);
}

Expected<KeyframeStore> KeyframeStore::load(const Route& route, const RepeatOptions& options) {
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  if (route.keyframes.empty()) {
    return Status(StatusCode::kInvalidInput, "route '" + route.directory + "' has no keyframe");
  }
  if (options.mode == RepeatMode::kHybrid) {
    return Status(StatusCode::kInvalidInput,
                  "hybrid mode loads a fast_hd and a mu store (RepeatPipeline), not one of its own");
  }
  KeyframeStore store;
  const std::optional<double> route_residual = routeMatchResidual(route);  // once: a median over the route
  for (std::size_t k = 0; k < route.keyframes.size(); ++k) {
    KeyframeReference reference;
    reference.base_pose = route.keyframes[k].pose;
    reference.plane = route.keyframes[k].plane;
    if (options.mode == RepeatMode::kMu) {
      auto lines = loadKeyframeLines(route, k);
      if (!lines) return lines.status();
      reference.lines = std::move(*lines);
    } else {
      if (!reference.plane && options.require_planes) {
        return Status(StatusCode::kInvalidInput,
                      "keyframe " + std::to_string(k) + " of '" + route.directory + "' has no plane: " +
                          toString(options.mode) + " mode needs the plane estimation of the teach phase (or use mu)");
      }
      auto features = loadKeyframeFeatures(route, k);
      if (!features) return features.status();
      reference.features = std::move(*features);
    }
    if (options.pixel_noise_per_keyframe) reference.pixel_noise_scale = keyframePixelNoiseScale(route, k, route_residual);
    if (k > 0) {
      // A corner keyframe: reached turning, or where the teach run started turning (its heading is
      // the straight segment's, but the walls of the corner are as near).
      reference.turn = turnedBetween(route.keyframes[k - 1].pose, route.keyframes[k].pose) ||
                       (k + 1 < route.keyframes.size() && turnedBetween(route.keyframes[k].pose, route.keyframes[k + 1].pose));
    }
    store.keyframes_.push_back(std::move(reference));
  }
  const Pose2D& m = route.info.camera_mount;
  const CameraMount mount(m.x, m.y, m.yaw);
  const PinholeCamera camera(route.info.camera);
  if (options.mode != RepeatMode::kMu && options.plane_feature_tolerance_px > 0.0) {
    store.restrictToPlaneFeatures(camera, mount, options);
  }
  if (options.mode == RepeatMode::kFastHd && options.plane_sigma_from_neighbours) {
    if (planeUncertaintyStored(route)) {  // measured by the teach run (or a migration)
      for (std::size_t k = 0; k < route.keyframes.size(); ++k) store.setPlaneUncertainty(k, route.keyframes[k].plane_uncertainty);
    } else {
      store.measurePlaneAgreement(mount, camera);
      store.measureNeighbourFixes(route, camera, mount, options);
    }
    store.setHeadingFloor(options.pose.common_shift_sigma_px / camera.fx());
    store.plane_uncertainty_known_ = true;
  }
  if (options.mode == RepeatMode::kMu && options.mu_line_landmarks) {
    store.triangulateLines(camera, mount, options.line_landmarks);
  }
  store.experiences_.resize(store.keyframes_.size());
  if (options.mode != RepeatMode::kMu && options.use_experiences) {
    const Status loaded = store.loadExperiences(route, mount);
    if (!loaded.isOk()) return loaded;
  }
  return store;
}

Status KeyframeStore::loadExperiences(const Route& route, const CameraMount& mount) {
  for (std::size_t k = 0; k < keyframes_.size(); ++k) {
    const KeyframeReference& keyframe = keyframes_[k];
    if (!keyframe.plane) continue;  // a pose needs the place's plane
    const auto& experiences = route.keyframes[k].experiences;
    for (std::size_t e = experiences.size(); e-- > 0;) {  // newest first
      const RouteExperience& learned = experiences[e];
      // The experience's camera in the keyframe's camera frame carries the plane into its frame.
      const PlanarPose relative = mount.baseToCamera(keyframe.base_pose.inverse().compose(learned.pose));
      const auto plane = transferPlane(*keyframe.plane, relative);
      if (!plane) continue;  // (its camera behind the keyframe's plane: not a view of it)
      auto features = loadExperienceFeatures(route, k, e);
      if (!features) return features.status();
      KeyframeReference reference;
      reference.features = std::move(*features);
      reference.base_pose = learned.pose;
      reference.base_pose_covariance = learned.pose_covariance;
      reference.plane = *plane;
      reference.plane_normal_sigma_rad = keyframe.plane_normal_sigma_rad;
      reference.plane_distance_sigma = keyframe.plane_distance_sigma;
      reference.neighbour_fix_error_per_m2 = keyframe.neighbour_fix_error_per_m2;
      reference.neighbour_fix_heading_floor_rad = keyframe.neighbour_fix_heading_floor_rad;
      reference.turn = keyframe.turn;
      reference.pixel_noise_scale = keyframe.pixel_noise_scale;
      reference.experience = learned.id;
      experiences_[k].push_back(std::move(reference));
    }
  }
  return Status::ok();
}

int KeyframeStore::experienceCount() const {
  int count = 0;
  for (const auto& e : experiences_) count += static_cast<int>(e.size());
  return count;
}

void KeyframeStore::triangulateLines(const PinholeCamera& camera, const CameraMount& mount,
                                     const LineLandmarkOptions& options) {
  constexpr int kViewsEachSide = 2;
  const LineCamera lens{camera.fx(), camera.cx()};
  const int n = size();
  for (int k = 0; k < n; ++k) {
    KeyframeReference& reference = keyframes_[static_cast<std::size_t>(k)];
    std::vector<LineView> views;
    // Nearest first: the first view with a candidate decides (triangulateLineLandmarks).
    for (int d = 1; d <= kViewsEachSide; ++d) {
      for (const int j : {k + d, k - d}) {
        if (j < 0 || j >= n) continue;
        const KeyframeReference& neighbour = keyframes_[static_cast<std::size_t>(j)];
        views.push_back(LineView{mount.baseToCamera(reference.base_pose.inverse().compose(neighbour.base_pose)),
                                 &neighbour.lines});
      }
    }
    auto landmarks = triangulateLineLandmarks(reference.lines, views, lens, options);
    // (Fails only on a bad camera or options, which load() has validated.)
    if (landmarks) reference.line_landmarks = std::move(*landmarks);
  }
}

void KeyframeStore::measurePlaneAgreement(const CameraMount& mount, const PinholeCamera& camera) {
  for (KeyframeReference& reference : keyframes_) {
    if (!reference.plane) continue;
    std::vector<Eigen::Vector3d> rays;
    rays.reserve(reference.features.keypoints.size());
    for (const cv::KeyPoint& keypoint : reference.features.keypoints) {
      rays.push_back(camera.pixelToNormalized(keypoint.pt).homogeneous());
    }
    reference.plane_pivot = centroidOnPlane(*reference.plane, rays);
  }
  constexpr double kLargest = 0.5;  // the range PlanarPoseEstimatorOptions accepts
  // Farther apart than this (normal [rad] or relative distance), two planes are not one surface
  // seen twice with errors: at a corner the next keyframe sees the next wall (docs/math.md §3.6).
  constexpr double kOtherSurface = 0.6;
  struct Disagreement {
    double angle = 0.0, distance = 0.0;
    bool otherSurface() const { return angle > kOtherSurface || distance > kOtherSurface; }
  };
  // Closer than this (normal [rad] and relative distance), a neighbour's plane is this plane
  // carried by the taught motion (the straighter pair's, a turn in place's: docs/math.md §2.6),
  // not a second estimate: agreeing with it says nothing.
  constexpr double kCopy = 1e-6;
  const int n = size();
  const auto disagreement = [&](const KeyframeReference& reference, const KeyframeReference& neighbour) {
    // This keyframe's camera in the neighbour's camera frame.
    const PlanarPose here = mount.baseToCamera(neighbour.base_pose.inverse().compose(reference.base_pose));
    const auto carried = transferPlane(*neighbour.plane, here);
    // The neighbour's plane behind this camera: as far off as can be.
    Disagreement d{kLargest * std::sqrt(2.0), kLargest * std::sqrt(2.0)};
    if (carried) {
      // The distances compared where this plane's features are (docs/math.md §3.6).
      const Eigen::Vector3d pivot = reference.plane_pivot.value_or(reference.plane->distance * reference.plane->normal);
      d.angle = std::acos(std::clamp(carried->normal.dot(reference.plane->normal), -1.0, 1.0));
      d.distance = std::abs(carried->normal.dot(pivot) - carried->distance) / reference.plane->distance;
    }
    return d;
  };
  std::vector<int> degrees(static_cast<std::size_t>(n), 0);
  std::vector<bool> compared_with_nothing(static_cast<std::size_t>(n), false);
  for (int k = 0; k < n; ++k) {
    KeyframeReference& reference = keyframes_[static_cast<std::size_t>(k)];
    if (!reference.plane) continue;
    std::vector<std::pair<int, Disagreement>> neighbours;  // (keyframe, its plane against this one)
    for (const int step : {-1, 1}) {
      // The nearest keyframe on this side whose plane is an estimate of its own: a run of copies
      // is one estimate, compared with the keyframes beyond it.
      for (int j = k + step; j >= 0 && j < n && keyframes_[static_cast<std::size_t>(j)].plane; j += step) {
        const Disagreement d = disagreement(reference, keyframes_[static_cast<std::size_t>(j)]);
        if (d.angle < kCopy && d.distance < kCopy) continue;
        neighbours.emplace_back(j, d);
        break;
      }
    }
    if (neighbours.empty()) continue;
    const auto other = [](const std::pair<int, Disagreement>& neighbour) { return neighbour.second.otherSurface(); };
    const bool one_agrees = !std::all_of(neighbours.begin(), neighbours.end(), other);
    // Every neighbour sees another surface: where the two see one surface between them, this plane
    // is the odd one and the disagreement is its own; where they differ too (three walls of a
    // corridor, a route's end), it was compared with nothing (below).
    if (!one_agrees && (neighbours.size() < 2 ||
                        disagreement(keyframes_[static_cast<std::size_t>(neighbours[0].first)],
                                     keyframes_[static_cast<std::size_t>(neighbours[1].first)])
                            .otherSurface())) {
      compared_with_nothing[static_cast<std::size_t>(k)] = true;
      continue;
    }
    // Where one neighbour sees the same surface and the other another one (a wall's end), the
    // other says nothing about this plane's error (the simulator's corners: 0-1° and exactly 90°).
    double angle_squares = 0.0, distance_squares = 0.0;
    int counted = 0;
    for (const auto& neighbour : neighbours) {
      const Disagreement& d = neighbour.second;
      if (one_agrees && d.otherSurface()) continue;
      angle_squares += d.angle * d.angle;
      distance_squares += d.distance * d.distance;
      ++counted;
    }
    reference.plane_normal_sigma_rad = std::min(kLargest, std::sqrt(angle_squares / (2.0 * counted)));
    reference.plane_distance_sigma = std::min(kLargest, std::sqrt(distance_squares / (2.0 * counted)));
    degrees[static_cast<std::size_t>(k)] = counted;
  }
  // A plane compared with nothing takes the plane error of its place: the larger of the nearest
  // compared planes' on each side (along a building's walls they agree to a degree; at a street
  // corner each is another mixture of road and facade; docs/math.md §3.6).
  for (int k = 0; k < n; ++k) {
    if (!compared_with_nothing[static_cast<std::size_t>(k)]) continue;
    KeyframeReference& reference = keyframes_[static_cast<std::size_t>(k)];
    for (const int step : {-1, 1}) {
      for (int j = k + step; j >= 0 && j < n; j += step) {
        if (degrees[static_cast<std::size_t>(j)] == 0) continue;
        const KeyframeReference& compared = keyframes_[static_cast<std::size_t>(j)];
        reference.plane_normal_sigma_rad = std::max(reference.plane_normal_sigma_rad, compared.plane_normal_sigma_rad);
        reference.plane_distance_sigma = std::max(reference.plane_distance_sigma, compared.plane_distance_sigma);
        break;
      }
    }
  }
  keepAtLeastTheRoutesPlaneVariance(degrees, &keyframes_);
}

void KeyframeStore::measureNeighbourFixes(const Route& route, const PinholeCamera& camera, const CameraMount& mount,
                                          const RepeatOptions& options) {
  // Planes within this [rad] are one surface, and a fix's error grows with the displacement as at
  // the neighbours; at a corner's mixture of road and facades (KITTI 07: 0.1-0.5 rad, the straights
  // 0.02-0.04) one neighbour misses the other side's error: counted there from both (docs/math.md §3.10).
  constexpr double kAgreeingPlanes = 0.1;
  const int n = size();
  // Each keyframe's stored features serve both its neighbours: read once, dropped once both used
  // (the store holds only the plane features; reading all at once would hold every image's).
  std::map<int, std::optional<ImageFeatures>> stored;
  const auto storedFeatures = [&](int j) -> const std::optional<ImageFeatures>& {
    auto found = stored.find(j);
    if (found == stored.end()) {
      auto loaded = loadKeyframeFeatures(route, static_cast<std::size_t>(j));
      // (load() read it already: it cannot fail here but on a changed disk)
      found = stored.emplace(j, loaded ? std::optional<ImageFeatures>(std::move(*loaded)) : std::nullopt).first;
    }
    return found->second;
  };
  for (int k = 0; k < n; ++k) {
    stored.erase(stored.begin(), stored.lower_bound(k - 1));
    KeyframeReference& reference = keyframes_[static_cast<std::size_t>(k)];
    if (!reference.plane) continue;
    Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
    int measured = 0;
    std::array<std::optional<std::pair<double, double>>, 2> heading_error_at;  // (d, e_θ) before, after
    for (const int j : {k - 1, k + 1}) {
      if (j < 0 || j >= n) continue;
      const PlanarPose taught =
          mount.baseToCamera(reference.base_pose.inverse().compose(keyframes_[static_cast<std::size_t>(j)].base_pose));
      const double d = std::hypot(taught.x, taught.z);
      // Reached by turning (a turn in place, turnedBetween), the views differ by the rotation more
      // than by the displacement, and the error per metre of it says nothing (the simulator's l_hall:
      // 1.0 per metre from a neighbour 6 cm and 22° away, where the fixes along its walls are 0.1 %).
      if (d < kSameViewpointM || turnedBetween(reference.base_pose, keyframes_[static_cast<std::size_t>(j)].base_pose)) {
        continue;
      }
      const std::optional<ImageFeatures>& neighbour = storedFeatures(j);
      if (!neighbour) continue;
      // A fix the repeat would refuse (another wall in view) is not one whose error it must carry.
      const auto fix = localizeAgainstPlane(reference, *neighbour, camera, options, /*check_on_plane=*/true);
      if (!fix || static_cast<int>(fix->inliers.size()) < options.min_inliers) continue;
      const Eigen::Vector3d e(fix->pose.x - taught.x, fix->pose.z - taught.z, wrapToPi(fix->pose.theta - taught.theta));
      sum += e * e.transpose() / (d * d);
      ++measured;
      heading_error_at[j > k ? 1 : 0] = std::make_pair(d, e(2));
    }
    if (measured == 0 || (measured == 1 && !(reference.plane_normal_sigma_rad < kAgreeingPlanes))) continue;
    reference.neighbour_fix_error_per_m2 = Eigen::Matrix3d(sum / measured);
    if (heading_error_at[0] && heading_error_at[1]) {
      const auto [d_before, e_before] = *heading_error_at[0];
      const auto [d_after, e_after] = *heading_error_at[1];
      const double intercept = (e_before * d_after + e_after * d_before) / (d_before + d_after);
      reference.neighbour_fix_heading_intercept_rad = std::clamp(intercept, -kLargestHeadingFloorRad, kLargestHeadingFloorRad);
    }
  }
}

void KeyframeStore::setPlaneUncertainty(std::size_t keyframe, const std::optional<PlaneUncertainty>& stored) {
  KeyframeReference& reference = keyframes_[keyframe];
  if (!stored || !reference.plane) return;
  reference.plane_normal_sigma_rad = stored->normal_sigma_rad;
  reference.plane_distance_sigma = stored->distance_sigma;
  reference.plane_pivot = stored->pivot;
  reference.neighbour_fix_error_per_m2 = stored->fix_error_per_m2;
  reference.neighbour_fix_heading_intercept_rad = stored->fix_heading_intercept_rad;
}

void KeyframeStore::setHeadingFloor(double configured_rad) {
  std::vector<double> intercepts;
  for (const KeyframeReference& k : keyframes_) {
    if (k.neighbour_fix_heading_intercept_rad) intercepts.push_back(*k.neighbour_fix_heading_intercept_rad);
  }
  const double typical = pooledHeadingFloor(intercepts, configured_rad);
  for (KeyframeReference& k : keyframes_) {
    if (!k.neighbour_fix_error_per_m2) continue;
    k.neighbour_fix_heading_floor_rad = std::max(typical, std::abs(k.neighbour_fix_heading_intercept_rad.value_or(0.0)));
  }
}

std::optional<PlaneUncertainty> KeyframeStore::planeUncertainty(int keyframe) const {
  const KeyframeReference& reference = at(keyframe);
  if (!plane_uncertainty_known_ || !reference.plane) return std::nullopt;
  return PlaneUncertainty{reference.plane_normal_sigma_rad, reference.plane_distance_sigma, reference.plane_pivot,
                          reference.neighbour_fix_error_per_m2, reference.neighbour_fix_heading_intercept_rad};
}

std::vector<Pose2D> KeyframeStore::poses() const {
  std::vector<Pose2D> poses;
  poses.reserve(keyframes_.size());
  for (const auto& k : keyframes_) poses.push_back(k.base_pose);
  return poses;
}

void KeyframeStore::restrictToPlaneFeatures(const PinholeCamera& camera, const CameraMount& mount,
                                            const RepeatOptions& options) {
  const int n = size();
  if (n < 2) return;
  // A closed route's last keyframes have the first ones as neighbours (the gallery's start
  // corner: the last turn keyframe, facing the first leg, had only keyframes turning in place
  // before it and kept the far wall's features against the side wall's plane: poses 9 cm off
  // claiming 2 mm).
  const bool closed = isClosedLoop(poses(), options.closed_route_gap);
  auto wrapped = [&](int j) -> std::optional<int> {
    if (j >= 0 && j < n) return j;
    if (!closed) return std::nullopt;
    return (j % n + n) % n;
  };
  // The camera of keyframe j in the camera frame of keyframe k.
  auto relativeCamera = [&](int k, int j) {
    return mount.baseToCamera(keyframes_[static_cast<std::size_t>(k)].base_pose.inverse().compose(
        keyframes_[static_cast<std::size_t>(j)].base_pose));
  };
  // Every keyframe against its neighbours' whole feature sets, then each restricted.
  std::vector<std::optional<std::vector<int>>> plane_features(static_cast<std::size_t>(n));
  for (int k = 0; k < n; ++k) {
    const KeyframeReference& reference = keyframes_[static_cast<std::size_t>(k)];
    if (!reference.plane) continue;  // (hybrid: not used for poses)
    // The keyframes the camera moved to from here (k±1..k±kMaxSteps), at least kMinBaseline away
    // and within kMaxTurn of this one's heading: a turn in place maps every wall alike and cannot
    // tell this one's plane from a side wall. The keyframe where the teach run stopped to turn has
    // its neighbours on the leg it came along (found in the simulator: with a shelf hiding the wall
    // ahead, the side wall's features out-voted it and the poses were 6 cm off claiming 4 mm).
    // A feature stays when it moves as the plane predicts to every one of them that it matches:
    // near a corner the side wall's features miss the plane by little at the nearest neighbour
    // (the gallery's keyframe 14: 21 of them among the inliers where its own photograph had been
    // replaced, 3.5 cm off claiming 4 mm), by more at one 0.5 m on. Without any such neighbour
    // (the middle of a turn in place), the nearest keyframe.
    constexpr double kMinBaseline = 0.1;  // [m] of the camera
    constexpr double kMaxTurn = 0.5;      // [rad]
    constexpr int kMaxSteps = 3;
    std::vector<int> neighbours;
    for (int step = 1; step <= kMaxSteps; ++step) {
      for (const int candidate : {k + step, k - step}) {
        const auto j = wrapped(candidate);
        if (!j || *j == k) continue;
        const PlanarPose motion = relativeCamera(k, *j);
        if (std::hypot(motion.x, motion.z) >= kMinBaseline && std::abs(motion.theta) <= kMaxTurn) neighbours.push_back(*j);
      }
    }
    if (neighbours.empty()) {
      const auto next = wrapped(k + 1);
      neighbours.push_back(next && *next != k ? *next : k - 1);
    }
    // Per feature: -1 missed the plane somewhere, 2 on it where the plane predicts parallax,
    // 1 on it only where it does not (confirms nothing alone), 0 not matched.
    std::vector<int> verdict(reference.features.keypoints.size(), 0);
    for (const int j : neighbours) {
      const KeyframeReference& neighbour = keyframes_[static_cast<std::size_t>(j)];
      const auto dmatches = matchFeatures(reference.features, neighbour.features, options.matching);
      if (!dmatches) continue;
      std::vector<int> kept;
      const PointMatches on_pixels =
          undistortMatches(camera, toPointMatches(reference.features, neighbour.features, *dmatches), &kept);
      // Images that are not level (tilt_sigma > 0): the pair's tilt is estimated with the plane
      // (docs/math.md §2.5). Found in the simulator: the gallery's last keyframe, facing along the
      // side wall, kept 7 features of the far wall that its plane put 25-58 m away, confirmed by the
      // keyframes ahead because they lay where the robot drove to (without parallax); 6 of them
      // among 32 inliers gave poses 0.3-0.65° off claiming 0.03°.
      const std::optional<RobustHomographyOptions> tilt_fit =
          options.pose.tilt_sigma_rad > 0.0 ? std::optional(options.pose.robust) : std::nullopt;
      const std::vector<PlaneMatchRating> ratings = ratePlaneMatches(
          on_pixels, camera, relativeCamera(k, j), *reference.plane, options.plane_feature_tolerance_px, tilt_fit);
      for (std::size_t i = 0; i < on_pixels.size(); ++i) {
        int& feature = verdict[static_cast<std::size_t>((*dmatches)[static_cast<std::size_t>(kept[i])].queryIdx)];
        if (ratings[i] == PlaneMatchRating::kOffThePlane) {
          feature = -1;
        } else if (feature != -1) {
          feature = std::max(feature, ratings[i] == PlaneMatchRating::kOnWithParallax ? 2 : 1);
        }
      }
    }
    auto featuresRated = [&](int at_least) {
      std::vector<int> selected;
      for (std::size_t i = 0; i < verdict.size(); ++i) {
        if (verdict[i] >= at_least) selected.push_back(static_cast<int>(i));
      }
      return selected;
    };
    const int refuted = static_cast<int>(std::count(verdict.begin(), verdict.end(), -1));
    std::vector<int> on_plane = featuresRated(2);
    // Too few confirmed where the plane predicts parallax: those it predicted without parallax are
    // still better than all of them. (A car driving along a street sees the facade recede towards
    // the direction of travel: of KITTI 07's keyframe 5's 1517 features, full size, its neighbours
    // saw 97 where its plane put them, 6 of them with parallax, and 737 off it; it kept all 1517 and
    // the first turn's fixes were 8 cm off, NEES mean 248; with the 97 3.6 cm, NEES 4.5
    // (docs/evaluation.md, "KITTI 07").)
    if (static_cast<int>(on_plane.size()) < 2 * options.min_inliers) on_plane = featuresRated(1);
    // Still too few: a pure rotation to the neighbour maps every feature alike, or the neighbour
    // shows little of this plane; keep every feature then. (Keeping only those not seen off the
    // plane broke fountain-P11's real wall: median 0.024 m instead of < 0.020, NEES 914; the 2 px
    // tolerance refutes true plane features of a real camera.) Not so a keyframe taken turning in
    // place whose neighbours refuted more features than they confirmed: its plane is the wall the
    // leg before it faced, rotated, an assumption the views disprove (l_hall's start corner: the
    // turn keyframe facing the far wall kept 770 features, 519 of them off the side wall's plane,
    // and gave fixes 11 mm / 0.3° off claiming 0.4 mm / 0.005°).
    const bool disproved = reference.turn && refuted > static_cast<int>(on_plane.size());
    if (static_cast<int>(on_plane.size()) < 2 * options.min_inliers && !disproved) continue;
    plane_features[static_cast<std::size_t>(k)] = std::move(on_plane);
  }
  for (int k = 0; k < n; ++k) {
    KeyframeReference& reference = keyframes_[static_cast<std::size_t>(k)];
    if (plane_features[static_cast<std::size_t>(k)]) {
      reference.features = selectFeatures(reference.features, *plane_features[static_cast<std::size_t>(k)]);
    }
  }
}

}  // namespace homography_teach_repeat
