#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "homography_teach_repeat/geometry/planar_pose.h"

using namespace homography_teach_repeat;

namespace {

void expectNear(const PlanarPose& a, const PlanarPose& b, double tol = 1e-12) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.z, b.z, tol);
  EXPECT_NEAR(wrapToPi(a.theta - b.theta), 0.0, tol);
}

void expectNear(const Pose2D& a, const Pose2D& b, double tol = 1e-12) {
  EXPECT_NEAR(a.x, b.x, tol);
  EXPECT_NEAR(a.y, b.y, tol);
  EXPECT_NEAR(wrapToPi(a.yaw - b.yaw), 0.0, tol);
}

PlanarPose randomPose(std::mt19937& rng) {
  std::uniform_real_distribution<double> position(-5.0, 5.0), angle(-M_PI, M_PI);
  return PlanarPose(position(rng), position(rng), angle(rng));
}

}  // namespace

TEST(WrapToPi, WrapsIntoHalfOpenInterval) {
  EXPECT_NEAR(wrapToPi(3.0 * M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapToPi(-M_PI), M_PI, 1e-12);
  EXPECT_NEAR(wrapToPi(0.5), 0.5, 1e-15);
  EXPECT_NEAR(wrapToPi(-7.0), -7.0 + 2.0 * M_PI, 1e-12);
  EXPECT_TRUE(std::isnan(wrapToPi(NAN)));
}

// docs/math.md §1.1: X2 = R21 (X1 − C) with R21 = Ry(θ21), θ21 = −θ12.
TEST(PlanarPose, IsometryMatchesMathConvention) {
  const PlanarPose pose(0.6, -1.4, -0.25);
  const Eigen::Vector3d X1(1.3, -0.4, 6.0);
  const Eigen::Vector3d X2 = pose.rotation21() * (X1 - pose.centre());
  EXPECT_LT((pose.toIsometry() * X2 - X1).norm(), 1e-12);
  // Ry(θ) = [[c, 0, −s], [0, 1, 0], [s, 0, c]].
  const double t21 = 0.25;
  Eigen::Matrix3d ry;
  ry << std::cos(t21), 0, -std::sin(t21), 0, 1, 0, std::sin(t21), 0, std::cos(t21);
  EXPECT_LT((pose.rotation21() - ry).norm(), 1e-15);
}

// θ12 > 0 turns the optical axis towards −x (left): its direction in frame 1 is (−sinθ, cosθ).
TEST(PlanarPose, PositiveThetaTurnsLeft) {
  const PlanarPose pose(0.0, 0.0, 0.3);
  const Eigen::Vector3d axis = pose.toIsometry().linear() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(axis.x(), -std::sin(0.3), 1e-15);
  EXPECT_NEAR(axis.z(), std::cos(0.3), 1e-15);
}

TEST(PlanarPose, ComposeMatchesIsometries) {
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const PlanarPose a = randomPose(rng), b = randomPose(rng);
    const Eigen::Isometry3d expected = a.toIsometry() * b.toIsometry();
    const Eigen::Isometry3d composed = a.compose(b).toIsometry();
    EXPECT_LT((expected.matrix() - composed.matrix()).norm(), 1e-12);
  }
}

TEST(PlanarPose, InverseComposesToIdentity) {
  std::mt19937 rng(4);
  for (int i = 0; i < 50; ++i) {
    const PlanarPose a = randomPose(rng);
    expectNear(a.compose(a.inverse()), PlanarPose());
    expectNear(a.inverse().compose(a), PlanarPose());
    expectNear(a.inverse().inverse(), a);
  }
}

TEST(PlanarPose, TransformPoint) {
  const PlanarPose pose(1.0, 2.0, M_PI / 2);
  // Frame-2 forward (0, 1) is frame-1 (−1, 0) after a left turn of 90°.
  const Eigen::Vector2d p = pose.transformPoint(Eigen::Vector2d(0.0, 1.0));
  EXPECT_NEAR(p.x(), 0.0, 1e-12);
  EXPECT_NEAR(p.y(), 2.0, 1e-12);
}

TEST(Pose2D, ComposeAndInverse) {
  const Pose2D a(1.0, 2.0, M_PI / 2), b(1.0, 0.0, 0.1);
  expectNear(a.compose(b), Pose2D(1.0, 3.0, M_PI / 2 + 0.1));
  expectNear(a.compose(a.inverse()), Pose2D());
  EXPECT_FALSE(Pose2D(NAN, 0.0, 0.0).isFinite());
}

TEST(CameraAxes, ForwardRightAndYawMapToRep103) {
  // Camera forward (z) is base x; camera right (x) is base −y; yaw is the same.
  expectNear(cameraAxesToRep103(PlanarPose(0.0, 1.0, 0.0)), Pose2D(1.0, 0.0, 0.0));
  expectNear(cameraAxesToRep103(PlanarPose(1.0, 0.0, 0.0)), Pose2D(0.0, -1.0, 0.0));
  expectNear(cameraAxesToRep103(PlanarPose(0.0, 0.0, 0.4)), Pose2D(0.0, 0.0, 0.4));
  expectNear(rep103ToCameraAxes(cameraAxesToRep103(PlanarPose(0.3, -2.0, 1.0))),
             PlanarPose(0.3, -2.0, 1.0));
}

TEST(CameraMount, CentredForwardCameraIsJustRelabelling) {
  const CameraMount mount(0.0, 0.0, 0.0);
  expectNear(mount.cameraToBase(PlanarPose(0.2, 1.5, 0.1)), Pose2D(1.5, -0.2, 0.1));
}

