#include "homography_teach_repeat/teach_repeat/repeat_localizer.h"

#include <chrono>
#include <string>
#include <utility>

#include "homography_teach_repeat/fast_hd/plane_estimation.h"

namespace homography_teach_repeat {
namespace {

// The fraction of the remembered inliers (the previous frame's, or a background detection's) that
// must stay inliers in the current frame after one optical-flow step; fewer: the frame detects its
// own features. Followed over frames far apart, the inliers are lost or misplaced (KITTI 07's repeat
// frames, 0.5-1 m apart: 45-85 % kept, and poses from 70-85 % up to 0.2 m off where detected ones
// were 5 cm); frames close together keep nearly all (the synthetic drive at 30 Hz: 97-99 %).
constexpr double kMinKeptFraction = 0.9;

double millisecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
}

// The plane of a reference and its uncertainty, without its features.
KeyframeReference planeOf(const KeyframeReference& reference) {
  KeyframeReference plane_only;
  plane_only.plane = reference.plane;
  plane_only.plane_normal_sigma_rad = reference.plane_normal_sigma_rad;
  plane_only.plane_distance_sigma = reference.plane_distance_sigma;
  plane_only.neighbour_fix_error_per_m2 = reference.neighbour_fix_error_per_m2;
  plane_only.neighbour_fix_heading_floor_rad = reference.neighbour_fix_heading_floor_rad;
  return plane_only;
}

// The caller's verdict on an estimate: only poses are checked (a μ fix is the filter's to judge).
Status vet(const RepeatLocalizer::PoseCheck& check, const RepeatEstimate& estimate) {
  if (!check || !estimate.has_pose) return Status::ok();
  return check(estimate);
}

}  // namespace

RepeatLocalizer::RepeatLocalizer(const Route& route, KeyframeStore keyframes, std::unique_ptr<KeyframeEstimator> estimator)
    : route_(route),
      keyframes_(std::move(keyframes)),
      estimator_(std::move(estimator)),
      selector_(keyframes_.poses(), estimator_->context().options.closed_route_gap),
      tracker_(estimator_->context().options.max_tracked_frames, estimator_->context().options.tracking_tolerance_px,
               estimator_->context().options.min_inliers) {}

bool RepeatLocalizer::backgroundDetectionOn() const {
  const RepeatOptions& o = estimator_->context().options;
  return o.background_detection && o.max_tracked_frames > 0 && estimator_->usesPointFeatures();
}

Expected<RepeatLocalizer> RepeatLocalizer::create(const Route& route, const RepeatOptions& configured) {
  const RepeatOptions options = withMeasuredNoise(configured, route);
  auto keyframes = KeyframeStore::load(route, options);  // validates the options
  if (!keyframes) return keyframes.status();
  const EstimatorContext context{PinholeCamera(route.info.camera), route.info.feature_type, route.info.camera_mount,
                                 keyframes->poses(), options};
  return RepeatLocalizer(route, std::move(*keyframes), makeKeyframeEstimator(context));
}

void RepeatLocalizer::setTrackedKeyframe(int keyframe) {
  selector_.setTracked(keyframe);
  tracker_.forget();
  background_.discard();
}

bool RepeatLocalizer::isTurnKeyframe(int keyframe) const {
  return keyframe >= 0 && keyframe < keyframeCount() && keyframes_.at(keyframe).turn;
}

