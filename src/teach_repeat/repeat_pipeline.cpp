#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <utility>

namespace homography_teach_repeat {
void RepeatPipelineOptions::validate() const {
  localization.validate();
  mu_filter.validate();
  if (odometry_gate) odometry_gate->validate();
  if (start_keyframe < -1) throw std::invalid_argument("start_keyframe must be >= -1");
  if (!std::isfinite(max_unaided_distance) || max_unaided_distance < 0.0) {
    throw std::invalid_argument("max_unaided_distance must be finite and >= 0");
  }
  if (!std::isfinite(follow_odometry_distance) || follow_odometry_distance < 0.0) {
    throw std::invalid_argument("follow_odometry_distance must be finite and >= 0");
  }
  if (search_all_after < 0) throw std::invalid_argument("search_all_after must be >= 0");
  if (!std::isfinite(shift_heading_period) || shift_heading_period < 0.0) {
    throw std::invalid_argument("shift_heading_period must be finite and >= 0");
  }
  shift_heading_options.validate();
  if (!std::isfinite(fast_hd_retry_period) || fast_hd_retry_period < 0.0) {
    throw std::invalid_argument("fast_hd_retry_period must be finite and >= 0");
  }
  integrity.validate();
}

Expected<RepeatPipeline::Localizers> RepeatPipeline::createLocalizers(const Route& route, const RepeatOptions& options,
                                                                      bool skip_turn_keyframes) {
  if (options.mode != RepeatMode::kHybrid) {
    auto localizer = RepeatLocalizer::create(route, options);
    if (!localizer) return localizer.status();
    return Localizers{std::move(*localizer), std::nullopt, ""};
  }
  // hybrid: Fast-HD where the route has planes, μ where it has vertical lines.
  bool any_plane = false;
  for (const auto& keyframe : route.keyframes) any_plane = any_plane || keyframe.plane.has_value();
  RepeatOptions points = options;
  points.mode = RepeatMode::kFastHd;
  points.require_planes = false;
  points.skip_turn_keyframes_for_poses = skip_turn_keyframes;
  RepeatOptions lines = options;
  lines.mode = RepeatMode::kMu;
  std::optional<RepeatLocalizer> point_localizer, line_localizer;
  std::string notes;
  if (any_plane) {
    auto created = RepeatLocalizer::create(route, points);
    if (created) {
      point_localizer.emplace(std::move(*created));
    } else {
      notes = "no Fast-HD poses: " + created.status().message();
    }
  } else {
    notes = "no Fast-HD poses: the route has no planes (taught without plane estimation)";
  }
  auto created = RepeatLocalizer::create(route, lines);
  std::size_t line_count = 0;
  if (created) {
    for (int k = 0; k < created->keyframeCount(); ++k) line_count += created->reference(k).lines.size();
  }
  if (created && line_count > 0) {
    line_localizer.emplace(std::move(*created));
  } else {
    notes += (notes.empty() ? "" : "; ") +
             ("no mu fixes: " + (created ? std::string("the route has no vertical lines") : created.status().message()));
  }
  if (!point_localizer && !line_localizer) {
    return Status(StatusCode::kInvalidInput, "hybrid mode: the route offers neither planes nor vertical lines (" + notes + ")");
  }
  if (!point_localizer) return Localizers{std::move(*line_localizer), std::nullopt, notes};
  return Localizers{std::move(*point_localizer), std::move(line_localizer), notes};
}

Expected<RepeatPipeline> RepeatPipeline::create(const Route& route, const RepeatPipelineOptions& options) {
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  auto localizers = createLocalizers(route, options.localization, options.hybrid_skip_turn_keyframes);
  if (!localizers) return localizers.status();
  if (options.start_keyframe >= localizers->primary.keyframeCount()) {
    return Status(StatusCode::kInvalidInput, "start_keyframe " + std::to_string(options.start_keyframe) +
                                                 " but the route has " +
                                                 std::to_string(localizers->primary.keyframeCount()) + " keyframes");
  }
  return RepeatPipeline(std::move(*localizers), options);
}

RepeatPipeline::RepeatPipeline(Localizers localizers, const RepeatPipelineOptions& options)
    : localizer_(std::move(localizers.primary)),
      line_localizer_(std::move(localizers.lines)),
      hybrid_notes_(std::move(localizers.notes)),
      options_(options),
      integrity_(options.integrity),
      filter_(options.mu_filter) {
  if (options_.odometry_gate) odometry_gate_.emplace(*options_.odometry_gate);
  makeShiftHeadingIfUsed();
  if (options_.start_keyframe >= 0) {
    localizer_.setTrackedKeyframe(options_.start_keyframe);
    if (line_localizer_) line_localizer_->setTrackedKeyframe(options_.start_keyframe);
    initialized_ = true;
  }
}

bool RepeatPipeline::usesFilter() const { return mode() == RepeatMode::kMu || mode() == RepeatMode::kHybrid; }

Status RepeatPipeline::addOdometry(double stamp, const Pose2D& odom) { return odometry_.add(stamp, odom); }

Status RepeatPipeline::reconfigure(const RepeatOptions& options) {
  auto localizers = createLocalizers(localizer_.route(), options, options_.hybrid_skip_turn_keyframes);
  if (!localizers) return localizers.status();
  const int tracked = localizer_.trackedKeyframe();
  localizer_ = std::move(localizers->primary);
  localizer_.setTrackedKeyframe(tracked);
  line_localizer_ = std::move(localizers->lines);
  if (line_localizer_) line_localizer_->setTrackedKeyframe(tracked);
  hybrid_notes_ = std::move(localizers->notes);
  options_.localization = options;
  makeShiftHeadingIfUsed();  // (e.g. fast_hd → hybrid or mu: made on the first switch to a filter mode)
  return Status::ok();
}

void RepeatPipeline::makeShiftHeadingIfUsed() {
  if (options_.shift_heading && usesFilter() && !shift_heading_) {
    shift_heading_.emplace(localizer_.route(), localizer_.camera(), options_.shift_heading_options);
  }
}

RepeatFrameResult RepeatPipeline::processFrame(double stamp, const Expected<cv::Mat>& image,
                                               const Expected<PinholeCamera>& camera) {
  ++statistics_.frames;
  RepeatFrameResult result;
  const bool mu = usesFilter();
  // A frame without an estimate; in the filter modes the filter still gives a pose for a while.
  auto fail = [&](const Status& status) {
    ++statistics_.failures;
    ++statistics_.failures_in_a_row;
    statistics_.last_status = status;
    result.status = status;
    result.estimate.reset();
    if (mu) {
      addUnaidedFilterPose(stamp, &result);
    } else {
      followOdometry(odometry_.poseNear(stamp, kOdometryLag));
    }
    assessIntegrity(stamp, &result);
    return result;
  };
  if (!camera) return fail(camera.status());
  const PinholeCamera& taught = localizer_.camera();
  if (camera->width() != taught.width() || camera->height() != taught.height()) {
    return fail(Status(StatusCode::kInvalidInput,
                       "camera_info is " + std::to_string(camera->width()) + "x" + std::to_string(camera->height()) +
                           ", the route was taught at " + std::to_string(taught.width()) + "x" +
                           std::to_string(taught.height())));
  }
  if (!image) return fail(image.status());
  if (mode() == RepeatMode::kHybrid) return processHybridFrame(stamp, *image);
  // The odometry at the image stamp is looked up once for every pose of this frame.
  const auto odom_near_image = odometry_.poseNear(stamp, kOdometryLag);
  // fast_hd/classic: the search starts at the keyframe nearest where the odometry has carried the
  // robot since the last pose, as hybrid's starts at the filter's prediction, not at the last
  // pose's keyframe (docs/reliability.md, "Lost and found").
  if (!mu) followOdometry(odom_near_image);
  bool search_all = false;
  const int tracked_before = localizer_.trackedKeyframe();
  auto estimate = localizeWithGate(*image, odom_near_image, predictedFilterPose(stamp), &search_all);
  result.timing = localizer_.lastTiming();
  // A whole-route search that found nothing acceptable must not leave tracking on its best guess.
  // mu: a frame whose lines give no fix takes the seasonal heading fix instead (hybrid's step 3).
  auto failSearch = [&](const Status& status) {
    if (search_all) localizer_.setTrackedKeyframe(tracked_before);
    if (mode() != RepeatMode::kMu || !shift_heading_) return fail(status);
    result.estimate.reset();
    const Status shifted = correctWithShiftHeading(stamp, *image, &result);
    if (!shifted.isOk()) return fail(Status(status.code(), status.message() + "; shift: " + shifted.message()));
    finishFilterFix(stamp, &result);
    return result;
  };
  if (!estimate) return failSearch(estimate.status());
  if (estimate->has_pose) {
    Status gated = gate(odom_near_image, *estimate, &result.warning);
    if (!gated.isOk()) {
      ++statistics_.gated;
      recordFix(stamp, false, estimate->inliers);
      return failSearch(gated);
    }
    recordFix(stamp, true, estimate->inliers);
    if (search_all) ++statistics_.found_by_search_all;
  } else {
    // mu: the fix corrects the filter; refused by it (kNoConsensus: its innovation gate, or no
    // confirmation by the previous frame) or without odometry it is a failed frame.
    const Status corrected = correctMuFilter(stamp, &*estimate);
    recordFix(stamp, corrected.isOk(), estimate->inliers);
    if (!corrected.isOk()) {
      if (corrected.code() == StatusCode::kNoConsensus) ++statistics_.gated;
      return failSearch(corrected);
    }
    result.fixes = estimate->line_landmark_fix ? "lines" : "mu";
  }
  initialized_ = true;
  statistics_.failures_in_a_row = 0;
  statistics_.last_status = Status::ok();
  statistics_.last_inliers = estimate->inliers;
  statistics_.last_degraded = estimate->degraded;
  statistics_.last_keyframe = estimate->keyframe;
  if (estimate->degraded) ++statistics_.degraded;
  result.estimate = *estimate;
  if (estimate->has_pose) {
    result.pose = estimate->base_pose;
    if (estimate->covariance_known) result.covariance = estimate->covariance;
    // (No odometry at the stamp: no alignment; a node that publishes it says so.)
    const auto odom = odometry_.poseAt(stamp);
    if (odom) {
      result.map_to_odom = estimate->base_pose.compose(odom->inverse());
      last_alignment_ = result.map_to_odom;
      last_fix_odometry_ = *odom;
    }
    assessIntegrity(stamp, &result);
    return result;
  }
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);  // found by correctMuFilter
  const auto pose = filter_.routePose(*odom);
  if (!pose) return fail(pose.status());
  setFilterPose(*pose, &result);
  assessIntegrity(stamp, &result);
  return result;
}

