#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/localization/odometry_gate.h"

using namespace homography_teach_repeat;

namespace {

// Odometry with a different origin from the route frame (its frame is whatever the base started
// with) and a small drift: the gate compares motions, not absolute poses.
const Pose2D kOdometryOrigin(5.0, -2.0, 1.0);

Pose2D odometryOf(const Pose2D& truth, double drift = 0.0) {
  return kOdometryOrigin.compose(Pose2D(truth.x * (1.0 + drift), truth.y, truth.yaw + drift));
}

}  // namespace

TEST(OdometryGate, AcceptsPosesThatMoveWithOdometry) {
  OdometryGate gate{OdometryGateOptions()};
  for (int k = 0; k <= 40; ++k) {  // 4 m straight, 2 % scale drift, then a turn in place
    const Pose2D truth(0.1 * k, 0.0, 0.0);
    EXPECT_TRUE(gate.check(truth, odometryOf(truth, 0.02 * k / 40.0)).isOk()) << k;
  }
  for (int k = 1; k <= 20; ++k) {
    const Pose2D truth(4.0, 0.0, 0.08 * k);
    EXPECT_TRUE(gate.check(truth, odometryOf(truth)).isOk()) << k;
  }
}

// The simulator's failure: while turning in place one pose lands 1.9 m away.
TEST(OdometryGate, RefusesAJumpWhileTurningInPlace) {
  OdometryGate gate{OdometryGateOptions()};
  ASSERT_TRUE(gate.check(Pose2D(1.0, 1.0, 0.0), odometryOf(Pose2D(1.0, 1.0, 0.0))).isOk());
  ASSERT_TRUE(gate.check(Pose2D(1.0, 1.0, 0.3), odometryOf(Pose2D(1.0, 1.0, 0.3))).isOk());
  const Status refused = gate.check(Pose2D(2.8, 1.6, 0.6), odometryOf(Pose2D(1.0, 1.0, 0.6)));
  EXPECT_EQ(refused.code(), StatusCode::kNoConsensus);
  EXPECT_NE(refused.message().find("odometry"), std::string::npos) << refused.message();
  // A heading jump alone too.
  EXPECT_FALSE(gate.check(Pose2D(1.0, 1.0, 1.5), odometryOf(Pose2D(1.0, 1.0, 0.65))).isOk());
  // The next good pose is accepted against the last accepted one.
  EXPECT_TRUE(gate.check(Pose2D(1.0, 1.0, 0.7), odometryOf(Pose2D(1.0, 1.0, 0.7))).isOk());
  EXPECT_EQ(gate.refusedInARow(), 0);
}

// The allowance grows with the odometry motion: after a long outage a drifted-but-right pose passes.
TEST(OdometryGate, AllowanceGrowsWithDistance) {
  OdometryGateOptions options;
  OdometryGate gate(options);
  ASSERT_TRUE(gate.check(Pose2D(0, 0, 0), odometryOf(Pose2D(0, 0, 0))).isOk());
  // 5 m later the odometry is 0.3 m short: within 0.15 + 0.1 * 5 = 0.65 m.
  EXPECT_TRUE(gate.check(Pose2D(5.0, 0, 0), odometryOf(Pose2D(4.7, 0, 0))).isOk());
  // 0.1 m later a 0.3 m disagreement is not.
  EXPECT_FALSE(gate.check(Pose2D(5.4, 0, 0), odometryOf(Pose2D(4.8, 0, 0))).isOk());
}

// A wrong reference (e.g. the first fix was the wrong wall) is replaced once `switch_after`
// consecutive refused poses agree with each other; scattered wrong poses never do that.
TEST(OdometryGate, SwitchesReferenceAfterConsistentRefusals) {
  OdometryGateOptions options;
  options.switch_after = 3;
  OdometryGate gate(options);
  ASSERT_TRUE(gate.check(Pose2D(3.0, 2.0, 0.0), odometryOf(Pose2D(0, 0, 0))).isOk());  // wrong
  EXPECT_FALSE(gate.check(Pose2D(0.1, 0, 0), odometryOf(Pose2D(0.1, 0, 0))).isOk());
  EXPECT_FALSE(gate.check(Pose2D(0.2, 0, 0), odometryOf(Pose2D(0.2, 0, 0))).isOk());
  EXPECT_EQ(gate.refusedInARow(), 2);  // both agree with the first refused pose
  EXPECT_TRUE(gate.check(Pose2D(0.3, 0, 0), odometryOf(Pose2D(0.3, 0, 0))).isOk());
  EXPECT_TRUE(gate.check(Pose2D(0.4, 0, 0), odometryOf(Pose2D(0.4, 0, 0))).isOk());

  OdometryGate scattered(options);
  ASSERT_TRUE(scattered.check(Pose2D(0, 0, 0), odometryOf(Pose2D(0, 0, 0))).isOk());
  for (int k = 1; k <= 6; ++k) {
    const Pose2D wrong(k % 2 == 0 ? 2.0 : -2.0, 1.5, 0.0);
    EXPECT_FALSE(scattered.check(wrong, odometryOf(Pose2D(0.01 * k, 0, 0))).isOk()) << k;
    EXPECT_EQ(scattered.refusedInARow(), 1);
  }
}

