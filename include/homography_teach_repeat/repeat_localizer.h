// The repeat phase without ROS: localizes the current image against the keyframes of a taught
// route and gives the pose of base_link in the route frame (the odometry frame of the teach run,
// in which the keyframe poses are stored) with its covariance, or the heading correction.
//
// Modes:
//  - fast_hd: features matched to the reference keyframe, robust homography, Fast-HD with the
//    keyframe's plane, covariance (MATH.md §3.4) and the 3-DoF refinement (planar_pose_estimator.h);
//  - mu: vertical lines matched to the keyframe's, 1D homography, heading from μ (paper 002);
//  - classic: the classic decomposition (cv::decomposeHomographyMat) with the positive-depth test,
//    the solution whose normal is closest to the keyframe's plane, scaled by its distance
//    (a baseline: no covariance model, reported as unknown).
// Reference keyframe: the tracked one, then its neighbours (k+1, k−1, k+2, ...) when it fails;
// tracking moves on when the robot is closer to the next keyframe than to the current one.
// Lost tracking (every candidate fails): the last good current image becomes a temporary
// reference (paper 000's outdoor experiment) and estimates are flagged `degraded`; after
// `max_degraded_frames` such frames, or when that fails too, localization reports failure.
// A failed estimate never gives a pose.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/feature_extractor.h"
#include "homography_teach_repeat/feature_matcher.h"
#include "homography_teach_repeat/heading_correction.h"
#include "homography_teach_repeat/pinhole_camera.h"
#include "homography_teach_repeat/planar_pose.h"
#include "homography_teach_repeat/planar_pose_estimator.h"
#include "homography_teach_repeat/route.h"
#include "homography_teach_repeat/status.h"
#include "homography_teach_repeat/vertical_lines.h"

namespace homography_teach_repeat {

enum class RepeatMode { kFastHd, kMu, kClassic };

// Whether a route is a loop: at least 3 keyframes and the last within `max_gap` [m] of the first.
bool isClosedRoute(const Route& route, double max_gap);
// "fast_hd", "mu", "classic"; throws std::invalid_argument naming the accepted values.
RepeatMode repeatModeFromString(const std::string& name);
std::string toString(RepeatMode mode);

struct RepeatOptions {
  RepeatMode mode = RepeatMode::kFastHd;
  int max_features = 1500;
  MatchOptions matching;
  PlanarPoseEstimatorOptions pose;
  HeadingCorrectionOptions heading;
  VerticalLineOptions lines;
  int min_inliers = 15;          // fewer homography inliers: the reference fails
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
  // A route whose last keyframe is within this distance [m] of its first is a loop: tracking and
  // the neighbour search wrap around from the last keyframe to the first (0: never).
  double closed_route_gap = 1.0;
  // mu mode: μ measures the heading only up to its translation coupling f·tx·cosφ/d (MATH.md
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
  // Forward-backward check of a tracked point [px]: tracked back into the previous frame it must
  // land within this distance of where it started.
  double tracking_tolerance_px = 0.5;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct RepeatEstimate {
  RepeatMode mode = RepeatMode::kFastHd;
  int keyframe = -1;      // reference keyframe; for a degraded estimate, the keyframe the
                          // temporary reference was localized against
  bool degraded = false;  // localized against the temporary reference
  int matches = 0;        // tentative matches (features or lines)
  int inliers = 0;
  // The matches came from the previous frame's inliers by optical flow (RepeatOptions::
  // max_tracked_frames), not from feature detection and matching.
  bool tracked = false;
  bool has_pose = false;  // false in mu mode
  Pose2D base_pose;       // base_link in the route frame
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();  // (x, y, yaw), route frame
  bool covariance_known = false;                         // false in classic mode
  PlanarPose camera_relative;  // current camera in the reference camera frame (MATH.md §1.1)
  double heading_correction = 0.0;  // yaw of the robot relative to the reference keyframe [rad]
  double mu = 0.0;                  // mu mode: h12/h22 [px]
  // The inlier correspondences (reference keyframe pixel -> current pixel, as measured, i.e.
  // distorted) for visualisation; mu mode: the matched line x at the principal row.
  PointMatches inlier_matches;
};

// Where the wall-clock time of the last localize() call went (repeat_node reports it in its
// diagnostics: on a slow machine it says whether the features or the references cost the time).
struct LocalizeTiming {
  double extraction_ms = 0.0;  // features (or vertical lines, mu mode; or tracking) of the image
  double references_ms = 0.0;  // matching and estimation against every reference tried
  int references_tried = 0;    // route keyframes and the temporary reference
  bool tracked = false;        // the estimate came from tracking (RepeatEstimate::tracked)
};

class RepeatLocalizer {
 public:
  // Loads every keyframe's features and lines. Status kInvalidInput naming the file for a
  // corrupt keyframe; kInvalidInput when fast_hd/classic mode meets a route without planes.
  static Expected<RepeatLocalizer> create(const Route& route, const RepeatOptions& options);

