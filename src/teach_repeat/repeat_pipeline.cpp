#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"

#include <cmath>
#include <cstdio>
#include <stdexcept>
#include <utility>

namespace homography_teach_repeat {
namespace {
// The odometry of an image's instant may arrive after the image (a simulator publishes both at
// once); for the odometry gate and the μ prediction the newest sample is close enough within this
// lag [s].
constexpr double kOdometryLag = 0.1;
}  // namespace

void RepeatPipelineOptions::validate() const {
  localization.validate();
  mu_filter.validate();
  if (odometry_gate) odometry_gate->validate();
  if (start_keyframe < -1) throw std::invalid_argument("start_keyframe must be >= -1");
  if (!std::isfinite(mu_max_unaided_distance) || mu_max_unaided_distance < 0.0) {
    throw std::invalid_argument("mu_max_unaided_distance must be finite and >= 0");
  }
}

Expected<RepeatPipeline> RepeatPipeline::create(const Route& route, const RepeatPipelineOptions& options) {
  try {
    options.validate();
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  auto localizer = RepeatLocalizer::create(route, options.localization);
  if (!localizer) return localizer.status();
  if (options.start_keyframe >= localizer->keyframeCount()) {
    return Status(StatusCode::kInvalidInput, "start_keyframe " + std::to_string(options.start_keyframe) +
                                                 " but the route has " + std::to_string(localizer->keyframeCount()) +
                                                 " keyframes");
  }
  return RepeatPipeline(std::move(*localizer), options);
}

RepeatPipeline::RepeatPipeline(RepeatLocalizer localizer, const RepeatPipelineOptions& options)
    : localizer_(std::move(localizer)), options_(options), mu_filter_(options.mu_filter) {
  if (options_.odometry_gate) odometry_gate_.emplace(*options_.odometry_gate);
  if (options_.start_keyframe >= 0) {
    localizer_.setTrackedKeyframe(options_.start_keyframe);
    initialized_ = true;
  }
}

Status RepeatPipeline::addOdometry(double stamp, const Pose2D& odom) { return odometry_.add(stamp, odom); }

Status RepeatPipeline::reconfigure(const RepeatOptions& options) {
  auto localizer = RepeatLocalizer::create(localizer_.route(), options);
  if (!localizer) return localizer.status();
  const int tracked = localizer_.trackedKeyframe();
  localizer_ = std::move(*localizer);
  localizer_.setTrackedKeyframe(tracked);
  options_.localization = options;
  return Status::ok();
}

RepeatFrameResult RepeatPipeline::processFrame(double stamp, const Expected<cv::Mat>& image,
                                               const Expected<PinholeCamera>& camera) {
  ++statistics_.frames;
  RepeatFrameResult result;
  const bool mu = localizer_.options().mode == RepeatMode::kMu;
  // A frame without an estimate; in mu mode the filter still gives a pose for a while.
  auto fail = [&](const Status& status) {
    ++statistics_.failures;
    statistics_.last_status = status;
    result.status = status;
    result.estimate.reset();
    if (mu) addUnaidedMuPose(stamp, &result);
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
  // The odometry gate's verdict on each reference's pose, inside the localizer: a pose it would
  // refuse from one keyframe lets the neighbour try (repeat_localizer.h). The pose returned is then
  // gated for real (accepted, or refused and counted towards a switch of reference).
  // The odometry at the image stamp is looked up once for every pose of this frame.
  const auto odom_near_image = odometry_.poseNear(stamp, kOdometryLag);
  const RepeatLocalizer::PoseCheck would_pass = [&](const RepeatEstimate& candidate) {
    return odometry_gate_ && odom_near_image ? odometry_gate_->agrees(candidate.base_pose, *odom_near_image)
                                             : Status::ok();
  };
  auto estimate = initialized_ ? localizer_.localize(*image, predictedMuPose(stamp), would_pass)
                                     : localizer_.initializeGlobally(*image);
  result.timing = localizer_.lastTiming();
  if (!estimate) return fail(estimate.status());
  if (estimate->has_pose) {
    const Status gated = gate(odom_near_image, *estimate, &result.warning);
    if (!gated.isOk()) {
      ++statistics_.gated;
      return fail(gated);
    }
  } else {
    // mu: the fix corrects the filter; refused by it (kNoConsensus: its innovation gate, or no
    // confirmation by the previous frame) or without odometry it is a failed frame.
    const Status corrected = correctMuFilter(stamp, &*estimate);
    if (!corrected.isOk()) {
      if (corrected.code() == StatusCode::kNoConsensus) ++statistics_.gated;
      return fail(corrected);
    }
  }
  initialized_ = true;
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
    if (odom) result.map_to_odom = estimate->base_pose.compose(odom->inverse());
    return result;
  }
  const auto odom = odometry_.poseAt(stamp);  // found by correctMuFilter
  const auto pose = mu_filter_.routePose(*odom);
  if (!pose) return fail(pose.status());
  setMuPose(*pose, &result);
  return result;
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
  const auto odom = odometry_.poseAt(stamp);
  if (!odom) {
    return Status(StatusCode::kInvalidInput, "mu mode needs odometry ('odom') at the image stamp: " + odom.status().toString());
  }
  const Route& route = localizer_.route();
  const RouteKeyframe& keyframe = route.keyframes[static_cast<std::size_t>(estimate.keyframe)];
  const double route_yaw = wrapToPi(keyframe.pose.yaw + estimate.heading_correction);
  const bool aligning = !mu_filter_.aligned();
  if (aligning) {
    // The repeat run starts at the keyframe the robot was placed at (start_keyframe, or the best
    // match of the global initialization), with the heading vision measures there.
    Status aligned = mu_filter_.align(Pose2D(keyframe.pose.x, keyframe.pose.y, route_yaw), *odom);
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
    // the odometry carries on, within mu_max_unaided_distance.
    const auto pose = unaidedMuPose(*odom);
    if (!pose) return Status(pose.status().code(), "only the temporary reference matched; " + pose.status().message());
    return Status::ok();
  }
  // A keyframe with a known wall gives the full μ model (heading and lateral offset); a keyframe
  // without a plane gives a heading-only fix.
  auto wall = muWallOf(keyframe.pose, keyframe.plane, route.info.camera_mount, localizer_.camera().fx(), estimate.keyframe);
  Status corrected;
  if (wall) {
    wall->mu = estimate.mu;
    wall->variance = 0.0;  // the filter's min_mu_variance
    corrected = mu_filter_.correctWithMu(*wall, *odom);
  } else {
    corrected = mu_filter_.correctHeading(route_yaw, *odom);
  }
  // The aligning frame's own fix only waits for the next frame's confirmation: it already gave the
  // heading.
  if (!corrected.isOk() && !aligning) return corrected;
  return Status::ok();
}

Status RepeatPipeline::correctWithLineLandmarks(const Pose2D& odom, RepeatEstimate* fix) {
  // The keyframe the localizer chose, then its neighbours ahead and behind: the filter's own
  // association decides which one's lines are in view.
  const Route& route = localizer_.route();
  const int count = localizer_.keyframeCount();
  std::string reasons;
  Status last(StatusCode::kNoConsensus, "no keyframe with line landmarks near " + std::to_string(fix->keyframe));
  for (const int step : {0, 1, -1}) {
    int k = fix->keyframe + step;
    if (localizer_.closedRoute()) k = (k + count) % count;
    if (k < 0 || k >= count) continue;
    const KeyframeReference& reference = localizer_.reference(k);
    if (reference.line_landmarks.empty()) continue;
    LineLandmarkObservation observation;
    observation.reference_pose = reference.base_pose;
    observation.camera_mount = route.info.camera_mount;
    observation.lens = LineCamera{localizer_.camera().fx(), localizer_.camera().cx()};
    observation.image_width = localizer_.camera().width();
    observation.landmarks = reference.line_landmarks;
    observation.reference_lines = reference.lines;
    observation.current_lines = fix->current_lines;
    const auto used = mu_filter_.correctWithLineLandmarks(observation, odom);
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

std::optional<Pose2D> RepeatPipeline::predictedMuPose(double stamp) const {
  if (localizer_.options().mode != RepeatMode::kMu || !mu_filter_.aligned()) return std::nullopt;
  const auto odom = odometry_.poseNear(stamp, kOdometryLag);
  if (!odom) return std::nullopt;
  const auto predicted = mu_filter_.predictedPose(*odom);
  if (!predicted) return std::nullopt;
  return *predicted;
}

Expected<Pose2D> RepeatPipeline::unaidedMuPose(const Pose2D& odom) {
  if (!(options_.mu_max_unaided_distance > 0.0)) {
    return Status(StatusCode::kNoConsensus,
                  "mu mode: no heading fix in this frame and mu_max_unaided_distance is 0 (no pose from the odometry alone)");
  }
  auto pose = mu_filter_.routePose(odom);
  if (!pose) return pose.status();
  if (mu_filter_.distanceSinceFix() > options_.mu_max_unaided_distance) {
    char message[160];
    std::snprintf(message, sizeof(message),
                  "mu mode: %.2f m without a heading fix (mu_max_unaided_distance %.2f m): no pose until vision is back",
                  mu_filter_.distanceSinceFix(), options_.mu_max_unaided_distance);
    return Status(StatusCode::kNoConsensus, message);
  }
  return pose;
}

void RepeatPipeline::addUnaidedMuPose(double stamp, RepeatFrameResult* result) {
  if (!mu_filter_.aligned()) return;
  const auto odom = odometry_.poseAt(stamp);
  if (!odom) return;
  const auto pose = unaidedMuPose(*odom);
  if (!pose) {
    result->warning = pose.status().message();
    return;
  }
  setMuPose(*pose, result);
}

void RepeatPipeline::setMuPose(const Pose2D& pose, RepeatFrameResult* result) {
  localizer_.advanceTrackingTo(pose);
  result->pose = pose;
  result->covariance = mu_filter_.covariance();
  result->map_to_odom = mu_filter_.alignment();
}

}  // namespace homography_teach_repeat
