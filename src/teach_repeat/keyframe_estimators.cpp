#include "homography_teach_repeat/teach_repeat/keyframe_estimators.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <utility>

#include "homography_teach_repeat/common/median.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/homography/homography_decomposition.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/localization/localization_filter.h"
#include "homography_teach_repeat/mu/heading_correction.h"

namespace homography_teach_repeat {
namespace {

// The reference keyframe's yaw rotates the relative covariance into the route frame.
Eigen::Matrix3d rotateCovariance(const Eigen::Matrix3d& covariance, double yaw) {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  R.topLeftCorner<2, 2>() << std::cos(yaw), -std::sin(yaw), std::sin(yaw), std::cos(yaw);
  const Eigen::Matrix3d rotated = R * covariance * R.transpose();
  return 0.5 * (rotated + rotated.transpose());  // exactly symmetric for the message
}

// fast_hd and classic: features matched to the reference, a pose from the point matches.
class PointEstimator : public KeyframeEstimator {
 public:
  explicit PointEstimator(const EstimatorContext& context)
      : KeyframeEstimator(context), extractor_(FeatureOptions{context.feature_type, context.options.max_features}) {}

  bool usesPointFeatures() const override { return true; }
  // A pose needs the keyframe's plane (a hybrid route may have keyframes without one).
  bool usable(const KeyframeReference& reference, int /*keyframe*/,
              const std::optional<Pose2D>& /*predicted_pose*/) const override {
    return reference.plane.has_value() && !(context_.options.skip_turn_keyframes_for_poses && reference.turn);
  }

  Expected<FrameObservations> observe(const cv::Mat& /*image*/, const cv::Mat& gray) override {
    auto features = extractor_.extract(gray);
    if (!features) return features.status();
    FrameObservations frame;
    frame.features = std::move(*features);
    return frame;
  }

  Expected<RepeatEstimate> estimate(const KeyframeReference& reference, int keyframe, const FrameObservations& frame,
                                    const std::optional<Pose2D>& /*predicted_pose*/) const override {
    const auto dmatches = matchFeatures(reference.features, frame.features, context_.options.matching);
    if (!dmatches) return dmatches.status();
    std::vector<int> frame_feature;  // of each match
    frame_feature.reserve(dmatches->size());
    for (const cv::DMatch& m : *dmatches) frame_feature.push_back(m.trainIdx);
    return estimateFrom(reference, keyframe, toPointMatches(reference.features, frame.features, *dmatches),
                        &frame_feature);
  }

  Expected<RepeatEstimate> estimateFromMatches(const KeyframeReference& reference, int keyframe,
                                               const PointMatches& measured) const override {
    return estimateFrom(reference, keyframe, measured, nullptr);
  }

 private:
  // `frame_feature` (optional): the frame's feature index of each match, for
  // RepeatEstimate::inlier_features.
  Expected<RepeatEstimate> estimateFrom(const KeyframeReference& reference, int keyframe, const PointMatches& measured,
                                        const std::vector<int>* frame_feature) const {
    std::vector<int> kept;  // index in `measured` of each undistorted match
    const PointMatches matches = undistortMatches(context_.camera, measured, &kept);
    RepeatEstimate estimate;
    estimate.mode = context_.options.mode;
    estimate.keyframe = keyframe;
    estimate.experience = reference.experience;
    estimate.matches = static_cast<int>(matches.size());
    std::vector<int> inliers;
    auto relative = cameraPose(reference, matches, &inliers, &estimate);
    if (!relative) return relative.status();
    estimate.inliers = static_cast<int>(inliers.size());
    for (const int i : inliers) {
      const int match = kept[static_cast<std::size_t>(i)];
      estimate.inlier_matches.push_back(measured[static_cast<std::size_t>(match)]);
      if (frame_feature) estimate.inlier_features.push_back((*frame_feature)[static_cast<std::size_t>(match)]);
    }
    if (estimate.inliers < context_.options.min_inliers) {
      return Status(StatusCode::kNoConsensus, std::to_string(estimate.inliers) + " inliers against keyframe " +
                                                  std::to_string(keyframe) + ", need " +
                                                  std::to_string(context_.options.min_inliers));
    }
    estimate.has_pose = true;
    estimate.camera_relative = *relative;
    const Pose2D relative_base = mount_.cameraToBase(*relative);
    estimate.base_pose = reference.base_pose.compose(relative_base);
    if (estimate.covariance_known && !reference.base_pose_covariance.isZero()) {
      // base = reference ∘ relative: the reference pose's own uncertainty through ∂base/∂reference.
      const double c = std::cos(reference.base_pose.yaw), s = std::sin(reference.base_pose.yaw);
      Eigen::Matrix3d J = Eigen::Matrix3d::Identity();
      J(0, 2) = -s * relative_base.x - c * relative_base.y;
      J(1, 2) = c * relative_base.x - s * relative_base.y;
      const Eigen::Matrix3d from_reference = J * reference.base_pose_covariance * J.transpose();
      const Eigen::Matrix3d total = estimate.covariance + from_reference;
      estimate.covariance = 0.5 * (total + total.transpose());
      const Eigen::Matrix3d shared = estimate.model_covariance + from_reference;
      estimate.model_covariance = 0.5 * (shared + shared.transpose());
    }
    estimate.heading_correction = wrapToPi(estimate.base_pose.yaw - keyframeYaw(keyframe));
    return estimate;
  }

