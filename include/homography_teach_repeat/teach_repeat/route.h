// A taught route on disk: a directory with an index `route.yaml` and per-keyframe files
//   keyframes/NNNNNN.png            the reference image (as recorded: distorted, 8-bit)
//   keyframes/NNNNNN.features.yml   keypoints + descriptors (cv::FileStorage)
//   keyframes/NNNNNN.lines.yml      vertical lines
// Every file is written atomically (atomic_file.h) and the index last, so a crash while teaching
// loses at most the keyframe being written: the index only ever lists complete keyframes.
//
// route.yaml (format_version 5; versions 1, without experiences, 2, without the measured match
// noise, 3, without the measured tilt, and 4, without the planes' measured uncertainty, are read as
// well and rewritten as 5 by migrateRoute, which measures what is missing, or the next write):
//   format_version: 5
//   feature_type: sift | orb | akaze | surf
//   camera: {width, height, fx, fy, cx, cy, distortion_model, distortion: [..]}
//   camera_mount: {x, y, yaw}            # camera optical centre in base_link [m, rad]
//   first_plane_distance: 3.2            # user-given scale [m]; 0 = unknown
//   measured_noise: {match_residual_px: 0.30,  # the keyframes' median match residual (below);
//                    tilt_rad: 0.004}    # the std of the keyframe pairs' relative tilt (below);
//                                        # absent: not measured (format 1-2; tilt_rad: 1-3)
//   plane_uncertainty_method: 3          # kPlaneUncertaintyMethod of the keyframes' plane_uncertainty
//   keyframes:
//     - {index: 0, stamp: 12.5, pose: {x, y, yaw},        # odometry pose of base_link [m, rad]
//        image: keyframes/000000.png, features: ..., lines: ...,
//        plane: {normal: [nx, ny, nz], distance: d},      # optional, in the keyframe camera frame
//        match_residual: {rms_px: 0.31, inliers: 412},    # optional: its features matched to the
//                                                         # next keyframe's (teach), the inliers' rms
//                                                         # transfer error about their homography [px]
//        tilt_to_next: {pitch: 0.003, roll: -0.001},      # optional: the next keyframe's camera tilt
//                                                         # relative to this one's [rad] (teach)
//        plane_uncertainty: {normal_rad: 0.02,            # optional, with a plane: its error as its
//                            distance: 0.03,              # neighbours measured it (teach; below)
//                            pivot: [x, y, z],
//                            fix_error_per_m2: [9 numbers],
//                            fix_heading_intercept_rad: -0.0002},
//        experiences:                                     # optional: other views of this place
//          - {stamp, pose: {x, y, yaw},                   # that repeat runs learned: base_link in
//             pose_covariance: [9 numbers],               # the route frame as the repeat estimated
//             image: keyframes/NNNNNN.e1.png,             # it, with its covariance (x, y, yaw,
//             features: keyframes/NNNNNN.e1.features.yml, # row-major); match_residual and
//             match_residual: ..., tilt_to_next: ...}]    # tilt_to_next (optional) against the
//                                                         # next keyframe's experience of its run
// Loading validates everything and names the file and the problem on any error.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <cmath>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace homography_teach_repeat {

constexpr int kRouteFormatVersion = 5;
// The version of the planes' uncertainty measurement (KeyframeStore's measurePlaneAgreement and
// measureNeighbourFixes), stored with the values: raised whenever that measurement changes, so that
// a route measured by an older build is measured again (at load, and by route_info --migrate)
// rather than read. 2 (2026-12-05): the heading intercepts measured with the fix's error
// (PlaneUncertainty::fix_heading_intercept_rad); 3 (2026-12-06): the fix's error also at planes
// that disagree with their neighbours', where both neighbours relocalize against the keyframe.
constexpr int kPlaneUncertaintyMethod = 3;
// The largest heading floor and |PlaneUncertainty::fix_heading_intercept_rad| [rad]: what the pose
// options' heading_sigma accepts (PlanarPoseEstimatorOptions).
constexpr double kLargestHeadingFloorRad = 0.05;

