// The localization filter of the repeat (modes hybrid and mu; docs/math.md §7): wheel odometry
// fused with Fast-HD pose fixes, μ fixes of vertical lines (paper 002 §5) and line landmark fixes.
// An extended Kalman filter on the route-frame base pose (x, y, yaw):
//  - predict: the odometry increment since the last reading, composed onto the estimate; the
//    covariance grows by `position_variance_per_metre` (along and across the motion) and
//    `heading_variance_per_metre` per metre travelled, `heading_variance_per_radian` per radian
//    turned.
//  - correct (correctWithMu): μ = h12/h22 measured against a reference keyframe whose wall
//    (normal, distance from the teach phase) is known. The measurement model is the exact μ of
//    the plane-induced 1D homography (docs/math.md §4.4-4.5, planeHomography1d): μ depends on the
//    heading *and* on the lateral offset (μ ≈ f (θ + tx/d)), the "over-rotation" paper 002
//    relies on. Treating μ as a pure heading (f tanθ) puts a lateral offset of 15 cm into the
//    heading as 5-9° near a wall (measured in the simulator) and the odometry then carries that
//    error through the next turn; the filter instead splits the innovation between heading and
//    lateral position by their covariances, and the two separate as the robot moves (the depth
//    of the wall changes, a heading error turns into lateral motion).
//  - correctHeading: a heading-only fix (a reference without a known wall), variance
//    `heading_fix_variance`.
//  - correctWithLineLandmarks: the keyframe's lines triangulated with their own depths
//    (line_landmarks.h, docs/math.md §4.8), each current line a bearing of the robot pose: one
//    consensus on the heading picks the associations, one iterated update takes them all. Where
//    the lines stand at many depths (a street) no single wall models them.
//  - correctWithPose: a full pose fix (a Fast-HD pose with its covariance, hybrid mode; docs/math.md
//    §7.1), the update with H = I. Vetted by the caller (the odometry gate), not here.
// Every fix tried leaves its normalized innovation squared for the integrity monitor
// (takeInnovation; docs/math.md §7.2).
// A μ fix must be confirmed by the previous frame's fix against the same keyframe (max_mu_step_px)
// and is refused when its innovation exceeds `innovation_gate` standard deviations (a wrong line
// association gave fixes 38° and 97° off in the simulator); `refused_before_reset` refusals in a
// row mean the estimate is the wrong one: the covariance is widened and the next fix is taken.
// The pose lives in the route frame (the teach run's odometry frame); alignment() is the
// map -> odom transform, estimate ∘ odom⁻¹.
#pragma once

#include <Eigen/Core>

#include <optional>
#include <utility>
#include <vector>