Expected<RepeatEstimate> RepeatLocalizer::localize(const cv::Mat& image, std::optional<Pose2D> predicted_pose,
                                                   const PoseCheck& check) {
  timing_ = LocalizeTiming();
  const auto extraction_start = std::chrono::steady_clock::now();
  if (image.empty()) return Status(StatusCode::kInvalidInput, "image is empty");
  if (image.cols != camera().width() || image.rows != camera().height()) {
    return Status(StatusCode::kInvalidInput, "image is " + std::to_string(image.cols) + "x" + std::to_string(image.rows) +
                                                 ", the route's camera is " + std::to_string(camera().width()) + "x" +
                                                 std::to_string(camera().height()));
  }
  cv::Mat gray;  // point modes: the grey image, kept for tracking
  if (estimator_->usesPointFeatures()) {
    auto converted = toGray8(image);
    if (!converted) return converted.status();
    gray = std::move(*converted);
    background_.frameSeen();
    // While the worker detects, tracking goes on against the keyframe its matches are of, even
    // where the robot is nearer the next one (that pose is as valid; waiting for the worker is
    // not). Its features are taken in max_tracked_frames + 1 frames after the frame they are of
    // (the rate of detections without a worker), or where tracking cannot go on.
    const bool waiting = background_.pending();
    const bool can_track = tracker_.canTrack(waiting ? tracker_.keyframe() : selector_.tracked());
    if (waiting && (!can_track || background_.framesSince() > options().max_tracked_frames)) {
      auto estimate = localizeFromBackground(gray, check);
      if (estimate) {
        startBackgroundDetection(gray, predicted_pose);
        return estimate;
      }
    } else if (can_track) {
      auto estimate = localizeByTracking(gray, check);
      if (estimate) {
        if (backgroundDetectionOn() && !background_.pending()) startBackgroundDetection(gray, predicted_pose);
        return estimate;
      }
    }
    // Detect afresh (the time spent on tracking counts as extraction).
    tracker_.forget();
    background_.discard();
  }
  auto frame = estimator_->observe(image, gray);
  if (!frame) return frame.status();
  timing_.extraction_ms = millisecondsSince(extraction_start);
  return localizeAgainstCandidates(*frame, gray, predicted_pose, options().neighbour_search,
                                   options().max_degraded_frames, check);
}

Expected<RepeatEstimate> RepeatLocalizer::localizeAgainstCandidates(const FrameObservations& frame, const cv::Mat& gray,
                                                                    const std::optional<Pose2D>& predicted_pose,
                                                                    int neighbour_search, int max_degraded_frames,
                                                                    const PoseCheck& check) {
  const auto references_start = std::chrono::steady_clock::now();
  auto against = [&](const KeyframeReference& reference, int keyframe) {
    ++timing_.references_tried;
    auto estimate = estimator_->estimate(reference, keyframe, frame, predicted_pose);
    timing_.references_ms = millisecondsSince(references_start);
    return estimate;
  };
  std::vector<int> candidates;
  for (const int k : selector_.candidates(neighbour_search)) {
    if (estimator_->usable(keyframes_.at(k), k, predicted_pose)) candidates.push_back(k);
  }
  Status last_failure(StatusCode::kNoConsensus, "no reference keyframe tried");
  if (candidates.empty()) {
    last_failure = Status(StatusCode::kNoConsensus,
                          estimator_->usesPointFeatures()
                              ? "no keyframe near " + std::to_string(selector_.tracked()) + " has a plane (a pose needs one)"
                              : "mu: no keyframe near " + std::to_string(selector_.tracked()) +
                                    " gives a heading fix here (turned in place, or facing more than " +
                                    std::to_string(options().mu_max_reference_angle) + " rad away)");
  }
  // The first estimate the check refused, with the view it was made against: returned when no
  // other reference gives one it accepts (the caller decides about it, as without a check).
  std::optional<std::pair<RepeatEstimate, const KeyframeReference*>> first_refused;
  auto use = [&](RepeatEstimate estimate, const KeyframeReference& view) -> Expected<RepeatEstimate> {
    keepAsTemporaryReference(frame, estimate, view);
    degraded_frames_ = 0;
    // Tracking follows the taught view's features only (an experience has its own).
    if (estimate.experience == 0) rememberForTracking(estimate, gray, 0);
    else tracker_.forget();
    advanceTracking(estimate);
    return estimate;
  };
  for (const int k : candidates) {
    // The taught view, then (when it fails or its pose is refused) the learned ones, newest first.
    std::vector<const KeyframeReference*> views{&keyframes_.at(k)};
    for (const KeyframeReference& e : keyframes_.experiences(k)) views.push_back(&e);
    for (const KeyframeReference* view : views) {
      auto estimate = against(*view, k);
      if (!estimate) {
        if (view->experience != 0) continue;  // the taught view's reason is the one to report
        // Every candidate's reason, nearest first: which keyframe failed how is what a user needs.
        const std::string reason = "keyframe " + std::to_string(k) + ": " + estimate.status().message();
        const bool first = k == candidates.front();
        last_failure = Status(first ? estimate.status().code() : last_failure.code(),
                              first ? reason : last_failure.message() + "; " + reason);
        continue;
      }
      const Status verdict = vet(check, *estimate);
      if (verdict.isOk()) return use(std::move(*estimate), *view);
      if (!first_refused) first_refused.emplace(std::move(*estimate), view);
    }
  }
  if (first_refused) return use(std::move(first_refused->first), *first_refused->second);
  const bool temporary_usable =
      temporary_ && estimator_->usable(*temporary_, temporary_keyframe_, predicted_pose);
  if (!temporary_usable || degraded_frames_ >= max_degraded_frames) return last_failure;
  auto estimate = against(*temporary_, temporary_keyframe_);
  if (!estimate) {
    return Status(estimate.status().code(),
                  "temporary reference: " + estimate.status().message() + "; " + last_failure.message());
  }
  estimate->degraded = true;
  ++degraded_frames_;
  if (estimate->has_pose) {
    // Chain: this frame is the next temporary reference (paper 000, outdoor experiment).
    const KeyframeReference source = planeOf(*temporary_);  // the next one replaces it
    keepAsTemporaryReference(frame, *estimate, source);
    estimate->heading_correction =
        wrapToPi(estimate->base_pose.yaw - route_.keyframes[static_cast<std::size_t>(temporary_keyframe_)].pose.yaw);
  }
  return estimate;
}