// How closely a keyframe's features match the next keyframe's about their homography, measured by
// the teach run (teach_session.h, measureRouteNoise): the pixel noise of this camera, lens and
// scene as the repeat's matches will have it (docs/route_format.md, "Measured noise").
struct MatchResidual {
  double rms_px = 0.0;  // rms transfer error of the inliers [px, > 0]
  int inliers = 0;      // [>= 4]
};

// The next keyframe's camera pitch and roll relative to this keyframe's camera, estimated by the
// teach run with the pair's plane from its homography and odometry motion (teach_session.h,
// pairTiltOf; docs/math.md §2.5): the body's pitch and roll between two views, which a camera
// levelled by its mount alone keeps (docs/route_format.md, "Measured noise").
constexpr double kMaxPairTilt = 0.1;  // [rad] the largest the estimate accepts (plane_estimation.h)
struct PairTilt {
  double pitch = 0.0;  // [rad] about the camera's x axis, finite, within ±kMaxPairTilt
  double roll = 0.0;   // [rad] about its optical axis, the same
  bool inRange() const { return std::abs(pitch) <= kMaxPairTilt && std::abs(roll) <= kMaxPairTilt; }  // false for NaN
};

// Another view of a keyframe's place, learned by a repeat run where the taught view matched weakly
// (changed appearance: a poster replaced, other light). Localized against like the keyframe, with
// its estimated pose and that pose's uncertainty (docs/route_format.md, "Experiences").
struct RouteExperience {
  int id = 1;          // 1, 2, ... within its keyframe (the file names')
  double stamp = 0.0;  // [s] of the repeat frame
  Pose2D pose;         // base_link in the route frame, as the repeat estimated it
  Eigen::Matrix3d pose_covariance = Eigen::Matrix3d::Zero();  // (x, y, yaw)
  std::string image_file;     // relative to the route directory
  std::string features_file;
  // Measured by the run that learned it, against the next keyframe's experience learned in the same
  // run (ExperienceRecorder::commit): the same pair quantities as a keyframe's, so the route's
  // measured noise takes in the views its learning runs saw (docs/route_format.md, "Measured noise").
  std::optional<MatchResidual> match_residual;
  std::optional<PairTilt> tilt_to_next;
};

// A keyframe's plane error as its neighbours measured it (KeyframeStore, docs/math.md §3.6, §3.10;
// docs/route_format.md, "Measured noise"): measured by the teach run (measurePlaneUncertainty,
// teach_session.h) so that the repeat reads it instead of measuring it at every start.
struct PlaneUncertainty {
  double normal_sigma_rad = 0.0;  // std of the normal's direction [rad, 0-0.5], turning about pivot
  double distance_sigma = 0.0;    // std of the distance along the normal at pivot [fraction, 0-0.5]
  // The centroid of the keyframe's plane features on its plane [m, keyframe camera frame]; absent:
  // the plane's point nearest the camera.
  std::optional<Eigen::Vector3d> pivot;
  // The error of a fix against the keyframe per metre of the camera's displacement, E[e eᵀ / d²]
  // over its neighbours' images relocalized against it (camera frame (x, z, θ) [1, 1, rad² per
  // m²], symmetric, non-negative diagonal); absent where no neighbour measured it.
  std::optional<Eigen::Matrix3d> fix_error_per_m2;
  // The part of such a fix's heading error that does not grow with the displacement [rad, signed,
  // within ±0.05] (docs/math.md §3.8): its neighbours' heading errors interpolated to zero
  // displacement between the one before and the one after; with fix_error_per_m2, where both were
  // measured (KeyframeStore::measureNeighbourFixes). The repeat pools the route's into the heading
  // floor of the fixes whose error is measured (pooledHeadingFloor).
  std::optional<double> fix_heading_intercept_rad;
  // kInvalidInput saying which value is non-finite or out of range.
  Status validate() const;
  // Whether it was measured with `plane`: its pivot (where it has one) lies on it (to 1e-9 of the
  // distance). A plane changed after the measurement leaves it stale.
  bool liesOn(const ScenePlane& plane) const;
};