RepeatFrameResult RepeatPipeline::processHybridFrame(double stamp, const cv::Mat& image) {
  RepeatFrameResult result;
  const auto odom_near_image = odometry_.poseNear(stamp, kOdometryLag);
  // Where the filter says the robot is: both searches start there (the route says which
  // keyframes are near; after an outage the odometry has carried the robot on).
  if (const auto predicted = predictedFilterPose(stamp)) {
    localizer_.advanceTrackingTo(*predicted);
    if (line_localizer_) line_localizer_->advanceTrackingTo(*predicted);
  }
  std::string reasons;
  auto note = [&](const std::string& what, const Status& status) {
    reasons += (reasons.empty() ? "" : "; ") + what + ": " + status.message();
  };
  const bool points = !primaryIsMu();
  // 1. Fast-HD (the primary localizer, when the route has planes).
  if (points && !fastHdSearchDue(stamp)) {
    char waited[128];
    std::snprintf(waited, sizeof(waited), "no search in this frame (the last one found no pose %.2f s ago; "
                  "fast_hd_retry_period %.2f s)", stamp - *last_failed_search_stamp_, options_.fast_hd_retry_period);
    note("fast_hd", Status(StatusCode::kNoConsensus, waited));
  } else if (points) {
    bool search_all = false;
    const int tracked_before = localizer_.trackedKeyframe();
    const auto estimate = localizeWithGate(image, odom_near_image, std::nullopt, &search_all);
    result.timing = localizer_.lastTiming();
    const Status fused = fuseHybridPose(stamp, odom_near_image, estimate, &result);
    if (fused.isOk()) {
      if (search_all) ++statistics_.found_by_search_all;
      last_failed_search_stamp_.reset();
    } else {
      if (search_all) localizer_.setTrackedKeyframe(tracked_before);
      note("fast_hd", fused);
      // Only a search that found nothing waits: a pose the gate or the filter refused was found
      // (and the gate's switch counts refusals); an image refused before any search (e.g. of the
      // wrong size) was no search.
      if (!estimate && estimate.status().code() != StatusCode::kInvalidInput) last_failed_search_stamp_ = stamp;
    }
  }
  // 2. μ (or line landmarks): where there is no pose, or beside it (hybrid_fuse_both).
  RepeatLocalizer* lines = points ? (line_localizer_ ? &*line_localizer_ : nullptr) : &localizer_;
  if (lines != nullptr && (result.fixes.empty() || options_.hybrid_fuse_both)) {
    auto estimate = lines->localize(image, predictedFilterPose(stamp));
    if (!points) result.timing = lines->lastTiming();
    Status corrected = estimate ? correctMuFilter(stamp, &*estimate, !result.fixes.empty()) : estimate.status();
    // A μ fix refused beside an accepted Fast-HD pose says nothing against that pose.
    if (estimate && (corrected.isOk() || result.fixes.empty())) {
      recordFix(stamp, corrected.isOk(), estimate->inliers);
    } else {
      filter_.takeInnovation();
    }
    if (corrected.isOk()) {
      result.fixes += std::string(result.fixes.empty() ? "" : "+") + (estimate->line_landmark_fix ? "lines" : "mu");
      if (!result.estimate) result.estimate = *estimate;
      initialized_ = true;
    } else {
      if (corrected.code() == StatusCode::kNoConsensus && estimate) ++statistics_.gated;
      note(estimate && estimate->line_landmark_fix ? "lines" : "mu", corrected);
    }
  }
  // 3. The seasonal heading fix, where neither gave one.
  if (result.fixes.empty() && shift_heading_) {
    const Status shifted = correctWithShiftHeading(stamp, image, &result);
    if (!shifted.isOk()) note("shift", shifted);
  }
  if (result.fixes.empty()) {
    // No fix: the filter carries the pose on odometry (within max_unaided_distance).
    ++statistics_.failures;
    ++statistics_.failures_in_a_row;
    const Status failed(StatusCode::kNoConsensus, reasons.empty() ? "no measurement in this frame" : reasons);
    statistics_.last_status = failed;
    result.status = failed;
    addUnaidedFilterPose(stamp, &result);
    assessIntegrity(stamp, &result);
    return result;
  }
  finishFilterFix(stamp, &result);
  return result;
}