void RepeatLocalizer::keepAsTemporaryReference(FrameObservations frame, const RepeatEstimate& estimate,
                                               const KeyframeReference& source) {
  const std::optional<ScenePlane>& from_plane = source.plane;
  KeyframeReference current;
  current.lines = std::move(frame.lines);
  if (estimate.has_pose && !estimate.inlier_features.empty()) {
    // Only the features on the reference's plane: the frame's other features (clutter in front of
    // the wall, another wall) would be matched by the next frames too, and a parallel surface
    // nearer or farther than the plane gives a homography that the plane's distance scales into
    // a wrong pose passing every check (the simulator's room, a shelf before the west wall: 7 cm
    // off claiming 7 mm; docs/reliability.md, "Temporary reference").
    current.features = selectFeatures(frame.features, estimate.inlier_features);
  } else {
    current.features = std::move(frame.features);
  }
  if (estimate.has_pose) {
    // The frame's pose, and the reference's plane seen from it; without a plane it cannot serve.
    current.base_pose = estimate.base_pose;
    if (estimate.covariance_known) current.base_pose_covariance = estimate.covariance;
    if (!from_plane) return;
    const auto plane = transferPlane(*from_plane, estimate.camera_relative);
    if (!plane) return;
    current.plane = *plane;
    current.plane_normal_sigma_rad = source.plane_normal_sigma_rad;
    current.plane_distance_sigma = source.plane_distance_sigma;
    current.neighbour_fix_error_per_m2 = source.neighbour_fix_error_per_m2;
    current.neighbour_fix_heading_floor_rad = source.neighbour_fix_heading_floor_rad;
    current.pixel_noise_scale = source.pixel_noise_scale;
  } else {
    current.heading_offset = estimate.heading_correction;
  }
  if (!estimate.degraded) temporary_keyframe_ = estimate.keyframe;
  temporary_ = std::move(current);
}

void RepeatLocalizer::rememberForTracking(const RepeatEstimate& estimate, const cv::Mat& gray, int frames_tracked) {
  tracker_.forget();
  if (!estimate.has_pose || estimate.degraded) return;
  tracker_.remember(estimate.inlier_matches, estimate.keyframe, gray, frames_tracked);
}

