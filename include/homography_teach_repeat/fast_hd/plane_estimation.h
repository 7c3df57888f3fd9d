// Scene-plane parameters from the teach sequence (paper 000 §III with the corrections of
// docs/math.md §2):
//  - first plane (§2.1): classic decomposition of the first homography, keep the solutions with
//    positive depth AND planar motion; odometry breaks a remaining tie (β ≈ 0 leaves two planar
//    solutions); metric scale from the user-given distance of the plane to the first reference;
//  - propagation (§2.2): the plane in the next reference frame is n2 = R21 n1, d2 = d1 − n1·C;
//  - further planes (§2.3-2.4): from the homology of two plane homographies between the same
//    images, once the motion is known from the first plane.
// Homographies map reference pixels to current pixels, undistorted, any scale.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <vector>

#include "homography_teach_repeat/geometry/camera_tilt.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct FirstPlaneOptions {
  // A solution is a planar motion when max(|R(2,2) − 1|, |T_y|) is below this (T = t/d).
  double planar_motion_tolerance = 0.05;
  // Two planar solutions whose planarity errors differ by less than this factor are a tie.
  double tie_ratio = 10.0;
};

struct PlaneAndMotion {
  ScenePlane plane;         // plane in the reference frame, metric
  PlanarPose motion;        // second camera in the reference frame (Cx, Cz, θ12)
  int candidates_after_depth_test = 0;
  int candidates_after_planar_test = 0;
  bool resolved_by_odometry = false;
  bool resolved_by_third_view = false;
};

// `reference_pixels`: the inlier pixels of the reference image (for the positive-depth test).
// A tie (β ≈ 0: two planar solutions, docs/math.md §2.1) is broken by, in this order:
//  - `odometry_motion`: the second camera in the first camera's frame from odometry; the
//    candidate motion closest to it wins;
//  - `H31`: the homography of the same plane from the first image to a third one. The plane
//    normal in the first frame is the same for every homography from that image while the
//    spurious solutions depend on the motion, so the candidate whose normal is closest to a
//    planar solution of H31 wins.
// Status: kInvalidInput (distance not > 0, no pixels), kDegenerate (no solution survives, or a
// tie with neither odometry nor a third view, or a horizontal plane), the decomposition's
// failures.
Expected<PlaneAndMotion> estimateFirstPlane(const Eigen::Matrix3d& H21, const PinholeCamera& camera,
                                            const std::vector<Eigen::Vector2d>& reference_pixels,
                                            double first_plane_distance,
                                            const PlanarPose* odometry_motion = nullptr,
                                            const Eigen::Matrix3d* H31 = nullptr,
                                            const FirstPlaneOptions& options = {});

// docs/math.md §2.2: the plane expressed in the frame of a camera at `pose` (pose in the frame where
// `plane` is given). kDegenerate when that camera is on or behind the plane (d2 <= 0).
Expected<ScenePlane> transferPlane(const ScenePlane& plane, const PlanarPose& pose);

// docs/math.md §2.3-2.4: the second plane in the reference frame from the homographies of the first
// (H_first) and the second plane (H_second) between the same two images, the first plane and the
// motion (camera 2 in the reference frame, metric, from Fast-HD on the first plane).
// Status: kDegenerate (no translation: C = 0; κ = 0; the result is a plane through the camera),
// kNotFinite.
Expected<ScenePlane> estimateSecondPlane(const Eigen::Matrix3d& H_first,
                                         const Eigen::Matrix3d& H_second,
                                         const PinholeCamera& camera, const ScenePlane& first_plane,
                                         const PlanarPose& motion);

// docs/math.md §2.4, "simpler equivalent without the homology": the plane (in the reference frame)
// that induces H21 between two cameras whose metric motion is known (camera 2 in the reference
// frame, e.g. from odometry): m = (R21 − K⁻¹(H21/κ)K)ᵀ t21 / |t21|², n = m/|m|, d = 1/|m|.
// Status: kDegenerate (translation below `min_baseline` [m]: a rotation does not see the plane;
// κ = 0; the plane at infinity or behind the camera), kNotFinite.
Expected<ScenePlane> planeFromHomographyAndMotion(const Eigen::Matrix3d& H21, const PinholeCamera& camera,
                                                 const PlanarPose& motion, double min_baseline = 1e-6);

// The same when the second camera may be tilted (pitch, roll) relative to the first, as a body on
// a road is while the images are levelled by one constant mount (docs/math.md §2.5): H21 = K T R21
// (I − C nᵀ/d) K⁻¹ with T = Rx(pitch) Rz(roll) unknown. The parts of K⁻¹H21K across C fix the
// scale and T (six equations in three unknowns, Gauss-Newton); the plane then follows as above
// from T⁻¹ H21. Status: as above; kDegenerate also when T is not observable or its angles
// exceed `max_tilt` [rad].
struct PlaneAndTilt {
  ScenePlane plane;
  double pitch = 0.0;  // [rad], about the camera's x axis
  double roll = 0.0;   // [rad], about its optical axis
  Eigen::Matrix3d tilt() const { return cameraTilt(pitch, roll).T; }  // T
};
Expected<PlaneAndTilt> planeAndTiltFromHomographyAndMotion(const Eigen::Matrix3d& H21, const PinholeCamera& camera,
                                                          const PlanarPose& motion, double min_baseline = 1e-6,
                                                          double max_tilt = 0.1);