 protected:
  // The current camera in the reference camera frame from undistorted matches; fills `inliers`
  // (indices into `matches`) and the estimate's covariance.
  virtual Expected<PlanarPose> cameraPose(const KeyframeReference& reference, const PointMatches& matches,
                                          std::vector<int>* inliers, RepeatEstimate* estimate) const = 0;

 private:
  FeatureExtractor extractor_;
};

class FastHdEstimator final : public PointEstimator {
 public:
  explicit FastHdEstimator(const EstimatorContext& context) : PointEstimator(context) {}

 private:
  Expected<PlanarPose> cameraPose(const KeyframeReference& reference, const PointMatches& matches,
                                  std::vector<int>* inliers, RepeatEstimate* estimate) const override {
    const RepeatOptions& options = context_.options;
    // The keyframe's own pixel σ and plane's (or its neighbours' fixes') uncertainty.
    const auto pose = estimatePlanarPose(matches, context_.camera, *reference.plane, fixPoseOptions(reference, options.pose));
    if (!pose) return pose.status();
    *inliers = pose->inliers;
    const Status on_plane = checkPoseOnPlane(*pose, *reference.plane, matches, context_.camera, options);
    if (!on_plane.isOk()) return on_plane;
    const Eigen::Matrix3d J = mount_.cameraToBaseJacobian(pose->pose);
    const Eigen::Matrix3d measured = neighbourFixCovariance(reference, pose->pose);
    estimate->covariance = rotateCovariance(J * (pose->covariance + measured) * J.transpose(), reference.base_pose.yaw);
    estimate->model_covariance =
        rotateCovariance(J * (pose->model_covariance + measured) * J.transpose(), reference.base_pose.yaw);
    estimate->covariance_known = true;
    return pose->pose;
  }
};

class ClassicEstimator final : public PointEstimator {
 public:
  explicit ClassicEstimator(const EstimatorContext& context) : PointEstimator(context) {}

 private:
  Expected<PlanarPose> cameraPose(const KeyframeReference& reference, const PointMatches& matches,
                                  std::vector<int>* inliers, RepeatEstimate* estimate) const override {
    const auto robust = estimateHomographyRobust(matches, context_.options.pose.robust);
    if (!robust) return robust.status();
    *inliers = robust->inliers;
    std::vector<Eigen::Vector2d> pixels;
    for (const int i : robust->inliers) pixels.push_back(matches[static_cast<std::size_t>(i)].reference);
    const auto all = decomposeHomographyClassic(robust->H, context_.camera);
    if (!all) return all.status();
    const auto visible = filterByPositiveDepth(*all, context_.camera, pixels);
    if (visible.empty()) return Status(StatusCode::kDegenerate, "classic decomposition: no solution in front");
    const HomographyDecomposition* best = &visible.front();
    for (const auto& d : visible) {
      if (d.normal.dot(reference.plane->normal) > best->normal.dot(reference.plane->normal)) best = &d;
    }
    estimate->covariance = Eigen::Matrix3d::Identity() * 1e6;  // no covariance model
    return best->planarPose(reference.plane->distance);
  }
};

class MuEstimator final : public KeyframeEstimator {
 public:
  explicit MuEstimator(const EstimatorContext& context)
      : KeyframeEstimator(context),
        line_extractor_(context.options.lines),
        corrector_(context.options.heading, LineCamera{context.camera.fx(), context.camera.cx()}) {}

  Expected<FrameObservations> observe(const cv::Mat& image, const cv::Mat& /*gray*/) override {
    auto lines = line_extractor_.extract(image, &context_.camera);
    if (!lines) return lines.status();
    FrameObservations frame;
    frame.lines = std::move(*lines);
    return frame;
  }

  bool usable(const KeyframeReference& reference, int keyframe, const std::optional<Pose2D>& predicted_pose) const override {
    // A keyframe with line landmarks models each line's depth, also at a corner.
    if (context_.options.mu_skip_turn_keyframes && reference.turn && reference.line_landmarks.empty()) return false;
    if (!predicted_pose || !std::isfinite(predicted_pose->yaw)) return true;
    const double reference_yaw = keyframeYaw(keyframe) + reference.heading_offset;
    return std::abs(wrapToPi(reference_yaw - predicted_pose->yaw)) <= context_.options.mu_max_reference_angle;
  }

