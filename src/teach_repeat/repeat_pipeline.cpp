#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <utility>

namespace homography_teach_repeat {
namespace {
// The odometry of an image's instant may arrive after the image (a simulator publishes both at
// once); for the odometry gate and the filter (its prediction, fixes and pose) the newest sample is
// close enough within this lag [s]. (With poseAt, a frame processed before its odometry had arrived
// got no pose at all in the simulator's hybrid runs: every other covered frame was LOST.)
constexpr double kOdometryLag = 0.1;
}  // namespace

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
  return Status::ok();
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
  bool search_all = false;
  const int tracked_before = localizer_.trackedKeyframe();
  auto estimate = localizeWithGate(*image, odom_near_image, predictedFilterPose(stamp), &search_all);
  result.timing = localizer_.lastTiming();
  // A whole-route search that found nothing acceptable must not leave tracking on its best guess.
  auto failSearch = [&](const Status& status) {
    if (search_all) localizer_.setTrackedKeyframe(tracked_before);
    return fail(status);
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
      return fail(corrected);
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
  if (points) {
    bool search_all = false;
    const int tracked_before = localizer_.trackedKeyframe();
    const auto estimate = localizeWithGate(image, odom_near_image, std::nullopt, &search_all);
    result.timing = localizer_.lastTiming();
    const Status fused = fuseHybridPose(stamp, odom_near_image, estimate, &result);
    if (fused.isOk()) {
      if (search_all) ++statistics_.found_by_search_all;
    } else {
      if (search_all) localizer_.setTrackedKeyframe(tracked_before);
      note("fast_hd", fused);
    }
  }
  // 2. μ (or line landmarks): where there is no pose, or beside it (hybrid_fuse_both).
  RepeatLocalizer* lines = points ? (line_localizer_ ? &*line_localizer_ : nullptr) : &localizer_;
  if (lines != nullptr && (result.fixes.empty() || options_.hybrid_fuse_both)) {
    auto estimate = lines->localize(image, predictedFilterPose(stamp));
    if (!points) result.timing = lines->lastTiming();
    Status corrected = estimate ? correctMuFilter(stamp, &*estimate) : estimate.status();
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
  statistics_.failures_in_a_row = 0;
  statistics_.last_status = Status::ok();
  statistics_.last_inliers = result.estimate->inliers;
  statistics_.last_degraded = result.estimate->degraded;
  statistics_.last_keyframe = result.estimate->keyframe;
  if (result.estimate->degraded) ++statistics_.degraded;
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);
  const auto pose = odom ? filter_.routePose(*odom) : Expected<Pose2D>(odom.status());
  if (pose) {
    setFilterPose(*pose, &result);
  } else {
    result.warning = "no pose: " + pose.status().message();
  }
  assessIntegrity(stamp, &result);
  return result;
}

Status RepeatPipeline::fuseHybridPose(double stamp, const Expected<Pose2D>& odom_near_image,
                                      const Expected<RepeatEstimate>& estimate, RepeatFrameResult* result) {
  if (!estimate) return estimate.status();
  if (!estimate->has_pose || !estimate->covariance_known) {
    return Status(StatusCode::kInvalidInput, "the estimate has no pose with a covariance");
  }
  Status gated = gate(odom_near_image, *estimate, &result->warning);
  if (!gated.isOk()) {
    ++statistics_.gated;
    integrity_.addFix(stamp, false, std::nullopt, 0, estimate->inliers);
    return gated;
  }
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);
  if (!odom) return Status(StatusCode::kInvalidInput, "hybrid mode needs odometry ('odom') at the image stamp: " + odom.status().message());
  // A first pose, or one the odometry gate took as its new reference (the old one was wrong):
  // the filter starts again from it (docs/math.md §7.1).
  const bool restart = !filter_.aligned() || (odometry_gate_ && odometry_gate_->switchedReference());
  if (restart) {
    Status aligned = filter_.align(estimate->base_pose, *odom, estimate->covariance);
    if (!aligned.isOk()) return aligned;
    integrity_.addFix(stamp, true, std::nullopt, 0, estimate->inliers);
  } else {
    const auto nis = filter_.correctWithPose(estimate->base_pose, estimate->covariance, *odom, estimate->model_covariance);
    const auto innovation = filter_.takeInnovation();
    if (!nis) {
      // Refused by the filter's gate: the pose disagrees with it beyond what both admit.
      if (nis.status().code() == StatusCode::kNoConsensus) ++statistics_.gated;
      if (innovation) integrity_.addFix(stamp, false, std::nullopt, 0, estimate->inliers);
      return nis.status();
    }
    integrity_.addFix(stamp, true, *nis, 3, estimate->inliers);
  }
  initialized_ = true;
  result->fixes = "fast_hd";
  result->estimate = *estimate;
  return Status::ok();
}