struct RouteKeyframe {
  int index = 0;
  double stamp = 0.0;  // [s]
  Pose2D pose;         // odometry pose of base_link when the image was taken
  std::string image_file;     // relative to the route directory
  std::string features_file;
  std::string lines_file;
  std::optional<ScenePlane> plane;  // dominant plane in this keyframe's camera frame
  std::optional<MatchResidual> match_residual;  // absent: not measured, or the pair did not register
  std::optional<PairTilt> tilt_to_next;  // absent: not measured, or the pair did not show it (no baseline)
  std::optional<PlaneUncertainty> plane_uncertainty;  // only with a plane; absent: not measured (format 1-4)
  std::vector<RouteExperience> experiences;
};

struct RouteInfo {
  FeatureType feature_type = FeatureType::kSift;
  CameraCalibration camera;
  Pose2D camera_mount;  // camera optical centre and yaw in base_link (planar part of the tf)
  double first_plane_distance = 0.0;
  // Whether the keyframes' match residuals were measured (format 3); false for an older route,
  // whose repeat falls back to the configured pixel_sigma (repeat_estimate.h, withMeasuredNoise).
  bool match_noise_measured = false;
  // Whether the keyframe pairs' tilts were measured (format 4); false for an older route, whose
  // repeat falls back to the configured tilt_sigma.
  bool tilt_measured = false;
  // kPlaneUncertaintyMethod of the keyframes' stored plane_uncertainty (format 5); 0: none stored.
  int plane_uncertainty_method = 0;
};

struct Route {
  std::string directory;
  RouteInfo info;
  std::vector<RouteKeyframe> keyframes;
  int loaded_format_version = kRouteFormatVersion;  // as found on disk (1-3: not yet migrated)
};

// The route's match residual: the median over its keyframes' and experiences' rms_px [px]; nullopt
// when not measured or none has one.
std::optional<double> routeMatchResidual(const Route& route);
// The std of the relative tilt between two views of the route [rad]: 1.4826 × the median of the
// keyframe (and experience) pairs' |pitch| and |roll| (a robust std of a zero-mean spread: a pair at
// a corner whose homography mixes two surfaces does not set it); nullopt when not measured or no
// pair has one.
std::optional<double> routeTiltSigma(const Route& route);

// Whether a keyframe with a plane lacks its plane_uncertainty, or has one measured with another
// plane (PlaneUncertainty::liesOn) or by another method (RouteInfo::plane_uncertainty_method): a
// route of format 1-4, one whose teach run could not measure it, one whose planes were changed in
// memory, one measured by a build whose measurement differed. migrateRoute measures it.
bool planeUncertaintyMissing(const Route& route);
// Whether the route has planes and none misses its plane_uncertainty: the repeat then reads them
// (KeyframeStore::load), otherwise it measures them all at load.
bool planeUncertaintyStored(const Route& route);

// Where a keyframe's or experience's file is: `file` as is when it is absolute (a route composed
// along a path through a map of routes, network/path_route.h, names files of several routes),
// otherwise relative to `directory` (the route's folder).
std::string routeFilePath(const std::string& directory, const std::string& file);

// Writes route.yaml (the current format_version) atomically from `route`.
Status writeRouteIndex(const Route& route);

// Adds a learned view to keyframe `keyframe` of `route` (loaded from its directory): writes its
// image and features, then the index, each atomically. When the keyframe already has
// `max_experiences` (>= 1), the oldest is dropped (its files removed after the index no longer
// lists them). kInvalidInput on an empty image, a non-finite pose, stamp or covariance, a keyframe
// out of range, or a write failure (the index then lists only complete experiences).
Status addExperience(Route& route, std::size_t keyframe, const cv::Mat& image, const ImageFeatures& features,
                     const Pose2D& pose, const Eigen::Matrix3d& pose_covariance, double stamp,
                     int max_experiences = 3);