  Expected<RepeatEstimate> estimate(const KeyframeReference& reference, int keyframe, const FrameObservations& frame,
                                    const std::optional<Pose2D>& predicted_pose) const override {
    const bool prior = predicted_pose && predicted_pose->isFinite();
    if (!reference.line_landmarks.empty()) {
      // The filter pairs the lines with the landmarks at its own prediction (RepeatPipeline).
      RepeatEstimate estimate;
      estimate.mode = RepeatMode::kMu;
      estimate.keyframe = keyframe;
      estimate.line_landmark_fix = true;
      estimate.matches = static_cast<int>(reference.line_landmarks.size());
      estimate.heading_correction = reference.heading_offset;
      estimate.current_lines = frame.lines;
      return estimate;
    }
    // Guided matching: the keyframe's wall at the predicted pose moves the lines by the offset and
    // depth change as well as the rotation; a reference without a wall (the temporary one of this
    // mode has no plane, nor has a keyframe on the floor) by the rotation only.
    std::optional<Eigen::Matrix2d> wall_guide;
    if (prior) {
      if (const auto wall = muWallOf(reference.base_pose, reference.plane, context_.camera_mount, context_.camera.fx(), keyframe)) {
        const auto H = wallHomography1dAt(*wall, *predicted_pose);
        if (H) wall_guide = *H;
      }
    }
    const double reference_yaw = keyframeYaw(keyframe) + reference.heading_offset;
    const auto correction =
        wall_guide ? corrector_.estimate(reference.lines, frame.lines, *wall_guide)
                   : corrector_.estimate(reference.lines, frame.lines, prior ? wrapToPi(predicted_pose->yaw - reference_yaw) : 0.0);
    if (!correction) return correction.status();
    RepeatEstimate estimate;
    estimate.mode = RepeatMode::kMu;
    estimate.keyframe = keyframe;
    estimate.matches = correction->line_matches;
    estimate.inliers = correction->inliers;
    estimate.mu = correction->mu;
    estimate.heading_correction = wrapToPi(reference.heading_offset + correction->theta);
    return estimate;
  }