void RepeatPipeline::recordFix(double stamp, bool accepted, int inliers) {
  // The filter modes leave the innovation of the fix they tried (none for a fix the confirmation
  // rule held back or the consensus refused: those say nothing of the filter's consistency).
  const auto innovation = usesFilter() ? filter_.takeInnovation() : std::nullopt;
  if (innovation) {
    integrity_.addFix(stamp, accepted && innovation->accepted, innovation->nis, innovation->dof, inliers);
  } else if (!usesFilter() || accepted) {
    integrity_.addFix(stamp, accepted, std::nullopt, 0, inliers);
  }
}

void RepeatPipeline::assessIntegrity(double stamp, RepeatFrameResult* result) {
  const double distance = usesFilter() && filter_.aligned() ? filter_.distanceSinceFix()
                                                            : std::numeric_limits<double>::quiet_NaN();
  std::optional<Eigen::Matrix3d> covariance;
  if (result->pose) covariance = result->covariance ? *result->covariance : Eigen::Matrix3d(Eigen::Matrix3d::Zero());
  result->integrity = integrity_.assess(stamp, covariance, distance);
  if (result->pose && !result->covariance && result->integrity.level != IntegrityLevel::kLost) {
    // classic: a pose without a covariance cannot be judged by its bounds.
    result->integrity.level = IntegrityLevel::kDegraded;
    result->integrity.reason = "the pose has no covariance (classic mode)";
  }
}

Status RepeatPipeline::gate(const Expected<Pose2D>& odom, const RepeatEstimate& estimate, std::string* warning) {
  if (!odometry_gate_) return Status::ok();
  if (!odom) {
    *warning = "no odometry at the image stamp, the pose is not checked against odometry (odometry_gate): " +
               odom.status().toString();
    return Status::ok();
  }
  return odometry_gate_->check(estimate.base_pose, *odom);
}

Status RepeatPipeline::correctMuFilter(double stamp, RepeatEstimate* fix) {
  const RepeatEstimate& estimate = *fix;
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);
  if (!odom) {
    return Status(StatusCode::kInvalidInput,
                  toString(mode()) + " mode needs odometry ('odom') at the image stamp: " + odom.status().toString());
  }
  const RepeatLocalizer& lines = line_localizer_ ? *line_localizer_ : localizer_;
  const Route& route = lines.route();
  const RouteKeyframe& keyframe = route.keyframes[static_cast<std::size_t>(estimate.keyframe)];
  const double route_yaw = wrapToPi(keyframe.pose.yaw + estimate.heading_correction);
  const bool aligning = !filter_.aligned();
  if (aligning) {
    // The repeat run starts at the keyframe the robot was placed at (start_keyframe, or the best
    // match of the global initialization), with the heading vision measures there.
    Status aligned = filter_.align(Pose2D(keyframe.pose.x, keyframe.pose.y, route_yaw), *odom);
    if (!aligned.isOk()) return aligned;
  }
  if (estimate.line_landmark_fix) {
    Status corrected = correctWithLineLandmarks(*odom, fix);
    if (!corrected.isOk() && !aligning) return corrected;
    return Status::ok();
  }
  if (estimate.degraded) {
    // The temporary reference (the last good frame) has no wall and its pose is itself an
    // estimate; as a heading fix its μ put the lateral offset into the heading (measured in the
    // simulator: 15 cm off the path read as 4° and moved the estimate 13 cm the wrong way). No fix:
    // the odometry carries on, within max_unaided_distance.
    const auto pose = unaidedFilterPose(*odom);
    if (!pose) return Status(pose.status().code(), "only the temporary reference matched; " + pose.status().message());
    return Status::ok();
  }
  // A keyframe with a known wall gives the full μ model (heading and lateral offset); a keyframe
  // without a plane gives a heading-only fix.
  auto wall = muWallOf(keyframe.pose, keyframe.plane, route.info.camera_mount, lines.camera().fx(), estimate.keyframe);
  Status corrected;
  if (wall) {
    wall->mu = estimate.mu;
    wall->variance = 0.0;  // the filter's min_mu_variance
    corrected = filter_.correctWithMu(*wall, *odom);
  } else {
    corrected = filter_.correctHeading(route_yaw, *odom);
  }
  // The aligning frame's own fix only waits for the next frame's confirmation: it already gave the
  // heading.
  if (!corrected.isOk() && !aligning) return corrected;
  return Status::ok();
}