// The base turns in place by +90°; a camera 0.3 m ahead of the base centre swings to the left.
TEST(CameraMount, OffsetCameraInPlaceRotation) {
  const CameraMount mount(0.3, 0.0, 0.0);
  const Pose2D base_relative(0.0, 0.0, M_PI / 2);
  // Camera 2 in the forward frame of camera 1: position (−0.3, 0.3), yaw 90° -> camera axes
  // x = −y_fwd = −0.3, z = x_fwd = −0.3.
  const PlanarPose camera_relative(-0.3, -0.3, M_PI / 2);
  expectNear(mount.cameraToBase(camera_relative), base_relative);
  expectNear(mount.baseToCamera(base_relative), camera_relative);
}

TEST(CameraMount, RoundTripAndJacobian) {
  const CameraMount mount(0.25, -0.1, 0.3);
  std::mt19937 rng(5);
  for (int i = 0; i < 20; ++i) {
    const PlanarPose pose = randomPose(rng);
    expectNear(mount.baseToCamera(mount.cameraToBase(pose)), pose, 1e-11);
    const Eigen::Matrix3d J = mount.cameraToBaseJacobian(pose);
    const double h = 1e-6;
    for (int k = 0; k < 3; ++k) {
      PlanarPose plus = pose, minus = pose;
      (k == 0 ? plus.x : k == 1 ? plus.z : plus.theta) += h;
      (k == 0 ? minus.x : k == 1 ? minus.z : minus.theta) -= h;
      const Pose2D a = mount.cameraToBase(plus), b = mount.cameraToBase(minus);
      EXPECT_NEAR(J(0, k), (a.x - b.x) / (2 * h), 1e-7);
      EXPECT_NEAR(J(1, k), (a.y - b.y) / (2 * h), 1e-7);
      EXPECT_NEAR(J(2, k), wrapToPi(a.yaw - b.yaw) / (2 * h), 1e-7);
    }
  }
}

namespace {
// base_T_optical for a level camera looking along base yaw `yaw`, at (x, y, z), optionally
// pitched down by `pitch`.
Eigen::Isometry3d opticalExtrinsic(double x, double y, double z, double yaw, double pitch) {
  Eigen::Matrix3d optical_in_base;  // columns: optical x, y, z in base axes for yaw = 0
  optical_in_base << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
               Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()).toRotationMatrix() *
               optical_in_base;
  t.translation() = Eigen::Vector3d(x, y, z);
  return t;
}
}  // namespace

TEST(CameraMount, FromLevelExtrinsic) {
  const CameraMount mount = CameraMount::fromExtrinsic(opticalExtrinsic(0.2, 0.05, 0.8, 0.4, 0.0), 0.02);
  expectNear(mount.forwardFrame(), Pose2D(0.2, 0.05, 0.4));
}

TEST(CameraMount, RejectsTiltedCameraAndNaN) {
  try {
    CameraMount::fromExtrinsic(opticalExtrinsic(0.0, 0.0, 1.0, 0.0, 0.2), 0.05);
    FAIL() << "a camera pitched by 0.2 rad was accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("not level"), std::string::npos) << e.what();
  }
  Eigen::Isometry3d bad = opticalExtrinsic(0.0, 0.0, 1.0, 0.0, 0.0);
  bad.translation().x() = NAN;
  EXPECT_THROW(CameraMount::fromExtrinsic(bad, 0.05), std::invalid_argument);
  EXPECT_THROW(CameraMount(0.0, NAN, 0.0), std::invalid_argument);
}

// The levelling of a tilted mount: the level frame's y is base_link's down, its z is horizontal
// along the mount's yaw, and the optical axis keeps its yaw; a level mount is not turned.
TEST(CameraMount, CameraToLevelUndoesPitchAndRoll) {
  EXPECT_TRUE(CameraMount::cameraToLevel(opticalExtrinsic(0.2, 0.0, 0.8, 0.4, 0.0)).isIdentity(1e-12));
  Eigen::Isometry3d tilted = opticalExtrinsic(0.2, 0.05, 0.8, 0.4, 0.035);
  tilted.linear() = tilted.linear() * Eigen::AngleAxisd(0.017, Eigen::Vector3d::UnitZ()).toRotationMatrix();  // roll
  const Eigen::Matrix3d camera_to_level = CameraMount::cameraToLevel(tilted);
  EXPECT_LT((camera_to_level.transpose() * camera_to_level - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  // The level frame's axes in base_link: columns of R_base_optical · camera_to_levelᵀ.
  const Eigen::Matrix3d level_in_base = tilted.linear() * camera_to_level.transpose();
  EXPECT_LT((level_in_base.col(1) - Eigen::Vector3d(0, 0, -1)).norm(), 1e-12);
  EXPECT_NEAR(level_in_base.col(2).z(), 0.0, 1e-12);
  EXPECT_NEAR(std::atan2(level_in_base.col(2).y(), level_in_base.col(2).x()), 0.4, 1e-12);
  // The turn is the tilt: about 2.2° for 2° of pitch and 1° of roll.
  EXPECT_NEAR(Eigen::AngleAxisd(camera_to_level).angle(), CameraMount::tiltOf(tilted), 0.01);
  Eigen::Isometry3d down = Eigen::Isometry3d::Identity();  // optical z along base_link's −z
  down.linear() << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  EXPECT_THROW(CameraMount::cameraToLevel(down), std::invalid_argument);
}