#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/mu/heading_1d.h"
#include "homography_teach_repeat/mu/line_landmarks.h"
#include "homography_teach_repeat/mu/wall_mu.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct LocalizationFilterOptions {
  double initial_position_variance = 0.0025;   // [m²] at align() ((5 cm)²: placed at the keyframe)
  double position_variance_per_metre = 0.0025;  // [m²/m] (5 cm after 1 m)
  double heading_fix_variance = 7.6e-5;         // [rad²] ((0.5°)²): align() and correctHeading()
  double heading_variance_per_metre = 1.0e-3;   // [rad²/m] (1.8° after 1 m)
  double heading_variance_per_radian = 1.0e-4;  // [rad²/rad] (turning in place)
  // [m²/rad] a base turning in place does not turn about exactly its centre (wheel slip, a caster):
  // without it a robot turning at a corner fused pose after pose with no position noise in between
  // and claimed a position to a tenth of a millimetre (the simulator's gallery: NEES 200-700).
  double position_variance_per_radian = 2.5e-5;
  double min_mu_variance = 4.0;                 // [px²] floor of a μ measurement's variance
  double innovation_gate = 4.0;                 // [σ] > 0
  // A pose fix (correctWithPose) whose normalized innovation squared exceeds this is refused (> 0;
  // 22 is χ² with 3 degrees of freedom at the tail of the scalar 4 σ gate, 6e-5): a Fast-HD pose
  // that passed its own checks and the odometry gate can still disagree with the filter by much
  // more than both admit (the simulator's gallery: poses 8 cm / 2.5° off at a corner claiming
  // millimetres, NEES 60000). Refusals count towards refused_before_reset as the μ fixes'.
  double pose_innovation_gate = 22.0;
  // [0, 1] The share of a pose fix's pixel-noise covariance that repeated fixes against one
  // keyframe do not average away: the keyframe's own features are in every fix (half of the
  // noise, docs/math.md §3.4: σ on all 4n coordinates). After a pose fix the filter's covariance is
  // kept at least the fix's shared part, its model covariance (the keyframe plane's own error)
  // plus this fraction of the rest (docs/math.md §7.1). 0: every fix independent (a robot
  // standing at the end of the simulator's room for 20 s claimed a tenth of a millimetre with 1 mm
  // errors: NEES 63).
  double pose_common_fraction = 0.25;  // chosen in closed loop (docs/math.md §7.1)
  int refused_before_reset = 20;                // >= 1
  // A μ fix is taken only when it agrees with the previous frame's μ against the same keyframe:
  // the change of μ between the two within this [px] of the change the odometry predicts, the
  // frames at most `max_confirmation_distance` [m] of odometry apart. A wrong line association is
  // a single frame (in the simulator ~2 % of the fixes were 30-300 px off, never two in a row
  // agreeing), and the filter's own gate lets it through after turns, when the heading is
  // uncertain.
  double max_mu_step_px = 10.0;                 // > 0
  double max_confirmation_distance = 0.3;       // [m] > 0
  double reset_position_variance = 0.04;        // [m²] added after refused_before_reset ((20 cm)²)
  double reset_heading_variance = 0.03;         // [rad²] added after refused_before_reset ((10°)²)
  // Line landmark fixes (correctWithLineLandmarks):
  double line_sigma_px = 1.0;                   // [px] of a current line's x, > 0
  int min_landmark_lines = 5;                   // fewer agreeing lines: no fix, >= 2
  double line_inlier_gate = 3.0;                // [σ] a line agrees with the consensus, > 0
  // [rad] >= 0: a rotation common to all lines of a fix that their independent noise does not
  // model (the keyframe's taught yaw, the camera's tilt; as PlanarPoseEstimatorOptions::
  // heading_sigma_rad, docs/math.md §3.8): its variance along ∂x/∂yaw of every line.
  double line_heading_sigma_rad = 0.0;
  // [m] >= 0: the same for a shift common to all lines (the keyframe's taught position relative to
  // the neighbours its landmarks were triangulated with). Without it the fixes on KITTI 07 came
  // out 3-15 cm off with a claimed 1-3 cm (NEES mean 44-77 in a segment; 1.4-4.0 with 0.05 m).
  double line_position_sigma_m = 0.05;
  double line_max_brightness_difference = 40.0; // [grey levels] teach and repeat line alike, > 0

  void validate() const;  // throws std::invalid_argument naming the bad field
};

// The normalized innovation squared of one fix: νᵀ S⁻¹ ν with `dof` components (a consistent
// filter gives a mean of `dof`), and whether the fix was taken.
struct FilterInnovation {
  double nis = 0.0;
  int dof = 1;
  bool accepted = false;
};

class LocalizationFilter {
 public:
  // Throws std::invalid_argument on invalid options.
  explicit LocalizationFilter(const LocalizationFilterOptions& options = {});

  // The robot is at `route_pose` while its odometry reads `odom_pose`. kInvalidInput on
  // non-finite input.
  Status align(const Pose2D& route_pose, const Pose2D& odom_pose);
  // The same with a known (x, y, yaw) covariance (a first Fast-HD pose, or one the odometry gate
  // took as its new reference); kInvalidInput also for a covariance that is not symmetric positive
  // definite.
  Status align(const Pose2D& route_pose, const Pose2D& odom_pose, const Eigen::Matrix3d& covariance);
  bool aligned() const { return aligned_; }