// Appends keyframes to a new route directory.
class RouteWriter {
 public:
  // Creates `directory` (and keyframes/) if needed. Status kInvalidInput when it cannot be created
  // or written (e.g. read-only), or already holds a route.yaml and `overwrite` is false.
  static Expected<RouteWriter> create(const std::string& directory, const RouteInfo& info,
                                      bool overwrite = false);

  // Writes the keyframe's files, then the index. Status kInvalidInput on an empty image, a
  // non-finite pose, or a write failure (the index then still lists only complete keyframes).
  Status addKeyframe(const cv::Mat& image, const ImageFeatures& features,
                     const std::vector<VerticalLine>& lines, const Pose2D& pose, double stamp);

  // Sets each keyframe's match residual and tilt to the next keyframe (sizes must match; finite rms
  // > 0 and >= 4 inliers, finite tilts within ±kMaxPairTilt where present) and marks the route's
  // noise and tilt measured; written with the next index write (setPlanes, addKeyframe): the
  // teach run's ~finish writes its index with its planes, then with their uncertainty.
  Status setMeasuredNoise(const std::vector<std::optional<MatchResidual>>& residuals,
                          const std::vector<std::optional<PairTilt>>& tilts);

  // Sets the plane of each keyframe (size must match) and the scale, clearing what was measured of
  // the planes before; rewrites the index.
  Status setPlanes(const std::vector<std::optional<ScenePlane>>& planes,
                   double first_plane_distance);

  // Sets each keyframe's plane_uncertainty (size must match; only where the keyframe has a plane,
  // each valid: PlaneUncertainty::validate, naming the keyframe); rewrites the index.
  Status setPlaneUncertainties(const std::vector<std::optional<PlaneUncertainty>>& uncertainties);

  const Route& route() const { return route_; }

 private:
  RouteWriter() = default;
  Status writeIndex() const;
  Route route_;
};

// Checks, before any image arrives, that a route can be written to `directory`: creates it and
// keyframes/ if needed and writes (then removes) a probe file through writeFileAtomically.
// Status kInvalidInput naming the directory when it cannot be created or written (read-only file
// system, permissions, a path through a regular file), or when it already holds a route.yaml and
// `overwrite` is false. teach_node calls it at start so a bad directory stops it at once.
Status checkRouteDirectoryWritable(const std::string& directory, bool overwrite);

// Reads and validates route.yaml (not the per-keyframe files). Status kInvalidInput naming the
// file for: a missing directory or index, YAML syntax errors (with line), an unknown
// format_version, missing or ill-typed fields, non-finite numbers, a bad camera, duplicate or
// unordered keyframe indices, a keyframe file that does not exist, a measured value that is not
// finite or out of range (naming the keyframe).
Expected<Route> loadRoute(const std::string& directory);

// Whether a route is a loop: at least 3 keyframes and the last within `max_gap` [m] of the first.
bool isClosedRoute(const Route& route, double max_gap);

// Per-keyframe data; kInvalidInput naming the file when it is missing or corrupt.
Expected<cv::Mat> loadKeyframeImage(const Route& route, std::size_t keyframe);
Expected<ImageFeatures> loadKeyframeFeatures(const Route& route, std::size_t keyframe);
Expected<std::vector<VerticalLine>> loadKeyframeLines(const Route& route, std::size_t keyframe);
Expected<ImageFeatures> loadExperienceFeatures(const Route& route, std::size_t keyframe, std::size_t experience);
// Replaces a keyframe's stored features (atomically); kInvalidInput for a keyframe the route does
// not have or a file that cannot be written.
Status writeKeyframeFeatures(const Route& route, std::size_t keyframe, const ImageFeatures& features);

}  // namespace homography_teach_repeat