 private:
  VerticalLineExtractor line_extractor_;
  HeadingCorrector corrector_;
};

}  // namespace

KeyframeEstimator::KeyframeEstimator(EstimatorContext context)
    : context_(std::move(context)), mount_(context_.camera_mount.x, context_.camera_mount.y, context_.camera_mount.yaw) {}

bool KeyframeEstimator::usable(const KeyframeReference& /*reference*/, int /*keyframe*/,
                               const std::optional<Pose2D>& /*predicted_pose*/) const {
  return true;
}

Expected<RepeatEstimate> KeyframeEstimator::estimateFromMatches(const KeyframeReference& /*reference*/, int /*keyframe*/,
                                                                const PointMatches& /*measured*/) const {
  return Status(StatusCode::kInvalidInput, toString(context_.options.mode) + " mode does not estimate from point matches");
}

std::unique_ptr<KeyframeEstimator> makeKeyframeEstimator(const EstimatorContext& context) {
  switch (context.options.mode) {
    case RepeatMode::kFastHd: return std::make_unique<FastHdEstimator>(context);
    case RepeatMode::kClassic: return std::make_unique<ClassicEstimator>(context);
    case RepeatMode::kMu: return std::make_unique<MuEstimator>(context);
    case RepeatMode::kHybrid: break;
  }
  return nullptr;
}

PlanarPoseEstimatorOptions fixPoseOptions(const KeyframeReference& reference, PlanarPoseEstimatorOptions options) {
  if (!reference.neighbour_fix_error_per_m2) {
    options.plane_normal_sigma_rad = std::max(options.plane_normal_sigma_rad, reference.plane_normal_sigma_rad);
    options.plane_distance_sigma = std::max(options.plane_distance_sigma, reference.plane_distance_sigma);
  }
  options.pixel_sigma_px *= reference.pixel_noise_scale;
  if (reference.neighbour_fix_error_per_m2 && reference.neighbour_fix_heading_floor_rad) {
    options.common_shift_sigma_px = 0.0;
    options.heading_sigma_rad = std::hypot(options.heading_sigma_rad, *reference.neighbour_fix_heading_floor_rad);
  }
  return options;
}

double pooledHeadingFloor(const std::vector<double>& intercepts, double configured_rad) {
  constexpr double kChiSquare1Median = 0.454936;  // of a unit χ² with one degree of freedom
  std::vector<double> squares;
  squares.reserve(intercepts.size());
  for (const double intercept : intercepts) squares.push_back(intercept * intercept);
  const double m = static_cast<double>(squares.size());
  const double variance = squares.empty() ? 0.0 : *upperMedian(std::move(squares)) / kChiSquare1Median;
  return std::min(std::sqrt((configured_rad * configured_rad + m * variance) / (m + 1.0)), kLargestHeadingFloorRad);
}

Eigen::Matrix3d neighbourFixCovariance(const KeyframeReference& reference, const PlanarPose& camera_pose) {
  if (!reference.neighbour_fix_error_per_m2) return Eigen::Matrix3d::Zero();
  return (camera_pose.x * camera_pose.x + camera_pose.z * camera_pose.z) * *reference.neighbour_fix_error_per_m2;
}

Status checkPoseOnPlane(const PlanarPoseEstimate& pose, const ScenePlane& plane, const PointMatches& matches,
                        const PinholeCamera& camera, const RepeatOptions& options) {
  // The pose must explain the matches through the keyframe's plane. Any homography gives a
  // Fast-HD pose, so a view dominated by another wall (a corner) gives a wrong pose with a small
  // DLT residual; the plane-induced homography of that pose does not fit it.
  // The model includes the refinement's nuisances: the current camera's tilt and its height
  // offset (a camera 3 cm lower moves a wall 2 m away by f·0.03/2 ≈ 8 px, docs/math.md §1.10).
  const Eigen::Matrix3d H_model =
      camera.K() * pose.tilt * camera.Kinverse() * planeInducedHomography(camera, pose.pose, plane, pose.height_offset);
  double sum = 0.0;
  for (const int i : pose.inliers) {
    const double e = transferError(H_model, matches[static_cast<std::size_t>(i)]);
    sum += e * e;
  }
  const double rms = std::sqrt(sum / static_cast<double>(std::max<std::size_t>(1, pose.inliers.size())));
  if (!(rms <= options.max_plane_residual_px)) {
    return Status(StatusCode::kNoConsensus, "the matches do not fit the keyframe's plane (RMS " + std::to_string(rms) +
                                                " px > max_plane_residual " + std::to_string(options.max_plane_residual_px) +
                                                " px): another wall in view?");
  }
  // Every vertical plane's homography under planar motion has the same form, so the residual
  // cannot tell the keyframe's wall from a side wall. The plane normal can: with enough parallax
  // the classic decomposition's normals (positive depth, at least 90 % of the inliers in front)
  // must include one near the keyframe plane's normal (docs/math.md §1.8: the other solution is
  // the spurious one).
  constexpr double kMinFractionInFront = 0.9;
  const auto solutions = decomposeHomographyClassic(pose.H, camera);
  if (!solutions) return Status::ok();  // nothing to check against; the residual test stands
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(pose.inliers.size());
  for (const int i : pose.inliers) pixels.push_back(matches[static_cast<std::size_t>(i)].reference);
  const auto visible = filterByPositiveDepth(*solutions, camera, pixels, kMinFractionInFront);
  if (visible.empty()) return Status::ok();
  double parallax = 0.0, best_cos = -1.0;
  for (const auto& d : visible) {
    parallax = std::max(parallax, d.translation_over_distance.norm());
    best_cos = std::max(best_cos, d.normal.dot(plane.normal));
  }
  if (parallax < options.min_normal_check_parallax) return Status::ok();  // not observable
  const double angle = std::acos(std::clamp(best_cos, -1.0, 1.0));
  if (angle > options.max_normal_angle) {
    return Status(StatusCode::kNoConsensus, "the dominant plane in view is not the keyframe's (normal " +
                                                std::to_string(angle * 180.0 / M_PI) + " deg away): another wall in view?");
  }
  return Status::ok();
}

Expected<PlanarPoseEstimate> localizeAgainstPlane(const KeyframeReference& reference, const ImageFeatures& current,
                                                  const PinholeCamera& camera, const RepeatOptions& options,
                                                  bool check_on_plane) {
  if (!reference.plane) return Status(StatusCode::kInvalidInput, "the reference has no plane");
  const auto matches = matchFeatures(reference.features, current, options.matching);
  if (!matches) return matches.status();
  if (matches->size() < 4) return Status(StatusCode::kNoConsensus, "fewer than 4 matches");
  const PointMatches points = undistortMatches(camera, toPointMatches(reference.features, current, *matches));
  auto pose = estimatePlanarPose(points, camera, *reference.plane, options.pose);
  if (!pose || !check_on_plane) return pose;
  const Status on_plane = checkPoseOnPlane(*pose, *reference.plane, points, camera, options);
  if (!on_plane.isOk()) return on_plane;
  return pose;
}

}  // namespace homography_teach_repeat