  // A μ fix taken when the odometry read `odom_pose`. kInvalidInput on non-finite input or a bad
  // observation, kNoConsensus when not aligned yet, not confirmed by the previous frame (see
  // max_mu_step_px; the first fix of a run waits for its confirmation) or refused by the
  // innovation gate, kDegenerate when the wall is not in front of both cameras.
  Status correctWithMu(const MuObservation& observation, const Pose2D& odom_pose);
  // A heading-only fix: the robot's yaw in the route frame was `route_yaw` when its odometry
  // read `odom_pose`, with variance `variance` [rad²] (at least heading_fix_variance). Same
  // statuses (the gate applies).
  Status correctHeading(double route_yaw, const Pose2D& odom_pose, double variance = 0.0);
  // A fix from the current lines against the reference's line landmarks (docs/math.md §4.9): each
  // landmark is projected at the predicted pose and paired with the current lines of its
  // appearance within innovation_gate of its predicted x; the heading change most pairs agree on
  // (within line_inlier_gate of what the position uncertainty allows each line) picks one line per
  // landmark; an iterated EKF update takes them all. Returns the lines used. kNoConsensus: not
  // aligned, fewer than min_landmark_lines agree, or a second heading is nearly as well supported
  // (a row of windows); refusals in a row widen the covariance as the innovation gate's do.
  // kInvalidInput: non-finite input, a landmark without its reference line.
  Expected<int> correctWithLineLandmarks(const LineLandmarkObservation& observation, const Pose2D& odom_pose);

  // A pose fix: base_link at `measured` (route frame) with the (x, y, yaw) `measurement_covariance`
  // when the odometry read `odom_pose` (docs/math.md §7.1); `shared_covariance` is the part of it
  // that every fix against the same reference shares (RepeatEstimate::model_covariance). Returns the normalized innovation
  // squared (3 degrees of freedom). kInvalidInput: non-finite input or a covariance that is not
  // symmetric positive definite; kNoConsensus: not aligned, or refused by pose_innovation_gate
  // (after refused_before_reset refusals in a row the covariance is widened and the fix taken).
  Expected<double> correctWithPose(const Pose2D& measured, const Eigen::Matrix3d& measurement_covariance,
                                   const Pose2D& odom_pose,
                                   const Eigen::Matrix3d& shared_covariance = Eigen::Matrix3d::Zero());
  // The innovation of the last fix tried since the last call (nullopt: none; a line landmark fix
  // leaves its lines' innovation against the prior), for the integrity monitor.
  std::optional<FilterInnovation> takeInnovation() { return std::exchange(last_innovation_, std::nullopt); }

  // The robot pose in the route frame for the odometry reading `odom_pose`, and its (x, y, yaw)
  // covariance. kNoConsensus when not aligned, kInvalidInput on non-finite input.
  Expected<Pose2D> routePose(const Pose2D& odom_pose);
  const Eigen::Matrix3d& covariance() const { return covariance_; }
  // The pose routePose would give for `odom_pose`, without moving the filter on (a prediction for
  // matching; the filter only ever integrates odometry forward through routePose and the fixes).
  Expected<Pose2D> predictedPose(const Pose2D& odom_pose) const;
  // Odometry distance [m] travelled since the last accepted fix (or the alignment).
  double distanceSinceFix() const { return distance_since_fix_; }
  int refusedInARow() const { return refused_in_a_row_; }

  // The map -> odom transform (route frame -> odometry frame).
  Pose2D alignment() const;

 private:
  // The odometry motion since the last prediction (kInvalidInput: non-finite odometry,
  // kNoConsensus: not aligned yet).
  Expected<Pose2D> odometryStepTo(const Pose2D& odom_pose) const;
  Status predict(const Pose2D& odom_pose);
  // Scalar EKF update; `innovation` = measured − predicted, `jacobian` = ∂predicted/∂(x, y, yaw).
  Status update(double innovation, const Eigen::RowVector3d& jacobian, double variance, const char* what);
  // A refused fix: after refused_before_reset in a row the covariance is widened (lasting
  // disagreement means the estimate is the wrong one). Returns whether it was widened.
  bool countRefusal();

  struct PreviousMu {
    int reference_id = -1;
    double mu = 0.0;
    Pose2D odom;
  };

  LocalizationFilterOptions options_;
  std::optional<PreviousMu> previous_mu_;
  bool aligned_ = false;
  Pose2D estimate_;
  Eigen::Matrix3d covariance_ = Eigen::Matrix3d::Zero();
  Pose2D last_odom_;
  double distance_since_fix_ = 0.0;  // [m]
  int refused_in_a_row_ = 0;
  std::optional<FilterInnovation> last_innovation_;
};

}  // namespace homography_teach_repeat
