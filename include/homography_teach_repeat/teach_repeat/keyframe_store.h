// The taught keyframes as the repeat phase uses them: each keyframe's features (fast_hd, classic)
// or vertical lines (mu), its pose, its scene plane and whether the teach run was turning there.
#pragma once

#include <optional>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/mu/line_landmarks.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

// What an image is localized against: a route keyframe, or the temporary reference (a recent
// frame that was localized; RepeatLocalizer).
struct KeyframeReference {
  ImageFeatures features;              // fast_hd/classic
  std::vector<VerticalLine> lines;     // mu
  std::vector<LineLandmark> line_landmarks;  // mu with RepeatOptions::mu_line_landmarks
  Pose2D base_pose;                    // route frame
  // Zero for a keyframe (its pose defines the route); a temporary reference's pose is an estimate,
  // and its covariance (x, y, yaw) carries into the poses measured against it.
  Eigen::Matrix3d base_pose_covariance = Eigen::Matrix3d::Zero();
  std::optional<ScenePlane> plane;     // camera frame of this reference
  double heading_offset = 0.0;         // mu mode: yaw of this reference relative to its keyframe
  // The plane's uncertainty measured from the neighbours (RepeatOptions::plane_sigma_from_neighbours):
  // std of the normal's direction [rad], turning it about plane_pivot, and of the distance along
  // the normal there [fraction of the plane's distance]; 0 when not measured (docs/math.md §3.6).
  double plane_normal_sigma_rad = 0.0;
  double plane_distance_sigma = 0.0;
  // The centroid of its plane features on the plane [m, camera frame] (centroidOnPlane), measured
  // with the sigmas; absent: the plane's point nearest the camera.
  std::optional<Eigen::Vector3d> plane_pivot;
  // Where its neighbours' planes agree with it (plane_normal_sigma_rad below 0.1 rad), or both
  // neighbours were measured, the error of a fix against this keyframe measured instead: its
  // neighbours' stored images relocalized against it as the repeat does, each error (fix − taught,
  // camera frame (x, z, θ)) over the distance between the cameras, E[e eᵀ / d²] [1, 1, rad² per
  // m²] (measureNeighbourFixes; docs/math.md §3.10). A fix at displacement d then carries d² times
  // it in place of the plane's term (keyframe_estimators.h: fixPoseOptions, neighbourFixCovariance).
  // Absent: no neighbour measured, or one only where they disagree.
  std::optional<Eigen::Matrix3d> neighbour_fix_error_per_m2;
  // With it: its neighbours' heading errors interpolated to zero displacement [rad] where both were
  // measured (PlaneUncertainty::fix_heading_intercept_rad), and the heading floor of a fix against it,
  // the route's intercepts pooled or its own (setHeadingFloor; docs/math.md §3.8), in place of the configured.
  std::optional<double> neighbour_fix_heading_intercept_rad;
  std::optional<double> neighbour_fix_heading_floor_rad;
  bool turn = false;                   // the teach run turned here (isTurnKeyframe)
  // This keyframe's pixel σ over the route's (RepeatOptions::pixel_noise_per_keyframe): the RMS
  // match residual of the teach run's pairs that include it over the route's, within [0.5, 2]; 1
  // where not measured.
  double pixel_noise_scale = 1.0;
  int experience = 0;                  // 0: a taught view; k > 0: the keyframe's experience k
};

// Whether the teach run turned between two keyframes: their yaws differ by more than 0.1 rad +
// 1 rad/m · their distance (driving a straight segment, the heading varies by a few degrees over
// the keyframe spacing).
bool turnedBetween(const Pose2D& a, const Pose2D& b);

// A neighbouring keyframe whose camera stood closer than this to the keyframe's saw the same picture
// re-projected (a turn in place moves the camera by the mount's offset times the turn: 7 cm for
// 0.2 m and 20°), not a view from elsewhere [m]. The neighbours' fixes and the route audit skip it.
constexpr double kSameViewpointM = 0.1;

class KeyframeStore {
 public:
  // Loads what `options.mode` needs of every keyframe. kInvalidInput naming the file for a corrupt
  // keyframe, for a route without keyframes, and when fast_hd/classic meets a keyframe without a
  // plane. fast_hd/classic with plane_feature_tolerance_px > 0: each keyframe keeps only the
  // features on its plane (restrictToPlaneFeatures). fast_hd with plane_sigma_from_neighbours:
  // each plane's error read from the route, or measured where the route does not store it.
  static Expected<KeyframeStore> load(const Route& route, const RepeatOptions& options);

