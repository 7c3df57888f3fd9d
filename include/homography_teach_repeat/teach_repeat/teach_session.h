// The teach phase without ROS: decides which images become keyframes, stores them (image,
// features, vertical lines, odometry pose) in a crash-safe route, and at the end estimates the
// scene planes along the keyframes (docs/math.md §2, plane_estimation.h) from the odometry (or the
// user-given distance of the first plane) and measures the match noise and the camera's tilt
// between the route's own images and each plane's uncertainty from its neighbours
// (docs/route_format.md, "Measured noise"), writing them into the route. teach_node is a thin
// wrapper around this.
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/teach_repeat/keyframe_policy.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/homography/image_registration.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace homography_teach_repeat {

// Whether the teach run estimates each keyframe pair's relative pitch and roll together with its
// plane (docs/math.md §2.5): a camera levelled by one constant mount rotation (no IMU) still pitches
// and rolls with the body between keyframes, which otherwise reads as a wrong plane; where the
// images are level the two extra unknowns only cost precision.
enum class KeyframeTilt {
  kAuto,      // estimated where the pairs' measured relative tilt (routeTiltSigma) exceeds kTiltedBodySigma
  kEstimate,  // always
  kLevel,     // never (an IMU levels the images, the simulator)
};
// [rad] The relative tilt between keyframes above which kAuto estimates it. Level images measure
// 0.0011-0.0013 rad (KITTI 07 levelled by the car's INS, fountain-P11 by its ground truth: the
// estimate's own noise on a real scene), KITTI 07 levelled by one constant mount 0.0078 rad
// (docs/evaluation.md, "Levelled by one constant mount").
inline constexpr double kTiltedBodySigma = 0.003;
// "auto", "true" (kEstimate), "false" (kLevel); std::invalid_argument naming the value otherwise.
KeyframeTilt keyframeTiltFromString(const std::string& name);
std::string toString(KeyframeTilt mode);
// Whether `mode` estimates the tilt on a route whose pairs measured `measured_tilt_sigma` [rad]
// (nullopt: not measured; kAuto then keeps the images level).
bool estimatesKeyframeTilt(KeyframeTilt mode, const std::optional<double>& measured_tilt_sigma);

struct TeachOptions {
  std::string route_directory;
  bool overwrite = false;
  FeatureOptions features{FeatureType::kSift, kRouteMaxFeatures};
  MatchOptions matching;
  RobustHomographyOptions robust;
  VerticalLineOptions lines;
  KeyframePolicy keyframes;
  double first_plane_distance = 0.0;  // [m], > 0 for plane estimation; 0 skips it
  // Planes from each keyframe pair's homography and the odometry motion (estimatePlanesFromOdometry:
  // routes past several walls, e.g. round a room; no tape measure) instead of the paper's single
  // plane tracked from the first keyframe with first_plane_distance (false).
  bool planes_from_odometry = true;
  // With planes_from_odometry: whether each keyframe pair's relative pitch and roll are estimated
  // with its plane (KeyframeTilt above; docs/math.md §2.5).
  KeyframeTilt keyframe_tilt = KeyframeTilt::kAuto;
  // With planes_from_odometry: a route whose last keyframe is within closed_route_gap [m] of its
  // first (at least 3 keyframes; 0: never) is a loop, and the keyframes of its closing corner that
  // face the first leg take the first keyframe's wall (OdometryPlaneOptions::closing_motion). The
  // same test as the repeat's and the controller's closed_route_gap.
  double closed_route_gap = 1.0;
  // The repeat's options with which finish() measures the planes' uncertainty from the route's own
  // keyframes (measurePlaneUncertainty): the repeat's defaults on a robot; an evaluation passes the
  // options its repeat runs with.
  RepeatOptions plane_measurement;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct PlaneEstimationReport {
  int keyframes = 0;
  int planes = 0;  // keyframes that received a plane
  std::optional<double> measured_tilt_rad;  // the pairs' relative tilt (routeTiltSigma), where measured
  bool keyframe_tilt_estimated = false;     // the planes were estimated with each pair's tilt
  std::vector<std::string> messages;  // one line per problem (pair and reason)
};

// One line for the teach run's log: whether the planes were estimated with each pair's tilt, and why
// (`mode` the run's KeyframeTilt).
std::string describeKeyframeTilt(const PlaneEstimationReport& report, KeyframeTilt mode);

class TeachSession {
 public:
  // Creates the route directory (a clear kInvalidInput if it cannot: read-only, exists...).
  // `camera_mount`: the camera optical centre and yaw in base_link.
  static Expected<TeachSession> start(const TeachOptions& options,
                                      const CameraCalibration& calibration,
                                      const Pose2D& camera_mount);

  // Stores the image as a keyframe if the policy says so. Returns true when stored, false when
  // skipped; kInvalidInput for an empty/odd image, a non-finite pose, or a calibration of a
  // different size than the route's; write failures as returned by the route writer.
  Expected<bool> offer(const cv::Mat& image, const Pose2D& odometry_pose, double stamp);

  // Plane estimation over the stored keyframes (needs >= 2 keyframes, and first_plane_distance > 0
  // without planes_from_odometry): the homographies between consecutive keyframes (undistorted
  // matches, robust estimator), docs/math.md §2 along the route with the odometry motion breaking the
  // β ≈ 0 tie; keyframes after a failed pair get no plane. The same pairs' inlier residuals are the
  // keyframes' match residuals (matchResidualOf), and their tilts the keyframes' tilt to the next
  // (pairTiltOf). Then each plane's uncertainty from its neighbours (measurePlaneUncertainty with
  // TeachOptions::plane_measurement; a failure there is a message of the report, the route keeps
  // its planes). Writes the route index.
  Expected<PlaneEstimationReport> finish();

  const Route& route() const { return writer_->route(); }
  // What the last stored keyframe holds (for the teach node's live warnings, route_audit.h).
  struct StoredCounts {
    int features = 0;
    int lines = 0;
  };
  const StoredCounts& lastStored() const { return last_stored_; }
  int keyframeCount() const { return static_cast<int>(writer_->route().keyframes.size()); }

 private:
  TeachSession(const TeachOptions& options, const CameraCalibration& calibration);

  TeachOptions options_;
  PinholeCamera camera_;
  FeatureExtractor features_;
  VerticalLineExtractor lines_;
  std::optional<RouteWriter> writer_;
  std::optional<Pose2D> last_keyframe_pose_;
  std::vector<ImageFeatures> keyframe_features_;  // kept for the plane estimation
  StoredCounts last_stored_;
};

// A keyframe pair's match residual (route.h, MatchResidual): the inliers' rms transfer error about
// their homography [px]; nullopt with fewer than 4 inliers or a non-finite or zero error.
std::optional<MatchResidual> matchResidualOf(const RegistrationResult& registered);

// A keyframe pair's relative tilt (route.h, PairTilt): the second camera's pitch and roll
// estimated with the pair's plane from its homography and the camera motion (camera 2 in camera 1's
// frame, from odometry; planeAndTiltFromHomographyAndMotion, docs/math.md §2.5). nullopt where the
// pair does not show it: fewer than 4 inliers, less than the plane estimation's baseline (turning
// in place), a tilt beyond kMaxPairTilt, or no plausible wall in front (a floor, too far).
std::optional<PairTilt> pairTiltOf(const RegistrationResult& registered, const PinholeCamera& camera,
                                   const PlanarPose& camera_motion);

// Two views of the route, taken at base poses `first_pose` and `second_pose` (route frame), measured
// as a pair: `first`'s features registered to `second`'s with `matching` and `robust`, undistorted
// by `camera`, and the inliers' match residual and the second camera's tilt (matchResidualOf,
// pairTiltOf; the motion from the poses and `mount`). Both empty when the pair does not register.
// measureRouteNoise's keyframe pairs and ExperienceRecorder::commit's learned pairs.
struct PairMeasurement {
  std::optional<MatchResidual> match_residual;
  std::optional<PairTilt> tilt_to_next;
};
PairMeasurement measureViewPair(const ImageFeatures& first, const ImageFeatures& second, const Pose2D& first_pose,
                                const Pose2D& second_pose, const PinholeCamera& camera, const CameraMount& mount,
                                const MatchOptions& matching = {}, const RobustHomographyOptions& robust = {});

// Measures a route's match noise and tilt from its stored keyframes, as the teach run does (each
// keyframe's features matched to the next's with `matching` and `robust`, undistorted by the
// route's camera; the motion from the keyframes' poses and the camera mount), and sets them in
// `route` (keyframes' match_residual and tilt_to_next, info.match_noise_measured and tilt_measured;
// not written). kInvalidInput for a missing or corrupt features file.
Status measureRouteNoise(Route& route, const MatchOptions& matching = {}, const RobustHomographyOptions& robust = {});

// Measures each plane's uncertainty from the route's stored keyframes as the repeat would at load
// (KeyframeStore, fast_hd with `options` and the route's measured noise, withMeasuredNoise): the
// neighbours' planes compared with it and its neighbours' images relocalized against it (docs/math.md
// §3.6, §3.10); sets every keyframe's plane_uncertainty (absent without a plane) and the route's
// plane_uncertainty_method (kPlaneUncertaintyMethod); not written.
// kInvalidInput for invalid options or a missing or corrupt features file.
Status measurePlaneUncertainty(Route& route, const RepeatOptions& options = {});

// Rewrites a route's index in the current format (5): a route of version 1 to 4 keeps its
// keyframes and experiences and has what it lacks measured (measureRouteNoise with the teach
// defaults, then measurePlaneUncertainty with the repeat's). Atomic; the keyframe files are
// untouched. kInvalidInput naming the file when the route cannot be read, measured or written.
Status migrateRoute(const std::string& directory);

}  // namespace homography_teach_repeat
