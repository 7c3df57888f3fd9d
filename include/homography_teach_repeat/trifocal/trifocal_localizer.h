// Three-view localization of the robot and the landmarks from bearings (paper 003), without ROS:
// keypoints of three images → bearings (x after undistortion, level camera) → matches chained
// over the views (1→2, 2→3) → robust 1D trifocal tensor (trifocal_ransac.h) → closed-form motion
// with the odometry of the three views as the prior that picks the candidate and the metric scale
// (trifocal_motion.h) → robot poses and triangulated landmarks in the odometry frame.
// Used by the trifocal_localizer node on a sliding triplet of the live stream.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <array>
#include <optional>
#include <vector>

#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/trifocal/trifocal_motion.h"
#include "homography_teach_repeat/trifocal/trifocal_ransac.h"

namespace homography_teach_repeat {

// A keypoint seen in the three views: its index in each view's features.
struct ThreeViewMatch {
  int first = -1;
  int second = -1;
  int third = -1;
};

// Matches 1→2 chained with 2→3 (ratio test and mutual check of `options` on each pair).
// Status kInvalidInput when the descriptor types differ.
Expected<std::vector<ThreeViewMatch>> matchThreeViews(const ImageFeatures& first, const ImageFeatures& second,
                                                      const ImageFeatures& third, const MatchOptions& options);

struct TrifocalLocalizerOptions {
  FeatureOptions features;
  MatchOptions matching;
  TrifocalRansacOptions ransac;
  TrifocalMotionOptions motion;
  int min_inliers = 12;  // fewer tensor inliers: no localization
  // Tensor inliers off the dominant wall needed: at least min_off_plane [>= 1] and
  // min_off_plane_fraction [0, 1) of the inliers; landmarks on one wall do not determine the
  // tensor (estimateDominantPlane), so fewer gives kDegenerate. Measured in the simulated rooms:
  // 6-8 of 230-300 off the wall (stray matches) gave 2.7-3.3° heading errors, 9 of 72 gave 0.4°.
  int min_off_plane = 5;
  double min_off_plane_fraction = 0.05;
  // The vision poses of views 2 and 3 must agree with the prior (odometry; view 2 from
  // `first_to_second` when given): position within max_prior_disagreement_fraction [>= 0] of the
  // prior's distance from view 1 plus 0.05 m, heading within max_prior_heading_disagreement
  // [rad, > 0]; else kNoConsensus. A wrong tensor (a wrong candidate, a wrong scale) is refused
  // instead of published — and instead of becoming the next triplet's prior: in a sanitizer CI run
  // of trifocal_localizer_sim one triplet came out 0.83 m / 6.5° off and, as the prior of the
  // following ones, put them 0.13-0.35 m off.
  double max_prior_disagreement_fraction = 0.3;
  double max_prior_heading_disagreement = 0.15;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

// One view: its keypoints and the odometry pose of base_link (odometry frame) at its stamp.
struct TrifocalView {
  ImageFeatures features;
  Pose2D odometry;
};

struct TrifocalLocalization {
  std::array<Pose2D, 3> base_poses;        // odometry frame; view 1 at its odometry pose
  std::vector<Eigen::Vector2d> landmarks;  // odometry frame (x, y), one per inlier with parallax
  TrifocalMotion motion;                   // cameras 2, 3 in camera 1 (metric)
  int triplets = 0;                        // matches chained over the three views
  int inliers = 0;
  int off_plane = 0;                       // inliers off the dominant wall
  int iterations = 0;
  bool ambiguous = false;                  // both candidates passed cheirality (prior decided)
};

class TrifocalLocalizer {
 public:
  // Throws std::invalid_argument on invalid options (features of an unavailable type included).
  TrifocalLocalizer(const PinholeCamera& camera, const CameraMount& mount, const TrifocalLocalizerOptions& options);

  // Keypoints of an image. Status kInvalidInput for an empty or odd-sized image.
  Expected<ImageFeatures> extract(const cv::Mat& image);

  // Status: kInvalidInput (non-finite odometry), kDegenerate (the odometry shows no baseline
  // between two views: no metric scale; fewer than min_off_plane matches off one wall; or the
  // tensor/motion is degenerate), kTooFewPoints
  // (fewer chained matches than the method needs), kNoConsensus (RANSAC, cheirality, or fewer
  // than min_inliers).
  // `first_to_second` [base_link of view 2 in base_link of view 1], when known better than from
  // odometry — on a sliding window, the previous localization measured it (its views 2 -> 3):
  // it replaces odometry in the prior for view 2, so that picking between the two candidates of
  // the closed form rests on vision for one of the two views (the fourth view of paper 003; with
  // odometry alone, a 6° heading error picked the wrong candidate in the simulator).
  Expected<TrifocalLocalization> localize(const TrifocalView& first, const TrifocalView& second,
                                          const TrifocalView& third,
                                          const std::optional<Pose2D>& first_to_second = std::nullopt) const;

  // Bearing of a keypoint (undistorted x; the camera must be level, see CameraMount).
  Bearing bearingOf(const cv::KeyPoint& keypoint) const;

 private:
  PinholeCamera camera_;
  CameraMount mount_;
  TrifocalLocalizerOptions options_;
  FeatureExtractor extractor_;
};

}  // namespace homography_teach_repeat
