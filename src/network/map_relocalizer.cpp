#include "homography_teach_repeat/network/map_relocalizer.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <thread>
#include <utility>

#include "homography_teach_repeat/common/text.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/network/map_place_index.h"

namespace homography_teach_repeat {
namespace {

using Clock = std::chrono::steady_clock;

double millisecondsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

RepeatOptions fastHdOptions(RepeatOptions repeat) {
  repeat.mode = RepeatMode::kFastHd;
  repeat.require_planes = true;
  return repeat;
}

}  // namespace

void RelocalizationOptions::validate() const {
  const auto require = [](bool ok, const std::string& what) {
    if (!ok) throw std::invalid_argument("relocalization: " + what);
  };
  require(candidates >= 1, "candidates must be at least 1 (got " + std::to_string(candidates) + ")");
  require(checks_per_frame >= 1, "checks_per_frame must be at least 1 (got " + std::to_string(checks_per_frame) + ")");
  require(confirmations >= 1, "confirmations must be at least 1 (got " + std::to_string(confirmations) + ")");
  require(std::isfinite(confirmation_distance) && confirmation_distance >= 0.0, "confirmation_distance must be >= 0 [m]");
  require(std::isfinite(confirmation_turn) && confirmation_turn >= 0.0, "confirmation_turn must be >= 0 [rad]");
  require(std::isfinite(gate_distance) && gate_distance > 0.0, "gate_distance must be > 0 [m]");
  require(std::isfinite(gate_distance_per_metre) && gate_distance_per_metre >= 0.0, "gate_distance_per_metre must be >= 0");
  require(std::isfinite(gate_yaw) && gate_yaw > 0.0, "gate_yaw must be > 0 [rad]");
  require(max_misses >= 0, "max_misses must be >= 0");
  require(max_hypotheses >= 1, "max_hypotheses must be at least 1");
  require(retry_after_frames >= 0, "retry_after_frames must be >= 0");
  require(cached_keyframes >= 1, "cached_keyframes must be at least 1");
  require(std::isfinite(hint_radius) && hint_radius > 0.0, "hint_radius must be > 0 [m]");
  require(std::isfinite(max_place_distance) && max_place_distance > 0.0, "max_place_distance must be > 0 [m]");
}

std::string toString(RelocalizationState state) {
  switch (state) {
    case RelocalizationState::kSearching: return "searching";
    case RelocalizationState::kTentative: return "tentative";
    case RelocalizationState::kAmbiguous: return "ambiguous";
    case RelocalizationState::kConfirmed: return "confirmed";
  }
  return "unknown";
}

std::optional<PlaceHint> placeHintFromMapPose(const RouteMap& map, const Pose2D& pose_in_map) {
  if (!pose_in_map.isFinite()) return std::nullopt;
  std::optional<PlaceHint> best;
  double best_distance = std::numeric_limits<double>::infinity();
  for (const auto& [name, frame] : routeFramesInMap(map)) {
    const Pose2D in_route = frame.inverse().compose(pose_in_map);
    for (const RouteKeyframe& k : map.find(name)->route.keyframes) {
      const double distance = std::hypot(k.pose.x - in_route.x, k.pose.y - in_route.y);
      if (distance < best_distance) {
        best_distance = distance;
        best = PlaceHint{name, in_route};
      }
    }
  }
  return best;
}

Expected<MapRelocalizer> MapRelocalizer::create(const RouteMap& map, std::optional<PlaceIndex> index,
                                                const RepeatOptions& repeat, const RelocalizationOptions& options) {
  try {
    options.validate();
    fastHdOptions(repeat).validate();
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  if (map.routes.empty()) return Status(StatusCode::kInvalidInput, "the map '" + map.directory + "' has no route");
  std::size_t keyframes = 0, with_plane = 0;
  for (const MapRoute& r : map.routes) {
    keyframes += r.route.keyframes.size();
    for (const RouteKeyframe& k : r.route.keyframes) with_plane += k.plane ? 1 : 0;
  }
  if (with_plane == 0) {
    return Status(StatusCode::kInvalidInput, "no keyframe of the map '" + map.directory +
                                                 "' has a plane: relocalization checks places with fast_hd, which "
                                                 "needs the teach phase's planes");
  }
  if (index && index->size() != keyframes) {
    return Status(StatusCode::kInvalidInput, "the place index has " + std::to_string(index->size()) +
                                                 " keyframes and the map " + std::to_string(keyframes) +
                                                 ": rebuild it (route_map index " + map.directory + ")");
  }
  return MapRelocalizer(std::make_shared<const RouteMap>(map), std::move(index), repeat, options);
}

MapRelocalizer::MapRelocalizer(std::shared_ptr<const RouteMap> map, std::optional<PlaceIndex> index,
                               const RepeatOptions& repeat, const RelocalizationOptions& options)
    : map_(std::move(map)), index_(std::move(index)), options_(options), cache_(map_, repeat, options.cached_keyframes) {
  const RepeatOptions fast_hd = fastHdOptions(repeat);
  for (const MapRoute& r : map_->routes) {
    std::vector<Pose2D> poses;
    for (const RouteKeyframe& k : r.route.keyframes) poses.push_back(k.pose);
    // Each route's own measured pixel noise and tilt (a map may join routes of several cameras).
    const EstimatorContext context{PinholeCamera(r.route.info.camera), r.route.info.feature_type,
                                   r.route.info.camera_mount, poses, withMeasuredNoise(fast_hd, r.route)};
    estimators_[r.name] = makeKeyframeEstimator(context);
  }
}

Status MapRelocalizer::setHint(const PlaceHint& hint) {
  if (map_->find(hint.route) == nullptr) {
    return Status(StatusCode::kInvalidInput, "the hint's route '" + hint.route + "' is not in the map");
  }
  if (!hint.pose.isFinite()) return Status(StatusCode::kInvalidInput, "the hint's pose is not finite");
  hint_ = hint;
  failed_at_frame_.clear();  // the keyframes around the hint are checked afresh
  return Status::ok();
}

void MapRelocalizer::reset() {
  hypotheses_.clear();
  failed_at_frame_.clear();
  hint_.reset();
  last_odometry_.reset();
}

void MapRelocalizer::warmUp() {
  const CameraCalibration& camera = map_->routes.front().route.info.camera;
  cv::Mat noise(camera.height, camera.width, CV_8UC1);
  cv::randu(noise, 0, 256);
  (void)estimators_.begin()->second->observe(noise, noise);
}

Expected<Relocalization> MapRelocalizer::update(const cv::Mat& image, const Pose2D& odometry) {
  if (image.empty()) return Status(StatusCode::kInvalidInput, "relocalization: the image is empty");
  if (!odometry.isFinite()) return Status(StatusCode::kInvalidInput, "relocalization: the odometry pose is not finite");
  if (!hint_ && !index_) {
    return Status(StatusCode::kInvalidInput, "relocalization without a hint needs the map's place index: build it with "
                                             "'route_map index " + map_->directory + "'");
  }
  ++frame_;
  if (last_odometry_) {
    const Pose2D motion = last_odometry_->inverse().compose(odometry);
    const double driven = std::hypot(motion.x, motion.y);
    for (PlaceHypothesis& h : hypotheses_) {
      h.base_pose = h.base_pose.compose(motion);
      h.driven += driven;
      h.driven_since_support += driven;
      h.turned += std::abs(motion.yaw);
    }
  }
  last_odometry_ = odometry;

  Relocalization result;
  const std::size_t loads_before = cache_.loads();
  const auto start = Clock::now();
  const auto gray = toGray8(image);
  if (!gray) return gray.status();
  const auto frame = estimators_.begin()->second->observe(image, *gray);
  result.timing.extraction_ms = millisecondsSince(start);
  if (!frame) {
    if (frame.status().code() == StatusCode::kInvalidInput) return frame.status();
    for (PlaceHypothesis& h : hypotheses_) ++h.misses;
  } else {
    // The keyframes this frame checks, read side by side first: each hypothesis' nearest
    // keyframe and the proposals (which must not duplicate them).
    std::vector<KeyframeRef> targets;
    for (const PlaceHypothesis& h : hypotheses_) {
      const auto nearest = nearestKeyframes(h.keyframe.route, h.base_pose, 1, std::numeric_limits<double>::infinity());
      targets.push_back(nearest.empty() ? h.keyframe : nearest.front());
    }
    auto proposed = selectProposals(frame->features.descriptors, targets, &result.timing);
    if (!proposed) return proposed.status();
    std::vector<KeyframeRef> all = targets;
    all.insert(all.end(), proposed->begin(), proposed->end());
    const auto read_start = Clock::now();
    cache_.prefetch(all, std::max(1u, std::thread::hardware_concurrency()));
    result.timing.checks_ms += millisecondsSince(read_start);
    checkHypotheses(*frame, targets, &result);
    checkProposals(*frame, *proposed, &result);
  }
  result.timing.loads = static_cast<int>(cache_.loads() - loads_before);
  judge(&result);
  if (!frame) result.reason = "no features in this image (" + frame.status().message() + "); " + result.reason;
  return result;
}

std::optional<RepeatEstimate> MapRelocalizer::check(const KeyframeRef& ref, const FrameObservations& frame,
                                                    Relocalization* result) {
  const auto start = Clock::now();
  const auto keyframe = cache_.get(ref);
  ++result->timing.checks;
  std::optional<RepeatEstimate> found;
  if (!keyframe) {
    result->problems.push_back(keyframe.status().message());
  } else {
    const KeyframeEstimator& estimator = *estimators_.at(ref.route);
    std::vector<const KeyframeReference*> views{&(*keyframe)->taught};
    for (const KeyframeReference& e : (*keyframe)->experiences) views.push_back(&e);
    for (const KeyframeReference* view : views) {
      if (!estimator.usable(*view, (*keyframe)->position, std::nullopt)) continue;
      auto estimate = estimator.estimate(*view, (*keyframe)->position, frame, std::nullopt);
      if (estimate && estimate->has_pose && estimate->covariance_known && nearKeyframe(ref, estimate->base_pose)) {
        found = std::move(*estimate);
        break;
      }
    }
  }
  result->timing.checks_ms += millisecondsSince(start);
  return found;
}

bool MapRelocalizer::nearKeyframe(const KeyframeRef& ref, const Pose2D& base_pose) const {
  const auto keyframe = map_->keyframePose(ref);
  return keyframe && std::hypot(base_pose.x - keyframe->x, base_pose.y - keyframe->y) <= options_.max_place_distance;
}

void MapRelocalizer::checkHypotheses(const FrameObservations& frame, const std::vector<KeyframeRef>& targets,
                                     Relocalization* result) {
  for (std::size_t i = 0; i < hypotheses_.size(); ++i) {
    PlaceHypothesis& h = hypotheses_[i];
    const auto estimate = check(targets[i], frame, result);
    if (estimate && agrees(h.base_pose, estimate->base_pose, h.driven_since_support)) {
      h.keyframe = targets[i];
      h.base_pose = estimate->base_pose;
      h.covariance = estimate->covariance;
      h.inliers = estimate->inliers;
      ++h.support;
      h.misses = 0;
      h.driven_since_support = 0.0;
    } else {
      ++h.misses;
    }
  }
  hypotheses_.erase(std::remove_if(hypotheses_.begin(), hypotheses_.end(),
                                   [&](const PlaceHypothesis& h) { return h.misses > options_.max_misses; }),
                    hypotheses_.end());
  // Two hypotheses of one route that now agree are one (keep the better supported).
  std::stable_sort(hypotheses_.begin(), hypotheses_.end(), [](const PlaceHypothesis& a, const PlaceHypothesis& b) {
    return a.support != b.support ? a.support > b.support : a.inliers > b.inliers;
  });
  std::vector<PlaceHypothesis> kept;
  for (const PlaceHypothesis& h : hypotheses_) {
    const bool duplicate = std::any_of(kept.begin(), kept.end(), [&](const PlaceHypothesis& k) {
      return k.keyframe.route == h.keyframe.route && agrees(k.base_pose, h.base_pose, 0.0);
    });
    if (!duplicate) kept.push_back(h);
  }
  hypotheses_ = std::move(kept);
}

Expected<std::vector<KeyframeRef>> MapRelocalizer::selectProposals(const cv::Mat& descriptors,
                                                                   const std::vector<KeyframeRef>& targets,
                                                                   RelocalizationTiming* timing) {
  auto refs = proposals(descriptors, timing);
  if (!refs) return refs.status();
  // Near (within 2 keyframes of) a place already being checked: the same view, nothing new.
  const auto near = [&](const KeyframeRef& a, const KeyframeRef& b) {
    return a.route == b.route && std::abs(map_->keyframePosition(a) - map_->keyframePosition(b)) <= 2;
  };
  std::vector<KeyframeRef> selected;
  for (const KeyframeRef& ref : *refs) {
    if (selected.size() >= static_cast<std::size_t>(options_.checks_per_frame)) break;
    const auto failed = failed_at_frame_.find(toString(ref));
    if (failed != failed_at_frame_.end() && frame_ - failed->second <= options_.retry_after_frames) continue;
    const auto is_near = [&](const KeyframeRef& other) { return near(ref, other); };
    if (std::any_of(targets.begin(), targets.end(), is_near) || std::any_of(selected.begin(), selected.end(), is_near)) {
      continue;
    }
    selected.push_back(ref);
  }
  return selected;
}

void MapRelocalizer::checkProposals(const FrameObservations& frame, const std::vector<KeyframeRef>& selected,
                                    Relocalization* result) {
  for (const KeyframeRef& ref : selected) {
    const auto estimate = check(ref, frame, result);
    if (!estimate) {
      failed_at_frame_[toString(ref)] = frame_;
      continue;
    }
    PlaceHypothesis h;
    h.keyframe = ref;
    h.base_pose = estimate->base_pose;
    h.covariance = estimate->covariance;
    h.inliers = estimate->inliers;
    h.support = 1;
    const bool known = std::any_of(hypotheses_.begin(), hypotheses_.end(), [&](const PlaceHypothesis& k) {
      return k.keyframe.route == h.keyframe.route && agrees(k.base_pose, h.base_pose, 0.0);
    });
    if (!known) hypotheses_.push_back(h);
  }
}

Expected<std::vector<KeyframeRef>> MapRelocalizer::proposals(const cv::Mat& descriptors, RelocalizationTiming* timing) const {
  if (hint_) {
    return nearestKeyframes(hint_->route, hint_->pose, static_cast<std::size_t>(options_.candidates), options_.hint_radius);
  }
  const auto start = Clock::now();
  std::vector<KeyframeRef> refs;
  if (!descriptors.empty()) {
    const auto candidates = index_->query(descriptors, options_.candidates);
    if (!candidates) return candidates.status();
    for (const PlaceCandidate& c : *candidates) refs.push_back(keyframeOf(*index_, c));
  }
  timing->query_ms = millisecondsSince(start);
  return refs;
}

std::vector<KeyframeRef> MapRelocalizer::nearestKeyframes(const std::string& route, const Pose2D& pose, std::size_t count,
                                                          double radius) const {
  const MapRoute* r = map_->find(route);
  if (r == nullptr) return {};
  std::vector<std::pair<double, int>> scored;
  for (const RouteKeyframe& k : r->route.keyframes) {
    const double distance = std::hypot(k.pose.x - pose.x, k.pose.y - pose.y);
    if (distance > radius) continue;
    scored.emplace_back(distance + std::abs(wrapToPi(k.pose.yaw - pose.yaw)), k.index);
  }
  const std::size_t n = std::min(count, scored.size());
  std::partial_sort(scored.begin(), scored.begin() + static_cast<std::ptrdiff_t>(n), scored.end());
  std::vector<KeyframeRef> refs;
  for (std::size_t i = 0; i < n; ++i) refs.push_back(KeyframeRef{route, scored[i].second});
  return refs;
}

bool MapRelocalizer::agrees(const Pose2D& predicted, const Pose2D& measured, double driven) const {
  const double distance = std::hypot(measured.x - predicted.x, measured.y - predicted.y);
  return distance <= options_.gate_distance + options_.gate_distance_per_metre * driven &&
         std::abs(wrapToPi(measured.yaw - predicted.yaw)) <= options_.gate_yaw;
}

bool MapRelocalizer::samePlace(const PlaceHypothesis& a, const PlaceHypothesis& b) const {
  if (a.keyframe.route == b.keyframe.route) return agrees(a.base_pose, b.base_pose, 0.0);
  for (const Junction& j : map_->junctions) {
    const bool a_to_b = j.from.route == a.keyframe.route && j.to.route == b.keyframe.route;
    const bool b_to_a = j.from.route == b.keyframe.route && j.to.route == a.keyframe.route;
    if (!a_to_b && !b_to_a) continue;
    const auto to_frame_in_from = junctionRouteTransform(*map_, j);
    if (!to_frame_in_from) continue;
    const PlaceHypothesis& in_from = a_to_b ? a : b;
    const PlaceHypothesis& in_to = a_to_b ? b : a;
    const Pose2D carried = to_frame_in_from->compose(in_to.base_pose);
    // A junction's small heading error grows with the distance from it.
    const Pose2D junction_point =
        map_->find(j.from.route)->route.keyframes[static_cast<std::size_t>(map_->keyframePosition(j.from))].pose;
    const double away = std::hypot(carried.x - junction_point.x, carried.y - junction_point.y);
    if (agrees(in_from.base_pose, carried, away)) return true;
  }
  return false;
}

void MapRelocalizer::judge(Relocalization* result) {
  std::stable_sort(hypotheses_.begin(), hypotheses_.end(), [](const PlaceHypothesis& a, const PlaceHypothesis& b) {
    return a.support != b.support ? a.support > b.support : a.inliers > b.inliers;
  });
  if (hypotheses_.size() > static_cast<std::size_t>(options_.max_hypotheses)) {
    hypotheses_.resize(static_cast<std::size_t>(options_.max_hypotheses));
  }
  result->hypotheses = hypotheses_;
  if (hypotheses_.empty()) {
    result->state = RelocalizationState::kSearching;
    result->reason = "no keyframe checked so far gives a pose";
    return;
  }
  const PlaceHypothesis& best = hypotheses_.front();
  std::vector<const PlaceHypothesis*> rivals;
  for (std::size_t i = 1; i < hypotheses_.size(); ++i) {
    if (!samePlace(best, hypotheses_[i])) rivals.push_back(&hypotheses_[i]);
  }
  const std::string best_text = toString(best.keyframe) + " (supported in " + std::to_string(best.support) + " frames)";
  if (!rivals.empty()) {
    result->state = RelocalizationState::kAmbiguous;
    result->reason = std::to_string(rivals.size() + 1) + " places fit: " + best_text;
    for (const PlaceHypothesis* r : rivals) {
      result->reason += ", " + toString(r->keyframe) + " (" + std::to_string(r->support) + ")";
    }
    return;
  }
  const bool moved = best.driven >= options_.confirmation_distance || best.turned >= options_.confirmation_turn;
  if (best.support >= options_.confirmations && moved) {
    result->state = RelocalizationState::kConfirmed;
    result->place = best;
    result->reason = best_text + " over " + formatFixed(best.driven, 2) + " m and " + formatFixed(best.turned, 2) + " rad";
    return;
  }
  result->state = RelocalizationState::kTentative;
  result->reason = best_text + "; confirmed after " + std::to_string(options_.confirmations) + " frames and " +
                   formatFixed(options_.confirmation_distance, 2) + " m or " + formatFixed(options_.confirmation_turn, 2) +
                   " rad (now " + formatFixed(best.driven, 2) + " m, " + formatFixed(best.turned, 2) + " rad)";
}

}  // namespace homography_teach_repeat