// One step of the teach sequence: the homography from reference k to reference k+1 (of the
// plane tracked along the route), the inlier reference pixels, and the odometry motion.
struct ReferencePair {
  bool has_homography = true;  // false: no homography between the two keyframes (odometry mode)
  Eigen::Matrix3d H_next_from_current = Eigen::Matrix3d::Identity();
  std::vector<Eigen::Vector2d> reference_pixels;
  bool has_odometry = false;
  PlanarPose odometry_motion;  // reference k+1 in the frame of reference k
};

struct RouteSequencePlanes {
  std::vector<ScenePlane> planes;    // plane in each reference frame (size = pairs + 1)
  std::vector<PlanarPose> motions;   // reference k+1 in the frame of reference k (Fast-HD)
};

// Runs §2.1 on the first pair (a tie without odometry is broken with the third view
// H20 = H21·H10 when there is a second pair), then for each next pair Fast-HD with the propagated
// plane (§2.2).
Expected<RouteSequencePlanes> estimatePlanesAlongRoute(const std::vector<ReferencePair>& pairs,
                                                      const PinholeCamera& camera,
                                                      double first_plane_distance,
                                                      const FirstPlaneOptions& options = {});

// The planes along a route from odometry (a route that passes several walls, e.g. round a room):
// each keyframe's plane from its pair's homography and the odometry motion
// (planeFromHomographyAndMotion) when the pair has at least `min_baseline` [m] of translation and
// the result is plausible (in front of the camera, not a floor/ceiling, nearer than
// `max_distance`), or from the pair before it when that one turned less (straighter_pair_margin);
// otherwise the previous keyframe's plane transferred by the motion (§2.2; e.g. while turning in
// place). The last keyframe inherits the transfer of the one before it.
// Status: kInvalidInput (no pairs, a pair without odometry), kDegenerate (no keyframe could be
// estimated before the first transfer was needed).
struct OdometryPlaneOptions {
  double min_baseline = 0.15;  // [m]
  double max_distance = 50.0;  // [m]
  // Estimate each pair's relative tilt with its plane (planeAndTiltFromHomographyAndMotion): for
  // images levelled by one constant mount rotation, whose body pitches and rolls between keyframes.
  bool estimate_tilt = false;
  // A keyframe's plane comes from the pair that starts at it (k -> k+1) unless the pair that ends
  // at it (k-1 -> k) turned less by more than this margin [rad]: then from that pair, transferred
  // into keyframe k by the motion (§2.2). A pair that turns sees the wall from two directions with
  // little overlap, and its plane was degrees off where the straight pair before it was exact (the
  // simulator's gallery: 4.9° and 8 mm against 0.08° and 1 mm at keyframe 26; docs/math.md §2.6).
  // Negative: always the pair that starts at the keyframe.
  double straighter_pair_margin = 0.05;
  // A closed route (the teach run ended where it started): the camera motion from the last keyframe
  // to the first. The keyframes after the last pair with a plane of its own (the closing corner,
  // turned in place) are otherwise filled forwards with the wall the last leg faced; each of them
  // that faces nearer the first keyframe's heading than that leg's takes the first keyframe's plane
  // instead, carried back along the closing motion, as the last keyframe of a corner inside the
  // route takes the next leg's wall from its own pair (docs/math.md §2.6).
  std::optional<PlanarPose> closing_motion;
};
// Whether an estimated plane is one the odometry planes take: valid, a wall (not a floor or
// ceiling) in front of the camera, nearer than options.max_distance.
bool isPlausibleWall(const ScenePlane& plane, const OdometryPlaneOptions& options);

Expected<RouteSequencePlanes> estimatePlanesFromOdometry(const std::vector<ReferencePair>& pairs,
                                                        const PinholeCamera& camera,
                                                        const OdometryPlaneOptions& options = {});

// How each match between a keyframe's image and a neighbouring view agrees with the keyframe's
// plane (the repeat keeps a keyframe's features that lie on it; docs/math.md §2.5, §2.6):
// `matches` undistorted pixels, reference = the keyframe; `motion` the neighbour's camera in the
// keyframe's frame; a match is on the plane when its current pixel lies within `tolerance_px` of
// where the plane-induced homography puts its reference pixel. With `tilt_fit` (images that are not
// level) the pair's own robust homography gives the neighbour's tilt against the keyframe
// (planeAndTiltFromHomographyAndMotion) and the prediction includes it; the plane stays
// `plane`. Where the plane predicts little parallax against the rotation alone (near the direction
// of travel, or towards the plane's vanishing line), a point far off the plane moves alike and its
// match confirms nothing: it counts as confirming only where the two predictions lie at least
// kConfirmingParallax tolerances apart.
enum class PlaneMatchRating { kOffThePlane, kOnWithoutParallax, kOnWithParallax };
constexpr double kConfirmingParallax = 2.0;
std::vector<PlaneMatchRating> ratePlaneMatches(const PointMatches& matches, const PinholeCamera& camera,
                                               const PlanarPose& motion, const ScenePlane& plane,
                                               double tolerance_px,
                                               const std::optional<RobustHomographyOptions>& tilt_fit);

}  // namespace homography_teach_repeat