TEST(OdometryGate, BadInput) {
  OdometryGate gate{OdometryGateOptions()};
  EXPECT_EQ(gate.check(Pose2D(NAN, 0, 0), Pose2D()).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(gate.check(Pose2D(), Pose2D(0, INFINITY, 0)).code(), StatusCode::kInvalidInput);
  EXPECT_FALSE(gate.hasReference());  // invalid input is never a reference
  ASSERT_TRUE(gate.check(Pose2D(), Pose2D()).isOk());
  EXPECT_TRUE(gate.hasReference());
  gate.reset();
  EXPECT_FALSE(gate.hasReference());
  OdometryGateOptions bad;
  bad.position_tolerance = 0.0;
  EXPECT_THROW(OdometryGate{bad}, std::invalid_argument);
  bad = OdometryGateOptions();
  bad.drift_fraction = -1.0;
  EXPECT_THROW(OdometryGate{bad}, std::invalid_argument);
  bad = OdometryGateOptions();
  bad.switch_after = 0;
  EXPECT_THROW(OdometryGate{bad}, std::invalid_argument);
}

// An estimate that creeps away a little at every frame (here it moves at 60 % of the robot's
// speed: 4 cm per 10 cm step, each step within the allowance) is caught against the oldest
// accepted pose within `window` of travel.
TEST(OdometryGate, CatchesAPoseCreepingAway) {
  OdometryGate gate{OdometryGateOptions()};
  int first_refusal = -1;
  for (int k = 0; k <= 20 && first_refusal < 0; ++k) {
    const Pose2D truth(0.1 * k, 0.0, 0.0);
    if (!gate.check(Pose2D(0.06 * k, 0.0, 0.0), odometryOf(truth)).isOk()) first_refusal = k;
  }
  EXPECT_GT(first_refusal, 0);
  EXPECT_LE(first_refusal, 12);  // within about the window (1 m) of travel
}

// agrees(): the verdict check() would give on agreement, without accepting or counting: asking
// about many refused poses never switches the reference, and the agreeing pose is not stored.
TEST(OdometryGate, AgreesHasNoSideEffects) {
  OdometryGateOptions options;
  options.switch_after = 2;
  OdometryGate gate(options);
  EXPECT_TRUE(gate.agrees(Pose2D(9.0, 9.0, 0.0), odometryOf(Pose2D(0, 0, 0))).isOk());  // no reference yet
  ASSERT_TRUE(gate.check(Pose2D(0, 0, 0), odometryOf(Pose2D(0, 0, 0))).isOk());
  for (int k = 0; k < 5; ++k) {
    const Status refused = gate.agrees(Pose2D(1.0, 0.5, 0.0), odometryOf(Pose2D(0.1, 0, 0)));
    EXPECT_EQ(refused.code(), StatusCode::kNoConsensus) << k;
    EXPECT_NE(refused.message().find("odometry"), std::string::npos) << refused.message();
  }
  EXPECT_EQ(gate.refusedInARow(), 0);
  EXPECT_TRUE(gate.agrees(Pose2D(0.1, 0, 0), odometryOf(Pose2D(0.1, 0, 0))).isOk());
  EXPECT_EQ(gate.agrees(Pose2D(NAN, 0, 0), odometryOf(Pose2D(0.1, 0, 0))).code(), StatusCode::kInvalidInput);
  // check() on the same refused pose still refuses once, then (switch_after 2) switches.
  EXPECT_FALSE(gate.check(Pose2D(1.0, 0.5, 0.0), odometryOf(Pose2D(0.1, 0, 0))).isOk());
  EXPECT_EQ(gate.refusedInARow(), 1);
}