void RepeatPipeline::finishFilterFix(double stamp, RepeatFrameResult* result) {
  statistics_.failures_in_a_row = 0;
  statistics_.last_status = Status::ok();
  statistics_.last_inliers = result->estimate->inliers;
  statistics_.last_degraded = result->estimate->degraded;
  statistics_.last_keyframe = result->estimate->keyframe;
  if (result->estimate->degraded) ++statistics_.degraded;
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);
  const auto pose = odom ? filter_.routePose(*odom) : Expected<Pose2D>(odom.status());
  if (pose) {
    setFilterPose(*pose, result);
  } else {
    result->warning = "no pose: " + pose.status().message();
  }
  assessIntegrity(stamp, result);
}

Expected<RepeatEstimate> RepeatPipeline::localizeWithGate(const cv::Mat& image, const Expected<Pose2D>& odom_near_image,
                                                          const std::optional<Pose2D>& predicted, bool* search_all) {
  // The odometry gate's verdict on each reference's pose, inside the localizer: a pose it would
  // refuse from one keyframe lets the neighbour try (repeat_localizer.h). The pose returned is then
  // gated for real by the caller (accepted, or refused and counted towards a switch of reference).
  const RepeatLocalizer::PoseCheck would_pass = [&](const RepeatEstimate& candidate) {
    return odometry_gate_ && odom_near_image ? odometry_gate_->agrees(candidate.base_pose, *odom_near_image)
                                             : Status::ok();
  };
  *search_all = initialized_ && searchAllNow();
  if (*search_all) ++statistics_.searches_all;
  return initialized_ && !*search_all ? localizer_.localize(image, predicted, would_pass)
                                      : localizer_.initializeGlobally(image);
}

