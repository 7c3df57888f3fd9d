// Gating visual poses against odometry. Wheel odometry drifts slowly but is never wildly wrong
// over a short distance; a visual pose is wildly wrong when the image was matched to the wrong
// wall or a degenerate view slipped through the other checks (seen in the simulator while
// turning in place at a corner: one pose 1.9 m off with a covariance of centimetres). So every
// visual pose is compared with the pose the odometry predicts from the last accepted one:
//   predicted = visual_a ∘ (odom_a⁻¹ ∘ odom),
// and refused when it differs by more than an allowance that grows with the odometry motion since
// then (position: tolerance + drift_fraction · distance; heading: tolerance +
// heading_drift_per_metre · distance + rotation_drift_fraction · |rotation|).
// Checking against the last accepted pose only would let an estimate that creeps away a little at
// every frame through (seen in the simulator: a pose moving at 60 % of the robot's speed, each
// frame within the allowance), so the oldest accepted pose within `window` metres of odometry
// travel is checked as well.
// Lasting disagreement means the reference was the wrong one (e.g. a wrong first fix, or a long
// outage with more drift than allowed): `switch_after` consecutive refused poses that agree with
// each other through odometry (each with the first of them) become the new reference.
#pragma once

#include <deque>
#include <optional>
#include <string>

#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct OdometryGateOptions {
  double position_tolerance = 0.15;      // [m] > 0
  double heading_tolerance = 0.10;       // [rad] > 0
  double drift_fraction = 0.10;          // [m per m travelled] >= 0
  double heading_drift_per_metre = 0.05; // [rad per m travelled] >= 0
  double rotation_drift_fraction = 0.05; // [rad per rad turned] >= 0
  int switch_after = 5;                  // >= 1
  double window = 1.0;                   // [m] > 0

  void validate() const;  // throws std::invalid_argument naming the bad field
};

class OdometryGate {
 public:
  explicit OdometryGate(const OdometryGateOptions& options);  // validates

  // A visual pose (route frame) with the odometry pose at the same stamp. Status ok when it is
  // accepted; kNoConsensus naming the disagreement when refused; kInvalidInput for non-finite
  // poses. The first pose is accepted as the reference.
  Status check(const Pose2D& visual, const Pose2D& odometry);
  // Whether check() would accept the pose as agreeing with the reference, without changing the
  // gate (no acceptance, no count towards a switch): for choosing among several references' poses
  // of the same frame. ok, or kNoConsensus naming the disagreement; kInvalidInput as check().
  Status agrees(const Pose2D& visual, const Pose2D& odometry) const;
  // Forget the reference (a new run, a relocalization ordered from outside).
  void reset();
  int refusedInARow() const { return candidates_; }
  // Whether the last check() accepted its pose as a new reference after `switch_after` refusals
  // (the old reference was the wrong one: a filter on the poses must start again from this one).
  bool switchedReference() const { return switched_; }
  bool hasReference() const { return !accepted_.empty(); }
  const OdometryGateOptions& options() const { return options_; }

 private:
  struct Anchor {
    Pose2D visual;
    Pose2D odometry;
  };
  void accept(const Anchor& anchor);
  // The excess of the disagreement over its allowance: <= 0 when `visual` agrees with `anchor`.
  double excess(const Anchor& anchor, const Pose2D& visual, const Pose2D& odometry,
                std::string* description) const;

  OdometryGateOptions options_;
  std::deque<Anchor> accepted_;      // accepted poses within `window` of travel, newest last
  std::optional<Anchor> candidate_;  // the first refused pose of the current run
  int candidates_ = 0;               // consecutive refused poses that agree with each other
  bool switched_ = false;
};

}  // namespace homography_teach_repeat