Expected<RepeatEstimate> RepeatLocalizer::localizeByTracking(const cv::Mat& gray, const PoseCheck& check) {
  const auto start = std::chrono::steady_clock::now();
  const int remembered = tracker_.rememberedMatches();
  const auto followed = tracker_.track(gray);
  timing_.extraction_ms = millisecondsSince(start);
  if (!followed) return followed.status();
  const auto references_start = std::chrono::steady_clock::now();
  ++timing_.references_tried;
  const int keyframe = tracker_.keyframe();
  auto estimate = estimator_->estimateFromMatches(keyframes_.at(keyframe), keyframe, *followed);
  timing_.references_ms = millisecondsSince(references_start);
  if (!estimate) return estimate;
  estimate->tracked = true;
  if (estimate->inliers < kMinKeptFraction * remembered) {
    return Status(StatusCode::kNoConsensus, "tracking: " + std::to_string(estimate->inliers) + " of " +
                                                std::to_string(remembered) +
                                                " remembered inliers followed into this frame (the frames are too far apart)");
  }
  const Status verdict = vet(check, *estimate);
  if (!verdict.isOk()) return verdict;
  timing_.tracked = true;
  degraded_frames_ = 0;
  rememberForTracking(*estimate, gray, tracker_.framesTracked() + 1);
  advanceTracking(*estimate);
  return estimate;
}

Expected<RepeatEstimate> RepeatLocalizer::localizeFromBackground(const cv::Mat& gray, const PoseCheck& check) {
  BackgroundDetection::Result detected = background_.take();
  timing_.extraction_ms = detected.waited_ms;
  if (!detected.observations) return detected.observations.status();
  tracker_.forget();
  // Against the keyframes only (no temporary reference: that frame is past). Its pose is not the
  // current one, so the caller's check waits for the pose followed into this frame.
  const auto earlier = localizeAgainstCandidates(*detected.observations, detected.gray, detected.predicted_pose,
                                                 options().neighbour_search, 0, {});
  if (!earlier) return earlier.status();
  if (tracker_.keyframe() < 0) {
    return Status(StatusCode::kNoConsensus, "background detection: the frame's estimate gives no matches to follow");
  }
  // The step into this frame is the detection's own: max_tracked_frames tracked frames follow it.
  tracker_.setFramesTracked(-1);
  const LocalizeTiming before = timing_;
  auto estimate = localizeByTracking(gray, check);
  timing_.extraction_ms += before.extraction_ms;
  timing_.references_ms += before.references_ms;
  timing_.references_tried += before.references_tried;
  if (!estimate) return Status(estimate.status().code(), "background detection: " + estimate.status().message());
  timing_.background = true;
  return estimate;
}

void RepeatLocalizer::startBackgroundDetection(const cv::Mat& gray, const std::optional<Pose2D>& predicted_pose) {
  KeyframeEstimator* estimator = estimator_.get();  // owned by this localizer, which outlives the job
  background_.start([estimator](const cv::Mat& image) { return estimator->observe(image, image); }, gray,
                    predicted_pose);
}

void RepeatLocalizer::warmUpBackgroundDetection() {
  if (!backgroundDetectionOn()) return;
  cv::Mat noise(camera().height(), camera().width(), CV_8UC1);
  cv::RNG random(1);
  random.fill(noise, cv::RNG::UNIFORM, 0, 256);
  startBackgroundDetection(noise, std::nullopt);
  background_.discard();
}

void RepeatLocalizer::advanceTracking(const RepeatEstimate& estimate) {
  selector_.setTracked(estimate.keyframe);
  if (estimate.has_pose) selector_.advanceTo(estimate.base_pose);
}

Expected<RepeatEstimate> RepeatLocalizer::initializeGlobally(const cv::Mat& image) {
  background_.discard();  // the estimator is this thread's again
  if (image.empty()) return Status(StatusCode::kInvalidInput, "image is empty");
  auto gray = estimator_->usesPointFeatures() ? toGray8(image) : Expected<cv::Mat>(cv::Mat());
  if (!gray) return gray.status();
  auto frame = estimator_->observe(image, *gray);
  if (!frame) return frame.status();
  int best_keyframe = -1, best_inliers = -1;
  for (int k = 0; k < keyframeCount(); ++k) {
    setTrackedKeyframe(k);
    // This keyframe alone: no neighbours, no temporary reference.
    const auto estimate = localizeAgainstCandidates(*frame, *gray, std::nullopt, 0, 0, {});
    if (estimate && estimate->inliers > best_inliers) {
      best_inliers = estimate->inliers;
      best_keyframe = k;
    }
  }
  if (best_keyframe < 0) return Status(StatusCode::kNoConsensus, "the image matches no keyframe of the route");
  setTrackedKeyframe(best_keyframe);
  return localize(image);
}

}  // namespace homography_teach_repeat
