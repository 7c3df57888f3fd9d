// What a taught route offers the repeat, keyframe by keyframe, before a robot is sent along it
// (docs/route_audit.md): the features on the keyframe's plane and how well the plane is known, the
// covariance a Fast-HD fix would have a given distance to the side of the path (the repeat's own
// covariance model, docs/math.md §3.4-3.8, on the keyframe's plane features moved by the plane's
// homography), the vertical lines and line landmarks the μ mode has there, and how much the
// keyframe looks like another part of the route (aliasing). Each keyframe gets the list of its
// weaknesses, each naming the threshold it misses. The route_info tool prints and draws it.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/homography/local_stretch.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {

struct RouteAuditOptions {
  // The settings the repeat will run with: its covariance terms, matching and line options.
  RepeatOptions repeat;
  double probe_offset_m = 0.3;  // the predicted fix: this far to the right of the keyframe [m, > 0]
  bool aliasing = true;         // match every keyframe against every other (n² matchings)
  int same_place_keyframes = 2;  // keyframes this many indices apart or closer are the same place
  // A keyframe is weak for fast_hd with fewer features on its plane, a predicted fix less certain
  // than these, or another keyframe matching at least max_alias_ratio of its neighbour's inliers;
  // weak for mu with fewer vertical lines than min_lines.
  int min_plane_features = 40;
  double max_position_sigma_m = 0.05;
  double max_heading_sigma_rad = 0.0087;  // 0.5°
  double max_alias_ratio = 0.5;
  // Another keyframe that matches this one is the same place seen again, not an alias, when the
  // pose it gives for this keyframe is within these of the taught one [m, rad].
  double alias_position_tolerance_m = 0.5;
  double alias_heading_tolerance_rad = 0.087;
  int min_lines = 10;
  // Each keyframe's pixel noise relative to the route's is the repeat's (repeat.pixel_noise_per_keyframe:
  // its teach pairs' residual over the route's; keyframePixelNoiseScale), so the prediction is
  // the covariance the repeat will claim there.
  // How much noisier a match is where the other view sees its keypoint stretched (matchStretchNoiseScale):
  // the gain κ of 1 + κ (a − 1), a the local stretch [0-10; 0: not modelled]. It scales the
  // prediction's pixel σ by the probe's stretch (docs/route_audit.md: 2, measured in the
  // simulator's room).
  double stretch_noise_gain = 2.0;
  // How much rarer a match is where the other view stretches its keypoint: a plane feature matches
  // with a chance exp(−λ (a − 1)) times its keyframe's own (matchChanceScale), λ this decay [0-10;
  // 0: not modelled]. The neighbours match at their stretch, the probe at its own, so the part the
  // probe is expected to match is the neighbour's times the ratio of the two (docs/route_audit.md:
  // 1.7-1.8, measured in the simulator's room, where a stretch of 1.35 halves the matches).
  double match_stretch_decay = 1.8;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

struct KeyframeAudit {
  int keyframe = 0;
  Pose2D pose;                 // route frame
  int features = 0;            // stored
  bool has_plane = false;
  double plane_distance_m = 0.0;
  double plane_normal_sigma_rad = 0.0;  // from the neighbours' planes (0: not measured)
  double plane_distance_sigma = 0.0;    // [fraction]
  // Where its neighbours' planes agree with it: the RMS error per metre of their images relocalized
  // against it (camera frame: x, z, heading [rad/m]; KeyframeReference::neighbour_fix_error_per_m2).
  std::optional<Eigen::Vector3d> neighbour_fix_error_per_m;
  // With it, the heading floor of a fix against it [rad] (KeyframeReference::neighbour_fix_heading_floor_rad).
  std::optional<double> neighbour_fix_heading_floor_rad;
  int plane_features = 0;               // the features the repeat matches (on the plane)
  // (x forward, y left, yaw) of base_link for a fix probe_offset_m to the right; absent with the
  // reason in prediction_problem.
  std::optional<Eigen::Matrix3d> predicted_covariance;
  // The part of predicted_covariance that differs from one fix to the next there: the current
  // image's pixel noise, and the keyframe image's over the keypoints two fixes do not both match
  // (1 − expected_match_fraction of it). The rest of the keyframe image's noise, its plane's error
  // and the heading floor are the same in every fix against it, a bias of the place: the spread
  // of repeated fixes about their mean (docs/route_audit.md, docs/math.md §3.4). Present with
  // predicted_covariance.
  std::optional<Eigen::Matrix3d> predicted_fix_to_fix_covariance;
  int predicted_matches = 0;             // the plane features that fix sees
  // Of those, the part it matches: the better neighbour's part (its image's features matched to
  // this keyframe as the repeat matches a current image: the inliers over this keyframe's plane
  // features in that neighbour's view, neighbour_plane_features_in_view), times
  // match_stretch_scale. Only a neighbour whose camera stood elsewhere (not turned in place) and
  // that sees min_inliers of them counts; with none (-1), the route's median part over the
  // stretch of its neighbours' views times the probe's chance scale, and on a route where no
  // keyframe has one, neighbour_inliers / plane_features.
  double expected_match_fraction = 1.0;
  int neighbour_plane_features_in_view = -1;
  double neighbour_match_fraction = -1.0;  // that neighbour's inliers over them; -1 as above
  // How much less likely a feature is to match from the probe than from that neighbour, for how
  // much more each view stretches the features it sees (matchChanceScale of the probe's over the
  // neighbour's, match_stretch_decay; with the route's part, the probe's alone; 1: not modelled).
  double match_stretch_scale = 1.0;
  std::string prediction_problem;
  int lines = 0;
  int line_landmarks = 0;
  int neighbour_inliers = -1;  // the better of the previous and the next keyframe's image matched to it; -1: a route of one keyframe
  // The keyframe's pixel σ over the route's, as the repeat scales it (keyframePixelNoiseScale; 1
  // with repeat.pixel_noise_per_keyframe off).
  double pixel_noise_scale = 1.0;
  // The probe's pixel σ over the keyframe's: its view stretches the keyframe's plane features
  // (matchStretchNoiseScale with stretch_noise_gain; 1: not at all, or not modelled). The
  // prediction's pixel σ is the route's × pixel_noise_scale × stretch_noise_scale.
  double stretch_noise_scale = 1.0;
  int alias_keyframe = -1;     // the other keyframe that matched best with a pose that is not the taught one
  int alias_inliers = 0;
  std::vector<std::string> fast_hd_weaknesses;
  std::vector<std::string> mu_weaknesses;
};

struct RouteAudit {
  std::vector<KeyframeAudit> keyframes;
  int weak_for_fast_hd = 0;
  int weak_for_mu = 0;
  std::vector<std::string> notes;  // route-wide (e.g. no planes at all)
};

// kInvalidInput for invalid options, a route without keyframes, or a corrupt keyframe file.
Expected<RouteAudit> auditRoute(const Route& route, const RouteAuditOptions& options);

// What can be said of a keyframe the moment it is stored, before any plane is estimated (the teach
// node warns with it): fewer features than min_plane_features (fast_hd: its plane can only have
// fewer), fewer vertical lines than min_lines (mu). Each string names the threshold.
std::vector<std::string> storedKeyframeWeaknesses(int features, int lines, const RouteAuditOptions& options);

// "fast_hd: 3, 4 (no plane ...); mu: 0-2" style summary of the weak keyframes, for logs and status
// messages; empty when none is weak.
std::string weakKeyframeSummary(const RouteAudit& audit);

}  // namespace homography_teach_repeat
