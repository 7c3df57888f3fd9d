// One estimator per repeat mode: what an image offers (features or vertical lines) and what it
// gives against one reference (docs/math.md §1, §3.4, §4).
//  - fast_hd: features matched to the reference, robust homography, Fast-HD with the reference's
//    plane, its covariance and the 3-DoF refinement; checked against the plane (residual, normal);
//  - classic: the classic decomposition with the positive-depth test, the solution whose normal
//    is closest to the reference's plane, scaled by its distance (a baseline without covariance);
//  - mu: vertical lines matched to the reference's, 1D homography, μ and the heading (paper 002),
//    the matching guided by the reference wall's 1D homography at a predicted pose.
#pragma once

#include <opencv2/core.hpp>

#include <memory>
#include <optional>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/teach_repeat/keyframe_store.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"

namespace homography_teach_repeat {

// What one image offers the estimators.
struct FrameObservations {
  ImageFeatures features;           // fast_hd/classic
  std::vector<VerticalLine> lines;  // mu
};

// What every estimator knows of the route.
struct EstimatorContext {
  PinholeCamera camera;
  FeatureType feature_type = FeatureType::kSift;  // of the taught keyframes
  Pose2D camera_mount;               // the camera forward frame in base_link (route info)
  std::vector<Pose2D> keyframe_poses;  // route frame, by keyframe index
  RepeatOptions options;
};

class KeyframeEstimator {
 public:
  explicit KeyframeEstimator(EstimatorContext context);
  virtual ~KeyframeEstimator() = default;
  KeyframeEstimator(const KeyframeEstimator&) = delete;
  KeyframeEstimator& operator=(const KeyframeEstimator&) = delete;

  // The measurements of `image` (`gray`: the same image as 8-bit grey, for the point modes).
  virtual Expected<FrameObservations> observe(const cv::Mat& image, const cv::Mat& gray) = 0;
  // Against `reference`, which is route keyframe `keyframe` or a temporary reference that came
  // from it. `predicted_pose` (route frame): a prior the mode may use (mu: the filter's).
  virtual Expected<RepeatEstimate> estimate(const KeyframeReference& reference, int keyframe,
                                            const FrameObservations& frame,
                                            const std::optional<Pose2D>& predicted_pose) const = 0;
  // Whether `reference` can give this mode a measurement for a robot at `predicted_pose`.
  virtual bool usable(const KeyframeReference& reference, int keyframe,
                      const std::optional<Pose2D>& predicted_pose) const;
  // The point modes: a pose from point matches against `reference` (pixels as measured, e.g.
  // followed by optical flow). kInvalidInput in mu mode.
  virtual Expected<RepeatEstimate> estimateFromMatches(const KeyframeReference& reference, int keyframe,
                                                       const PointMatches& measured) const;
  virtual bool usesPointFeatures() const { return false; }

  const EstimatorContext& context() const { return context_; }

 protected:
  double keyframeYaw(int keyframe) const { return context_.keyframe_poses[static_cast<std::size_t>(keyframe)].yaw; }
  EstimatorContext context_;
  CameraMount mount_;
};

std::unique_ptr<KeyframeEstimator> makeKeyframeEstimator(const EstimatorContext& context);

// The pose options of a Fast-HD fix against `reference` from the repeat's (docs/math.md §3.6, §3.9,
// §3.10): the pixel σ times the keyframe's scale; the plane's σ the configured one or the
// keyframe's own where larger, except where its neighbours' fixes measured the error
// (neighbour_fix_error_per_m2), where the configured one alone; there the heading floor is the one
// measured with it (neighbour_fix_heading_floor_rad, §3.8) in place of the configured common shift
// (heading_sigma_rad still added). The repeat and the route audit both take them from here.
PlanarPoseEstimatorOptions fixPoseOptions(const KeyframeReference& reference, PlanarPoseEstimatorOptions options);
// What the neighbours' fixes add to the covariance of a fix at `camera_pose` (the current camera in
// the reference camera's frame; camera frame (x, z, θ)): d² times neighbour_fix_error_per_m2, d
// the camera's displacement; zero without it. Part of the fix's shared error: every fix against
// the keyframe has it (docs/math.md §7.1).
Eigen::Matrix3d neighbourFixCovariance(const KeyframeReference& reference, const PlanarPose& camera_pose);
// The route's typical heading floor of fixes against keyframes whose fix error is measured [rad]
// (docs/math.md §3.8): a plane's error turns a fix in proportion to the camera's displacement,
// which has opposite signs at a keyframe's neighbours before and after, so their heading errors
// interpolated to zero displacement (`intercepts`, KeyframeReference::neighbour_fix_heading_intercept_rad)
// are what does not grow with it. Their variance from their median square (a χ²₁'s median is
// 0.455 of its mean: one keyframe whose fixes erred far does not set every keyframe's), the
// configured floor `configured_rad` (common_shift_sigma_px / fx) counted as one keyframe more:
// √((configured² + m median(ε²) / 0.455) / (1 + m)); the configured one without intercepts; at most
// kLargestHeadingFloorRad. A keyframe whose own intercept is larger keeps its own
// (KeyframeStore::setHeadingFloor).
double pooledHeadingFloor(const std::vector<double>& intercepts, double configured_rad);

// The fast_hd mode's checks of a pose against the reference's plane, which refuse it
// (kNoConsensus, naming which): its inliers' RMS residual about the plane-induced homography of
// the pose (with its tilt and height offset) above options.max_plane_residual_px, or, with enough
// parallax to tell, the classic decomposition's normals none within options.max_normal_angle of
// the plane's (the dominant plane in view is another wall).
Status checkPoseOnPlane(const PlanarPoseEstimate& pose, const ScenePlane& plane, const PointMatches& matches,
                        const PinholeCamera& camera, const RepeatOptions& options);

// `current` (another image's features) localized against `reference`'s plane as the fast_hd mode
// does: matched (RepeatOptions::matching), undistorted, Fast-HD with the reference's plane and
// RepeatOptions::pose (estimatePlanarPose; the current camera in the reference camera's frame),
// and with `check_on_plane` checked as the mode checks it (checkPoseOnPlane). kNoConsensus with
// fewer than 4 matches or a refused pose, kInvalidInput without a plane; the estimator's error
// otherwise. For measurements on the teach run's own images (the neighbours' fixes, KeyframeStore,
// checked; the route audit's matches, unchecked).
Expected<PlanarPoseEstimate> localizeAgainstPlane(const KeyframeReference& reference, const ImageFeatures& current,
                                                  const PinholeCamera& camera, const RepeatOptions& options,
                                                  bool check_on_plane);

}  // namespace homography_teach_repeat