  // Status: kInvalidInput (empty/odd image, size differs from the route's camera), or the
  // failure of the last reference tried (never a pose). mu mode: `predicted_pose` (route frame,
  // e.g. the heading-aided odometry's) restricts the references to those facing the same way
  // (RepeatOptions::mu_max_reference_angle) and guides the line matching: by the 1D homography
  // of the keyframe's wall at that pose (wallHomography1dAt), or by the rotation alone for a
  // reference without a wall. Ignored in the other modes and when not finite.
  Expected<RepeatEstimate> localize(const cv::Mat& image, std::optional<Pose2D> predicted_pose = std::nullopt);

  // Of the last localize() call (initializeGlobally: of its last localize()), failed ones too.
  const LocalizeTiming& lastTiming() const { return timing_; }

  // Start anywhere: tries every keyframe and tracks the one with most inliers.
  Expected<RepeatEstimate> initializeGlobally(const cv::Mat& image);

  void setTrackedKeyframe(int keyframe);
  // Tracking from a position known otherwise (mu mode: the heading-aided odometry, which vision
  // does not give): moves on while `robot` is closer to the next keyframe than to the tracked one.
  // Non-finite positions are ignored.
  void advanceTrackingTo(const Pose2D& robot);
  int trackedKeyframe() const { return tracked_; }
  bool closedRoute() const { return closed_; }
  int keyframeCount() const { return static_cast<int>(keyframes_.size()); }
  // mu mode: whether keyframe k was reached turning in place (gives no heading fix, see
  // RepeatOptions::mu_skip_turn_keyframes). The first keyframe never is: the run starts there.
  bool isTurnKeyframe(int keyframe) const;
  const Route& route() const { return route_; }
  const PinholeCamera& camera() const { return camera_; }

 private:
  struct Reference {
    ImageFeatures features;
    std::vector<VerticalLine> lines;
    Pose2D base_pose;                 // route frame
    std::optional<ScenePlane> plane;  // camera frame of this reference
    double heading_offset = 0.0;      // mu mode: yaw of this reference relative to its keyframe
    bool turn = false;                // reached turning in place (isTurnKeyframe)
  };
  // mu mode: whether a reference may give a heading fix to a robot at `predicted_pose`.
  bool usableForMu(const Reference& reference, int keyframe, const std::optional<Pose2D>& predicted_pose) const;

  RepeatLocalizer(const Route& route, const RepeatOptions& options);
  // The inlier matches of the last estimate, carried to the next frames by optical flow.
  struct TrackedMatches {
    cv::Mat image;  // grey frame the current points belong to
    std::vector<cv::Point2f> reference, current;  // keyframe and frame pixels (as measured)
    int keyframe = -1;
    int frames_tracked = 0;  // frames since the last feature detection
  };
  // The matches of `track_` followed into `gray`, estimated against their keyframe.
  Expected<RepeatEstimate> localizeByTracking(const cv::Mat& gray);
  // Keeps the estimate's inliers for tracking (or forgets them: degraded, mu, tracking off).
  void rememberForTracking(const RepeatEstimate& estimate, const cv::Mat& gray, int frames_tracked);

  // mu mode: `predicted_pose` (route frame) guides the line matching (HeadingCorrector).
  Expected<RepeatEstimate> localizeAgainst(const Reference& reference, int keyframe,
                                           const ImageFeatures& features,
                                           const std::vector<VerticalLine>& lines,
                                           const std::optional<Pose2D>& predicted_pose = std::nullopt) const;
  // fast_hd/classic: the pose from point matches against `reference` (pixels as measured).
  Expected<RepeatEstimate> estimateFromMatches(const Reference& reference, int keyframe,
                                               const PointMatches& measured) const;
  void advanceTracking(const RepeatEstimate& estimate);
  void restrictToPlaneFeatures();
  Status checkPlaneNormal(const Eigen::Matrix3d& H, const ScenePlane& plane, const PointMatches& matches,
                          const std::vector<int>& inliers) const;

  Route route_;
  RepeatOptions options_;
  PinholeCamera camera_;
  CameraMount mount_;
  FeatureExtractor extractor_;
  VerticalLineExtractor line_extractor_;
  std::vector<Reference> keyframes_;
  int tracked_ = 0;
  bool closed_ = false;
  std::optional<Reference> temporary_;
  int temporary_keyframe_ = -1;
  int degraded_frames_ = 0;
  LocalizeTiming timing_;
  std::optional<TrackedMatches> track_;
};

}  // namespace homography_teach_repeat