bool RepeatPipeline::fastHdSearchDue(double stamp) const {
  if (!last_failed_search_stamp_) return true;
  const double since = stamp - *last_failed_search_stamp_;
  // (A stamp before the failed search's: time went back, e.g. a bag played again.)
  return !(since >= 0.0 && since < options_.fast_hd_retry_period) || (initialized_ && searchAllNow());
}

bool RepeatPipeline::searchAllNow() const {
  const int every = options_.search_all_after;
  const auto failed = static_cast<int>(statistics_.failures_in_a_row);
  // (mu: the filter carries the pose, and a line landmark estimate matches every keyframe.)
  return every > 0 && failed >= every && failed % every == 0 && localizer_.keyframeCount() > 1 && !primaryIsMu();
}

void RepeatPipeline::followOdometry(const Expected<Pose2D>& odom) {
  if (!odom || !last_alignment_ || !last_fix_odometry_ || !(options_.follow_odometry_distance > 0.0)) return;
  // Straight-line distance since the fix: a bound on the path travelled from below, so the
  // tracking may follow a little further than the option says on a winding path, never less.
  const Pose2D moved = last_fix_odometry_->inverse().compose(*odom);
  if (std::hypot(moved.x, moved.y) > options_.follow_odometry_distance) return;
  localizer_.advanceTrackingTo(last_alignment_->compose(*odom));
}

}  // namespace homography_teach_repeat