  int size() const { return static_cast<int>(keyframes_.size()); }
  const KeyframeReference& at(int keyframe) const { return keyframes_[static_cast<std::size_t>(keyframe)]; }
  // The learned views of keyframe k (RouteExperience), newest first; each with its estimated pose
  // and covariance and the keyframe's plane carried into its camera frame (fast_hd/classic with
  // RepeatOptions::use_experiences; empty otherwise).
  const std::vector<KeyframeReference>& experiences(int keyframe) const {
    return experiences_[static_cast<std::size_t>(keyframe)];
  }
  int experienceCount() const;
  std::vector<Pose2D> poses() const;
  // Keyframe k's plane error as the store holds it: read from the route where every plane has it
  // stored (planeUncertaintyStored), measured at load otherwise (measurePlaneAgreement,
  // measureNeighbourFixes); nullopt without a plane, and unless fast_hd loaded with
  // RepeatOptions::plane_sigma_from_neighbours. What the teach run stores (measurePlaneUncertainty).
  std::optional<PlaneUncertainty> planeUncertainty(int keyframe) const;

 private:
  // Every vertical plane's homography under planar motion has the same form, and a side wall
  // close to the camera can out-vote the keyframe's wall in the robust fit: Fast-HD with the
  // keyframe's plane then gives a wrong pose that no residual reveals. So each keyframe keeps only
  // the features that move as its plane predicts to a neighbouring keyframe.
  void restrictToPlaneFeatures(const PinholeCamera& camera, const CameraMount& mount, const RepeatOptions& options);
  // Each plane against its neighbours' planes carried into its frame by the taught motion
  // (transferPlane): the two estimates differ by √2 σ when both have σ, so σ = RMS difference / √2
  // over the neighbours (normal angle [rad]; the distance at this plane's features' centroid
  // (plane_pivot), relative to the plane's), clamped to 0.5. A
  // neighbour that sees another surface (more than 0.6 rad or 60 % off) counts only when no
  // neighbour agrees and the two neighbours see one surface between them (this plane is the odd
  // one): at a corner of a building it sees the next wall (docs/math.md §3.6). A plane whose
  // neighbours all see other surfaces that differ from each other too (or whose one neighbour does,
  // at a route's end) was compared with nothing and takes the larger σ of the nearest compared
  // planes on each side. A neighbour whose plane is this one carried (a copy, within 1e-6) is
  // passed over for the next.
  void measurePlaneAgreement(const CameraMount& mount, const PinholeCamera& camera);
  // KeyframeReference::neighbour_fix_error_per_m2 of every keyframe whose neighbours' planes agree
  // with its own, or (a corner) that both neighbours were measured against: the stored features of
  // keyframes k ± 1 whose cameras stood at least 0.1 m away and that were not reached by turning
  // (turnedBetween), matched to its plane features and localized with its plane as the fast_hd mode
  // does (localizeAgainstPlane, checked; at least min_inliers inliers), against the teach run's
  // relative pose (docs/math.md §3.10); and where both neighbours were measured,
  // neighbour_fix_heading_intercept_rad (§3.8).
  void measureNeighbourFixes(const Route& route, const PinholeCamera& camera, const CameraMount& mount,
                             const RepeatOptions& options);
  // mu: each keyframe's lines triangulated with the two keyframes on each side (line_landmarks.h).
  void triangulateLines(const PinholeCamera& camera, const CameraMount& mount, const LineLandmarkOptions& options);

  // A keyframe's stored plane_uncertainty into its reference (nothing without one or a plane).
  void setPlaneUncertainty(std::size_t keyframe, const std::optional<PlaneUncertainty>& stored);
  // Each keyframe with a measured fix error gets the route's heading floor (its keyframes' heading
  // intercepts pooled with the configured floor `configured_rad`, pooledHeadingFloor), or its own
  // intercept where larger.
  void setHeadingFloor(double configured_rad);

  // Loads each keyframe's experiences (after the keyframes' planes are final).
  Status loadExperiences(const Route& route, const CameraMount& mount);

  std::vector<KeyframeReference> keyframes_;
  std::vector<std::vector<KeyframeReference>> experiences_;
  bool plane_uncertainty_known_ = false;  // measured or read (planeUncertainty)
};

}  // namespace homography_teach_repeat
