// The repeat phase's vocabulary: the modes, their options and what one frame's localization
// against a reference gives. Shared by the keyframe estimators, the localizer and the pipeline.
#pragma once

#include <Eigen/Core>

#include <string>
#include <vector>

#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/mu/heading_correction.h"
#include "homography_teach_repeat/mu/line_landmarks.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

// kHybrid: Fast-HD where a keyframe has a plane and μ where it has vertical lines, both fused by
// one filter on the odometry (RepeatPipeline); a localizer itself runs fast_hd or mu.
enum class RepeatMode { kFastHd, kMu, kClassic, kHybrid };

// "fast_hd", "mu", "classic", "hybrid"; throws std::invalid_argument naming the accepted values.
RepeatMode repeatModeFromString(const std::string& name);
std::string toString(RepeatMode mode);
// The mode repeat_node and evaluate_sequence run unless told (config/repeat_node.yaml `mode`):
// hybrid, every fix the place offers in one filter (docs/math.md §7.1). RepeatOptions::mode below is
// the single-frame localizer's own default.
inline constexpr RepeatMode kDefaultRepeatMode = RepeatMode::kHybrid;

struct RepeatOptions {
  RepeatMode mode = RepeatMode::kFastHd;
  int max_features = kRouteMaxFeatures;
  MatchOptions matching;
  PlanarPoseEstimatorOptions pose;
  HeadingCorrectionOptions heading;
  VerticalLineOptions lines;
  int min_inliers = 15;          // fewer homography inliers: the reference fails
  // fast_hd/classic: every keyframe must have a plane (the route loads only then). The hybrid
  // pipeline's point localizer sets it false: keyframes without a plane are not used for poses.
  bool require_planes = true;
  // fast_hd/classic: keyframes where the teach run turned (KeyframeReference::turn) give no pose.
  // Their planes come from a motion that is mostly rotation, which says little about a plane, and
  // their poses were biased by centimetres and a degree while claiming millimetres (the simulator's
  // gallery, at every corner). The hybrid pipeline sets it with hybrid_skip_turn_keyframes (the
  // filter turns on odometry there). Off by default: without a filter the corners need them.
  bool skip_turn_keyframes_for_poses = false;
  int neighbour_search = 2;      // keyframes tried on each side of the tracked one
  int max_degraded_frames = 30;  // consecutive frames on a temporary reference
  // fast_hd: the RMS transfer error [px] of the inliers under the homography the estimated pose
  // and the keyframe's plane induce; above it the estimate is refused (another wall dominates).
  double max_plane_residual_px = 3.0;
  // fast_hd: with at least `min_normal_check_parallax` (|t|/d of the classic decomposition) the
  // plane in view must have a normal within `max_normal_angle` [rad] of the keyframe plane's.
  double max_normal_angle = 0.35;
  double min_normal_check_parallax = 0.03;
  // fast_hd/classic: each keyframe matches with the features on its plane only: those that move
  // as the plane predicts to the neighbouring keyframe within this tolerance [px] (0: all).
  double plane_feature_tolerance_px = 2.0;
  // fast_hd: each keyframe plane's own uncertainty from how its neighbours' planes, carried into
  // its frame by the taught motion, disagree with it (KeyframeStore, docs/math.md §3.6): the
  // covariance then uses max(pose.plane_*_sigma, the keyframe's). Where the taught planes are
  // consistent (a wall along a corridor or a street) it adds little; where each keyframe saw a
  // different mixture of surfaces (a street corner) it says so. On by default: without it the
  // covariance of a real street's corners claims ten times less than their error
  // (docs/evaluation.md, KITTI 07).
  bool plane_sigma_from_neighbours = true;
  // fast_hd: the covariance's pixel σ from the route's own images: this gain times the match
  // residual the teach run measured (route.h, routeMatchResidual; docs/math.md §3.9), instead of
  // pose.pixel_sigma_px, which stays for a route without one (format 1-2) and for a gain of 0.
  // [0-10] 0.75: with iid noise the residual is twice σ (docs/math.md §3.9); the inliers are the
  // closer matches and the model is not exact, so the σ the covariance needs is 1.5 times that
  // (KITTI 07, fountain-P11 and its eight-view subset, measured 2026-12-04, docs/evaluation.md).
  double match_residual_gain = 0.75;
  // fast_hd: each keyframe's pixel σ scaled by its own measured residual (the teach run's pairs
  // that include it) over the route's, within [0.5, 2] (docs/math.md §3.9): a corner's keyframe
  // matches its neighbours less closely than a straight's.
  bool pixel_noise_per_keyframe = true;
  // fast_hd: a fix's pixel σ from its own inliers' residual about their homography where that
  // says more than the keyframe's σ, the same gain times it (pose.residual_sigma_gain =
  // match_residual_gain, docs/math.md §3.9): a frame matched less closely than the teach run's
  // pairs (features followed by optical flow over frames, a second surface in view) claims
  // accordingly more. Off, or a gain of 0: the keyframe's σ for every fix.
  bool pixel_noise_per_fix = true;
  // fast_hd: the prior σ of the current camera's tilt (pose.tilt_sigma_rad, a nuisance pair of the
  // refinement, docs/math.md §1.10) from the route's own images: this gain times the std of the
  // relative tilt the teach run measured between its keyframes (route.h, routeTiltSigma), instead
  // of pose.tilt_sigma_rad, which stays for a route without one (format 1-3) and for a gain of 0.
  // [0-10] 1: the repeat's view and its keyframe differ in tilt as two keyframes do.
  double measured_tilt_gain = 1.0;
  // A route whose last keyframe is within this distance [m] of its first is a loop: tracking and
  // the neighbour search wrap around from the last keyframe to the first (0: never).
  double closed_route_gap = 1.0;
  // mu mode: μ measures the heading only up to its translation coupling f·tx·cosφ/d (docs/math.md
  // §4.5): a lateral offset tx seen against a wall d away reads as a rotation of about tx/d. So
  //  - keyframes the teach run reached turning in place or started turning at (yaw changed by
  //    more than kTurnKeyframeAngle + kTurnKeyframeRate · distance from the previous or to the
  //    next keyframe) give no
  //    heading fix when `mu_skip_turn_keyframes`: at a corner the walls are about 1 m away and
  //    such fixes were 5-12° off in the simulator with the robot within 3 cm of the keyframe;
  //  - with a pose prior (localize()'s `predicted_pose`), only keyframes whose yaw is within
  //    `mu_max_reference_angle` [rad] of it are tried (a keyframe 60-90° away from the robot's
  //    heading shares no lines with the image, and a wrong association gave fixes 90° off).
  bool mu_skip_turn_keyframes = true;
  double mu_max_reference_angle = 0.2;
  // mu mode: each keyframe's vertical lines triangulated with their own depths from the keyframe
  // and its taught neighbours when the route is loaded (line_landmarks.h, docs/math.md §4.8); a
  // keyframe with landmarks gives the filter a fix from every line (a street: lines at 2-60 m on
  // both sides, which no single wall models), with turn keyframes too (each line's own depth holds
  // the coupling μ cannot). A keyframe without landmarks falls back to μ.
  bool mu_line_landmarks = false;
  LineLandmarkOptions line_landmarks;
  // fast_hd/classic: after a frame localized against a route keyframe, up to this many following
  // frames take that frame's inlier matches on by pyramidal Lucas-Kanade optical flow (checked
  // forward and backward) instead of detecting and matching features: the keyframe pixels stay,
  // the current pixels move with the image. Feature extraction is most of a frame's cost (SIFT at
  // 640x480: ~45 of ~50 ms on 2 cores; bench_repeat_localizer), tracking ~5 ms, so at 30 Hz the
  // node keeps up instead of dropping frames. A frame is detected again when tracking gives too
  // few points or no estimate, when the tracked keyframe changes, after a degraded estimate, and
  // after this many tracked frames (which bounds the drift of chained tracks). 0: every frame is
  // detected.
  int max_tracked_frames = 2;
  // With max_tracked_frames > 0: the features of a tracked frame are detected on a worker thread
  // while the next frames are tracked, and are brought into the frame max_tracked_frames + 1 later
  // (or the first that cannot be tracked: another keyframe) by one more optical-flow step from the
  // detected image. A frame then costs tracking plus matching instead of a detection (SIFT at
  // 640x480 on 2 cores: ~50 ms), at the same rate of detections. The result does not depend on
  // the worker's timing: a frame that needs the features waits for them. false: the frame is
  // detected where it needs the features (docs/design.md, "Background detection").
  bool background_detection = true;
  // Forward-backward check of a tracked point [px]: tracked back into the previous frame it must
  // land within this distance of where it started.
  double tracking_tolerance_px = 0.5;
  // fast_hd/classic: where a keyframe's taught view fails (or gives a pose the caller's check
  // refuses), its experiences (other views of the place learned by earlier repeat runs, route
  // format 2, docs/route_format.md) are tried, newest first.
  bool use_experiences = true;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct RepeatEstimate {
  RepeatMode mode = RepeatMode::kFastHd;
  int keyframe = -1;      // reference keyframe; for a degraded estimate, the keyframe the
                          // temporary reference was localized against
  bool degraded = false;  // localized against the temporary reference
  int experience = 0;     // 0: the keyframe's taught view; k > 0: its experience of id k
  int matches = 0;        // tentative matches (features or lines)
  int inliers = 0;
  // The matches came from the previous frame's inliers by optical flow (RepeatOptions::
  // max_tracked_frames), not from feature detection and matching.
  bool tracked = false;
  bool has_pose = false;  // false in mu mode
  Pose2D base_pose;       // base_link in the route frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (x, y, yaw), route frame
  bool covariance_known = false;                         // false in classic mode
  // The part of `covariance` that every fix against this reference shares, not this image's pixel
  // noise: the keyframe plane's own error, the heading floor, a temporary reference's pose
  // (PlanarPoseEstimate::model_covariance; the filter does not average it away, docs/math.md §7.1).
  Eigen::Matrix3d model_covariance = Eigen::Matrix3d::Zero();
  PlanarPose camera_relative;  // current camera in the reference camera frame (docs/math.md §1.1)
  double heading_correction = 0.0;  // yaw of the robot relative to the reference keyframe [rad]
  double mu = 0.0;                  // mu mode: h12/h22 [px]
  // mu mode against a keyframe with line landmarks (RepeatOptions::mu_line_landmarks): no μ; the
  // filter takes the current lines against the landmarks (RepeatPipeline).
  bool line_landmark_fix = false;
  std::vector<VerticalLine> current_lines;
  // The inlier correspondences (reference keyframe pixel -> current pixel, as measured, i.e.
  // distorted) for visualisation; mu mode: the matched line x at the principal row.
  PointMatches inlier_matches;
  // fast_hd/classic, detected frames (not tracked): the frame features (indices into
  // FrameObservations::features) of those inliers, i.e. the features on the reference's plane.
  // A temporary reference keeps only these (RepeatLocalizer, docs/reliability.md).
  std::vector<int> inlier_features;
};

// Where the wall-clock time of the last localize() call went (repeat_node reports it in its
// diagnostics: on a slow machine it says whether the features or the references cost the time).
struct LocalizeTiming {
  double extraction_ms = 0.0;  // features (or vertical lines, mu mode; or tracking) of the image
  double references_ms = 0.0;  // matching and estimation against every reference tried
  int references_tried = 0;    // route keyframes and the temporary reference
  bool tracked = false;        // the estimate came from tracking (RepeatEstimate::tracked)
  // The features were detected on the worker thread from an earlier frame and matched in this
  // one (RepeatOptions::background_detection); extraction_ms includes the wait for them.
  bool background = false;
};

// `options` for `route`: pose.pixel_sigma_px = match_residual_gain × the route's measured match
// residual where it has one and the gain is > 0, pose.tilt_sigma_rad = measured_tilt_gain × its
// measured tilt σ likewise; otherwise those stay as configured. RepeatLocalizer and the route audit
// localize with it (docs/math.md §3.9).
RepeatOptions withMeasuredNoise(RepeatOptions options, const Route& route);
// Keyframe k's pixel σ over the route's (RepeatOptions::pixel_noise_per_keyframe,
// KeyframeReference::pixel_noise_scale; docs/math.md §3.9): the RMS match residual of the teach
// run's pairs that include it (k − 1 → k and k → k + 1) over `route_residual` (routeMatchResidual),
// within [0.5, 2]; 1 where neither pair nor the route was measured. The repeat and the route audit
// both take it from here.
double keyframePixelNoiseScale(const Route& route, std::size_t k, const std::optional<double>& route_residual);
// One line for the log: which pixel σ and tilt σ withMeasuredNoise gives and where each comes from
// (the route's measurement and the gain; the gain 0; or a route that was not measured, with how to
// measure it), and whether the planes' uncertainty is read from the route or measured at load.
std::string describeMeasuredNoise(const RepeatOptions& options, const Route& route);
// Whether the route lacks a measurement this build's teach run makes (the match noise, the tilt, a
// plane's uncertainty): describeMeasuredNoise then names `route_info --migrate`, which measures it.
bool routeMeasurementsMissing(const Route& route);

}  // namespace homography_teach_repeat