Status RepeatPipeline::correctWithLineLandmarks(const Pose2D& odom, RepeatEstimate* fix) {
  // The keyframe the localizer chose, then its neighbours ahead and behind: the filter's own
  // association decides which one's lines are in view.
  const RepeatLocalizer& lines = line_localizer_ ? *line_localizer_ : localizer_;
  const Route& route = lines.route();
  const int count = lines.keyframeCount();
  std::string reasons;
  Status last(StatusCode::kNoConsensus, "no keyframe with line landmarks near " + std::to_string(fix->keyframe));
  for (const int step : {0, 1, -1}) {
    int k = fix->keyframe + step;
    if (lines.closedRoute()) k = (k + count) % count;
    if (k < 0 || k >= count) continue;
    const KeyframeReference& reference = lines.reference(k);
    if (reference.line_landmarks.empty()) continue;
    LineLandmarkObservation observation;
    observation.reference_pose = reference.base_pose;
    observation.camera_mount = route.info.camera_mount;
    observation.lens = LineCamera{lines.camera().fx(), lines.camera().cx()};
    observation.image_width = lines.camera().width();
    observation.landmarks = reference.line_landmarks;
    observation.reference_lines = reference.lines;
    observation.current_lines = fix->current_lines;
    const auto used = filter_.correctWithLineLandmarks(observation, odom);
    if (used) {
      fix->keyframe = k;
      fix->inliers = *used;
      return Status::ok();
    }
    reasons += (reasons.empty() ? "" : "; ") + ("keyframe " + std::to_string(k) + ": " + used.status().message());
    last = Status(used.status().code(), reasons);
  }
  return last;
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

std::optional<Pose2D> RepeatPipeline::predictedFilterPose(double stamp) const {
  if (!usesFilter() || !filter_.aligned()) return std::nullopt;
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);
  if (!odom) return std::nullopt;
  const auto predicted = filter_.predictedPose(*odom);
  if (!predicted) return std::nullopt;
  return *predicted;
}

Expected<Pose2D> RepeatPipeline::unaidedFilterPose(const Pose2D& odom) {
  if (!(options_.max_unaided_distance > 0.0)) {
    return Status(StatusCode::kNoConsensus, toString(mode()) +
                                                " mode: no fix in this frame and max_unaided_distance is 0 (no pose from "
                                                "the odometry alone)");
  }
  auto pose = filter_.routePose(odom);
  if (!pose) return pose.status();
  if (filter_.distanceSinceFix() > options_.max_unaided_distance) {
    char message[200];
    std::snprintf(message, sizeof(message),
                  "%s mode: %.2f m without a fix (max_unaided_distance %.2f m): no pose until vision is back",
                  toString(mode()).c_str(), filter_.distanceSinceFix(), options_.max_unaided_distance);
    return Status(StatusCode::kNoConsensus, message);
  }
  return pose;
}

void RepeatPipeline::addUnaidedFilterPose(double stamp, RepeatFrameResult* result) {
  if (!filter_.aligned()) return;
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);
  if (!odom) {
    result->warning = "no pose: no odometry at the image stamp: " + odom.status().message();
    return;
  }
  const auto pose = unaidedFilterPose(*odom);
  if (!pose) {
    result->warning = pose.status().message();
    return;
  }
  setFilterPose(*pose, result);
}

void RepeatPipeline::setFilterPose(const Pose2D& pose, RepeatFrameResult* result) {
  localizer_.advanceTrackingTo(pose);
  if (line_localizer_) line_localizer_->advanceTrackingTo(pose);
  result->pose = pose;
  result->covariance = filter_.covariance();
  result->map_to_odom = filter_.alignment();
}

}  // namespace homography_teach_repeat
