// RepeatPipeline and the localization filter (modes hybrid and mu; docs/math.md §7): a frame's
// fixes gated and fused, the integrity judged, and the pose the filter carries on odometry between
// fixes. The frame's way through the localizers is in repeat_pipeline.cpp.
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>
#include <utility>

namespace homography_teach_repeat {
namespace {

// A keyframe's wall with its own uncertainty: the plane's disagreement with its neighbours as the
// Fast-HD localizer measured it (KeyframeStore, plane_sigma_from_neighbours; 0 where it did not:
// mu mode, or the option off). docs/math.md §4.11.
std::optional<MuObservation> keyframeWall(const RepeatLocalizer& points, const RouteKeyframe& keyframe, int k,
                                          const Pose2D& camera_mount, double fx) {
  auto wall = muWallOf(keyframe.pose, keyframe.plane, camera_mount, fx, k);
  if (wall && k >= 0 && k < points.keyframeCount()) {
    wall->wall_normal_sigma_rad = points.reference(k).plane_normal_sigma_rad;
    wall->wall_distance_sigma = points.reference(k).plane_distance_sigma;
    const auto& pivot = points.reference(k).plane_pivot;
    if (pivot) wall->wall_pivot = Eigen::Vector2d(pivot->x(), pivot->z());
  }
  return wall;
}

}  // namespace

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
    // What the filter holds already: a fix's model term (the keyframe's plane, every fix against it
    // shares it); a tracked fix's matches are the previous detection's, their current points
    // followed by optical flow, so its pixel noise is that frame's too: the whole fix (§7.1).
    const Eigen::Matrix3d& shared = estimate->tracked ? estimate->covariance : estimate->model_covariance;
    const auto nis = filter_.correctWithPose(estimate->base_pose, estimate->covariance, *odom, shared);
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

Status RepeatPipeline::correctMuFilter(double stamp, RepeatEstimate* fix, bool beside_pose) {
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
  auto wall = keyframeWall(localizer_, keyframe, estimate.keyframe, route.info.camera_mount, lines.camera().fx());
  Status corrected;
  if (wall) {
    wall->mu = estimate.mu;
    wall->variance = 0.0;  // the filter's min_mu_variance
    corrected = filter_.correctWithMu(*wall, *odom);
  } else if (beside_pose) {
    // μ as a heading alone reads a lateral offset as a turn (5-9° for 15 cm near a wall, §4.5);
    // beside a Fast-HD pose, which measures the heading with the offset, it only adds that error
    // (KITTI 07's corners, where the keyframes see the road: up to 1 m and 1.8° off, docs/math.md §7.1).
    return Status(StatusCode::kNoConsensus, "keyframe " + std::to_string(estimate.keyframe) +
                                                " has no wall: its heading-only mu fix is not taken beside a Fast-HD pose");
  } else {
    corrected = filter_.correctHeading(route_yaw, *odom);
  }
  // The aligning frame's own fix only waits for the next frame's confirmation: it already gave the
  // heading.
  if (!corrected.isOk() && !aligning) return corrected;
  return Status::ok();
}

Status RepeatPipeline::correctWithShiftHeading(double stamp, const cv::Mat& image, RepeatFrameResult* result) {
  if (last_shift_heading_stamp_ && stamp >= *last_shift_heading_stamp_ &&
      stamp - *last_shift_heading_stamp_ < options_.shift_heading_period) {
    return Status(StatusCode::kNoConsensus, "the last attempt was less than shift_heading_period ago");
  }
  if (!filter_.aligned() && !initialized_) {
    return Status(StatusCode::kNoConsensus, "no pose to start from yet (the first fix comes from Fast-HD or mu)");
  }
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);
  if (!odom) return Status(StatusCode::kInvalidInput, "needs odometry ('odom') at the image stamp: " + odom.status().message());
  const Route& route = localizer_.route();
  const int k = localizer_.trackedKeyframe();
  const RouteKeyframe& keyframe = route.keyframes[static_cast<std::size_t>(k)];
  std::optional<Pose2D> predicted;
  if (filter_.aligned()) {
    const auto prediction = filter_.predictedPose(*odom);
    if (!prediction) return prediction.status();
    predicted = *prediction;
    const double away = std::abs(wrapToPi(predicted->yaw - keyframe.pose.yaw));
    if (away > options_.localization.mu_max_reference_angle) {
      char message[200];
      std::snprintf(message, sizeof(message),
                    "keyframe %d faces %.1f deg away from the predicted heading (mu_max_reference_angle %.1f deg)", k,
                    away * 180.0 / M_PI, options_.localization.mu_max_reference_angle * 180.0 / M_PI);
      return Status(StatusCode::kNoConsensus, message);
    }
  }
  last_shift_heading_stamp_ = stamp;
  const auto current = shift_heading_->describe(image);
  if (!current) return current.status();
  const auto view = shift_heading_->measureViews(k, *current);
  if (!view) return view.status();
  const ShiftHeadingFix* const fix = &view->fix;
  const double fx = localizer_.camera().fx();
  // μ is the shift of the principal point: the camera turned by atan(μ/f) from the view's
  // (docs/math.md §4.5), up to the coupling to a lateral offset that the wall model holds. An
  // experience (a learned view) has no wall of its own: a heading fix, with its yaw's variance.
  const double route_yaw = wrapToPi(view->view_pose.yaw + std::atan(fix->mu / fx));
  auto wall = view->experience == 0 ? keyframeWall(localizer_, keyframe, k, route.info.camera_mount, fx)
                                    : std::nullopt;
  if (fix->ambiguous) {
    // Two shifts compete (repeated structure, a near object's parallax): taken only where the
    // filter's prediction picks the winner (ShiftHeadingFix::pickedBy).
    double predicted_mu = NAN;
    if (predicted && wall) {
      const auto H = wallHomography1dAt(*wall, *predicted);
      if (H && std::abs((*H)(1, 1)) > 1e-12) predicted_mu = (*H)(0, 1) / (*H)(1, 1);
    } else if (predicted) {
      predicted_mu = fx * std::tan(wrapToPi(predicted->yaw - view->view_pose.yaw));
    }
    if (!fix->pickedBy(predicted_mu)) {
      char message[240];
      std::snprintf(message, sizeof(message),
                    "ambiguous against keyframe %d: %.0f px (%d votes) or %.0f px (%d votes), and the prediction "
                    "(%.0f px) does not pick the first",
                    k, fix->mu, fix->shift.support, fix->shift.runner_up_shift_px, fix->shift.runner_up_support,
                    predicted_mu);
      return Status(StatusCode::kNoConsensus, message);
    }
  }
  if (!filter_.aligned()) {
    // The start keyframe is known (start_keyframe): the filter starts there, as with a first μ fix.
    Status aligned = filter_.align(Pose2D(view->view_pose.x, view->view_pose.y, route_yaw), *odom);
    if (!aligned.isOk()) return aligned;
    integrity_.addFix(stamp, true, std::nullopt, 0, fix->shift.support);
  } else {
    Status corrected;
    if (wall) {
      wall->mu = fix->mu;
      wall->variance = fix->variance;
      wall->needs_confirmation = false;  // the vote's own consensus, not a line association
      corrected = filter_.correctWithMu(*wall, *odom);
    } else {
      corrected = filter_.correctHeading(route_yaw, *odom, fix->variance / (fx * fx) + view->view_yaw_variance);
    }
    recordFix(stamp, corrected.isOk(), fix->shift.support);
    if (!corrected.isOk()) {
      if (corrected.code() == StatusCode::kNoConsensus) ++statistics_.gated;
      return corrected;
    }
  }
  ++statistics_.shift_heading_fixes;
  initialized_ = true;
  RepeatEstimate estimate;
  estimate.mode = RepeatMode::kMu;
  estimate.keyframe = k;
  estimate.experience = view->experience;
  estimate.matches = fix->matches;
  estimate.inliers = fix->shift.support;
  estimate.mu = fix->mu;
  estimate.heading_correction = wrapToPi(route_yaw - keyframe.pose.yaw);
  result->estimate = estimate;
  result->fixes = "shift";
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
