#include "homography_teach_repeat/localization/localization_filter.h"

#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "homography_teach_repeat/mu/heading_1d.h"

namespace homography_teach_repeat {
namespace {

// A robot drives a straight line of `metres` along +x of the route frame in 1 cm steps; its
// odometry has a heading bias of `bias_per_metre` rad per metre, so the odometry believes it
// curves. Returns the final route-frame pose from LocalizationFilter, with a true heading fix
// every `fix_every` steps (0: never).
Pose2D driveStraight(double metres, double bias_per_metre, int fix_every, LocalizationFilter& odometry) {
  const double step = 0.01;
  Pose2D odom(0.0, 0.0, 0.0);
  EXPECT_TRUE(odometry.align(Pose2D(0.0, 0.0, 0.0), odom).isOk());
  Pose2D estimate;
  const int steps = static_cast<int>(std::lround(metres / step));
  for (int i = 1; i <= steps; ++i) {
    // Odometry integrates the true forward step with a biased heading increment.
    odom = odom.compose(Pose2D(step, 0.0, bias_per_metre * step));
    if (fix_every > 0 && i % fix_every == 0) {
      EXPECT_TRUE(odometry.correctHeading(/*true yaw*/ 0.0, odom).isOk());
    }
    const auto pose = odometry.routePose(odom);
    EXPECT_TRUE(pose.isOk());
    estimate = *pose;
  }
  return estimate;
}

TEST(LocalizationFilter, HeadingFixesRemoveTheDriftOfABiasedOdometry) {
  LocalizationFilter without, with;
  const Pose2D drifted = driveStraight(10.0, 0.02, 0, without);
  const Pose2D corrected = driveStraight(10.0, 0.02, 10, with);
  // Without fixes: the 0.2 rad heading error of the odometry bends the path by ~1 m.
  EXPECT_NEAR(drifted.yaw, 0.2, 1e-9);
  EXPECT_GT(std::abs(drifted.y), 0.9);
  // With a fix every 10 cm the heading error stays within a few mrad: the lateral error stays
  // below 2 cm.
  EXPECT_NEAR(corrected.x, 10.0, 1e-3);
  EXPECT_LT(std::abs(corrected.y), 0.02);
  EXPECT_LT(std::abs(corrected.yaw), 0.005);
}

TEST(LocalizationFilter, AlignmentPlacesTheRobotAtTheGivenRoutePose) {
  LocalizationFilter odometry;
  const Pose2D route(2.0, -1.0, 0.5), odom(10.0, 3.0, -1.2);
  ASSERT_TRUE(odometry.align(route, odom).isOk());
  const auto pose = odometry.routePose(odom);
  ASSERT_TRUE(pose.isOk());
  EXPECT_NEAR(pose->x, 2.0, 1e-12);
  EXPECT_NEAR(pose->y, -1.0, 1e-12);
  EXPECT_NEAR(pose->yaw, 0.5, 1e-12);
  // 1 m forward in odometry is 1 m forward along the route heading; predictedPose does not move
  // the filter on.
  const Pose2D ahead_odom = odom.compose(Pose2D(1.0, 0.0, 0.0));
  const auto peek = odometry.predictedPose(ahead_odom);
  ASSERT_TRUE(peek.isOk());
  EXPECT_EQ(odometry.distanceSinceFix(), 0.0);
  const auto ahead = odometry.routePose(ahead_odom);
  ASSERT_TRUE(ahead.isOk());
  EXPECT_NEAR(ahead->x, 2.0 + std::cos(0.5), 1e-12);
  EXPECT_NEAR(ahead->y, -1.0 + std::sin(0.5), 1e-12);
  EXPECT_NEAR(peek->x, ahead->x, 1e-12);
  EXPECT_NEAR(odometry.distanceSinceFix(), 1.0, 1e-12);
  // The map -> odom transform maps the odometry pose onto the estimate.
  const Pose2D mapped = odometry.alignment().compose(ahead_odom);
  EXPECT_NEAR(mapped.x, ahead->x, 1e-12);
  EXPECT_NEAR(mapped.y, ahead->y, 1e-12);
}

TEST(LocalizationFilter, CovarianceGrowsWithTravelAndAHeadingFixShrinksTheHeading) {
  LocalizationFilterOptions options;
  LocalizationFilter odometry(options);
  ASSERT_TRUE(odometry.align(Pose2D(), Pose2D()).isOk());
  ASSERT_TRUE(odometry.routePose(Pose2D(2.0, 0.0, 0.0)).isOk());
  const Eigen::Matrix3d before = odometry.covariance();
  EXPECT_NEAR(before(0, 0), options.initial_position_variance + 2.0 * options.position_variance_per_metre, 1e-12);
  EXPECT_NEAR(before(2, 2), options.heading_fix_variance + 2.0 * options.heading_variance_per_metre, 1e-12);
  // The heading uncertainty, carried over 2 m, made the lateral position uncertain too.
  EXPECT_GT(before(1, 1), before(0, 0));
  EXPECT_GT(before(1, 2), 0.0);
  ASSERT_TRUE(odometry.correctHeading(0.01, Pose2D(2.0, 0.0, 0.0)).isOk());
  const Eigen::Matrix3d after = odometry.covariance();
  EXPECT_LT(after(2, 2), options.heading_fix_variance);
  EXPECT_LT(after(1, 1), before(1, 1));  // correlated with the heading
  EXPECT_NEAR(after(0, 0), before(0, 0), 1e-12);  // along the motion: not observed
  EXPECT_TRUE((after - after.transpose()).cwiseAbs().maxCoeff() < 1e-15);
}

// The room of the simulator in one leg: the robot drives along +x towards a wall 4 m ahead of the
// reference keyframe, 15 cm to the left of the taught path with the right heading, while its
// odometry believes it is on the path. μ against the keyframe over-rotates by ~atan(tx/d):
// as a heading fix it would turn the heading estimate by 3-9°; the filter attributes it to the
// offset.
TEST(LocalizationFilter, MuFixesFindALateralOffsetInsteadOfAWrongHeading) {
  MuObservation wall;
  wall.reference_pose = Pose2D(1.0, 1.0, 0.0);
  wall.camera_mount = Pose2D(0.2, 0.0, 0.0);
  wall.wall_normal = Eigen::Vector2d(0.0, 1.0);  // the wall faces the keyframe camera
  wall.wall_distance = 3.8;                      // x = 5 in the route frame
  wall.focal_px = 500.0;
  const CameraMount mount(0.2, 0.0, 0.0);
  LocalizationFilter filter;
  LocalizationFilterOptions heading_only_options;
  LocalizationFilter heading_only(heading_only_options);
  const Pose2D start_odom(0.0, 0.0, 0.0);
  ASSERT_TRUE(filter.align(wall.reference_pose, start_odom).isOk());
  ASSERT_TRUE(heading_only.align(wall.reference_pose, start_odom).isOk());
  Pose2D truth(1.0, 1.15, 0.0);
  Pose2D odom = start_odom;
  for (int i = 1; i <= 250; ++i) {  // 2.5 m in 1 cm steps, a μ fix every 10 cm
    truth = truth.compose(Pose2D(0.01, 0.0, 0.0));
    odom = odom.compose(Pose2D(0.01, 0.0, 0.0));
    if (i % 10 != 0) continue;
    wall.mu = *predictedMu(mount.baseToCamera(wall.reference_pose.inverse().compose(truth)), wall.wall_normal,
                           wall.wall_distance, wall.focal_px);
    const Status fixed = filter.correctWithMu(wall, odom);
    // The first fix waits for the next frame's confirmation.
    if (i == 10) {
      EXPECT_EQ(fixed.code(), StatusCode::kNoConsensus);
    } else {
      ASSERT_TRUE(fixed.isOk()) << "step " << i << ": " << fixed.toString();
    }
    ASSERT_TRUE(heading_only.correctHeading(std::atan(wall.mu / wall.focal_px), odom).isOk());
  }
  const auto estimate = filter.routePose(odom);
  const auto naive = heading_only.routePose(odom);
  ASSERT_TRUE(estimate.isOk() && naive.isOk());
  // μ as a pure heading: several degrees wrong at the end of the leg.
  EXPECT_GT(std::abs(naive->yaw), 0.05);
  // The filter: the heading error is a fifth of that (measured 1.3° against 6.4°), most of the
  // offset is found (measured 11.6 of 15 cm).
  EXPECT_LT(std::abs(estimate->yaw), 0.25 * std::abs(naive->yaw));
  EXPECT_NEAR(estimate->y, 1.15, 0.05);
  EXPECT_NEAR(estimate->x, truth.x, 0.01);
  // Honest: the truth lies within 3 σ of the estimate.
  EXPECT_LT(std::abs(estimate->y - truth.y), 3.0 * std::sqrt(filter.covariance()(1, 1)));
  EXPECT_LT(std::abs(estimate->yaw - truth.yaw), 3.0 * std::sqrt(filter.covariance()(2, 2)));
}

// A wrong line association is one frame: its μ does not follow the previous frame's by what the
// odometry predicts. It is refused, and so is the next frame (confirmed by nothing); the one after
// is taken again.
TEST(LocalizationFilter, AMuFixMustAgreeWithThePreviousFrame) {
  MuObservation wall;
  wall.reference_pose = Pose2D(0.0, 0.0, 0.0);
  wall.camera_mount = Pose2D(0.2, 0.0, 0.0);
  wall.wall_distance = 3.0;
  wall.reference_id = 7;
  const CameraMount mount(0.2, 0.0, 0.0);
  LocalizationFilter filter;
  ASSERT_TRUE(filter.align(Pose2D(), Pose2D()).isOk());
  std::vector<StatusCode> codes;
  for (int i = 1; i <= 6; ++i) {
    const Pose2D pose(0.05 * i, 0.0, 0.0);
    wall.mu = *predictedMu(mount.baseToCamera(pose), wall.wall_normal, wall.wall_distance, wall.focal_px);
    if (i == 3) wall.mu += 40.0;  // the wrong association
    if (i == 5) wall.reference_id = 8;  // another keyframe: not comparable with frame 4's
    codes.push_back(filter.correctWithMu(wall, pose).code());
  }
  EXPECT_EQ(codes, (std::vector<StatusCode>{StatusCode::kNoConsensus, StatusCode::kOk, StatusCode::kNoConsensus,
                                            StatusCode::kNoConsensus, StatusCode::kNoConsensus, StatusCode::kOk}));
  EXPECT_NEAR(filter.routePose(Pose2D(0.3, 0.0, 0.0))->yaw, 0.0, 1e-3);
}

// A fix that passed its own consensus (needs_confirmation false: the seasonal shift vote) is taken
// at once, each frame, while the innovation gate still refuses a wild one; a heading fix with its
// own variance above heading_fix_variance shrinks the heading less.
TEST(LocalizationFilter, AFixCheckedByItsOwnConsensusNeedsNoConfirmation) {
  MuObservation wall;
  wall.camera_mount = Pose2D(0.2, 0.0, 0.0);
  wall.wall_distance = 3.0;
  wall.reference_id = 7;
  wall.needs_confirmation = false;
  const CameraMount mount(0.2, 0.0, 0.0);
  LocalizationFilter filter;
  ASSERT_TRUE(filter.align(Pose2D(), Pose2D()).isOk());
  std::vector<StatusCode> codes;
  for (int i = 1; i <= 4; ++i) {
    const Pose2D pose(0.5 * i, 0.0, 0.0);  // fixes 0.5 m apart: beyond max_confirmation_distance
    wall.mu = *predictedMu(mount.baseToCamera(pose), wall.wall_normal, wall.wall_distance, wall.focal_px);
    wall.reference_id = i;  // and against other keyframes
    if (i == 3) wall.mu += 200.0;
    codes.push_back(filter.correctWithMu(wall, pose).code());
  }
  EXPECT_EQ(codes, (std::vector<StatusCode>{StatusCode::kOk, StatusCode::kOk, StatusCode::kNoConsensus, StatusCode::kOk}));

  LocalizationFilterOptions options;
  LocalizationFilter tight(options), loose(options);
  for (LocalizationFilter* f : {&tight, &loose}) {
    ASSERT_TRUE(f->align(Pose2D(), Pose2D()).isOk());
    ASSERT_TRUE(f->routePose(Pose2D(2.0, 0.0, 0.0)).isOk());
  }
  ASSERT_TRUE(tight.correctHeading(0.0, Pose2D(2.0, 0.0, 0.0)).isOk());
  ASSERT_TRUE(loose.correctHeading(0.0, Pose2D(2.0, 0.0, 0.0), 100.0 * options.heading_fix_variance).isOk());
  EXPECT_GT(loose.covariance()(2, 2), 5.0 * tight.covariance()(2, 2));
  EXPECT_EQ(tight.correctHeading(0.0, Pose2D(2.0, 0.0, 0.0), std::nan("")).code(), StatusCode::kInvalidInput);
}

TEST(LocalizationFilter, TheGateRefusesAWildFixAndALastingDisagreementResetsIt) {
  LocalizationFilterOptions options;
  options.refused_before_reset = 3;
  LocalizationFilter odometry(options);
  ASSERT_TRUE(odometry.align(Pose2D(), Pose2D()).isOk());
  // 0.6 rad off with a heading σ of 0.5°: refused twice, the third in a row widens the estimate
  // and is taken.
  EXPECT_EQ(odometry.correctHeading(0.6, Pose2D(0.1, 0.0, 0.0)).code(), StatusCode::kNoConsensus);
  EXPECT_EQ(odometry.refusedInARow(), 1);
  EXPECT_EQ(odometry.correctHeading(0.6, Pose2D(0.2, 0.0, 0.0)).code(), StatusCode::kNoConsensus);
  EXPECT_TRUE(odometry.correctHeading(0.6, Pose2D(0.3, 0.0, 0.0)).isOk());
  EXPECT_EQ(odometry.refusedInARow(), 0);
  const auto pose = odometry.routePose(Pose2D(0.3, 0.0, 0.0));
  ASSERT_TRUE(pose.isOk());
  EXPECT_GT(pose->yaw, 0.5);
  // A refused fix leaves the estimate alone.
  EXPECT_EQ(odometry.correctHeading(-0.5, Pose2D(0.3, 0.0, 0.0)).code(), StatusCode::kNoConsensus);
  EXPECT_NEAR(odometry.routePose(Pose2D(0.3, 0.0, 0.0))->yaw, pose->yaw, 1e-12);
}

TEST(LocalizationFilter, BadInputIsAStatusNeverAPose) {
  LocalizationFilter odometry;
  EXPECT_EQ(odometry.routePose(Pose2D()).status().code(), StatusCode::kNoConsensus);
  EXPECT_EQ(odometry.correctHeading(0.0, Pose2D()).code(), StatusCode::kNoConsensus);
  EXPECT_EQ(odometry.correctWithMu(MuObservation(), Pose2D()).code(), StatusCode::kNoConsensus);
  EXPECT_EQ(odometry.align(Pose2D(NAN, 0.0, 0.0), Pose2D()).code(), StatusCode::kInvalidInput);
  ASSERT_TRUE(odometry.align(Pose2D(), Pose2D()).isOk());
  EXPECT_EQ(odometry.routePose(Pose2D(0.0, NAN, 0.0)).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(odometry.correctHeading(NAN, Pose2D()).code(), StatusCode::kInvalidInput);
  MuObservation bad_fix;
  bad_fix.mu = NAN;
  EXPECT_EQ(odometry.correctWithMu(bad_fix, Pose2D()).code(), StatusCode::kInvalidInput);
  bad_fix = MuObservation();
  bad_fix.wall_distance = 0.0;
  EXPECT_EQ(odometry.correctWithMu(bad_fix, Pose2D()).code(), StatusCode::kInvalidInput);
  bad_fix = MuObservation();
  bad_fix.wall_distance = 0.5;
  bad_fix.reference_pose = Pose2D(-5.0, 0.0, 0.0);  // the wall is behind the robot
  EXPECT_EQ(odometry.correctWithMu(bad_fix, Pose2D()).code(), StatusCode::kDegenerate);
  LocalizationFilterOptions bad;
  bad.innovation_gate = 0.0;
  EXPECT_THROW(LocalizationFilter{bad}, std::invalid_argument);
  bad = LocalizationFilterOptions();
  bad.position_variance_per_metre = -1.0;
  EXPECT_THROW(LocalizationFilter{bad}, std::invalid_argument);
  bad = LocalizationFilterOptions();
  bad.max_mu_step_px = 0.0;
  EXPECT_THROW(LocalizationFilter{bad}, std::invalid_argument);
  bad = LocalizationFilterOptions();
  bad.refused_before_reset = 0;
  EXPECT_THROW(LocalizationFilter{bad}, std::invalid_argument);
}

// The wall of a keyframe from its scene plane: the horizontal part of the normal, the distance to
// the wall's line in the (x, z) plane; and its 1D homography's μ is the filter's measurement model.
// A floor or ceiling plane (or none) is no wall.
TEST(LocalizationFilter, KeyframeWallFromItsScenePlane) {
  ScenePlane tilted;
  tilted.normal = Eigen::Vector3d(0.3, 0.1, 0.9).normalized();
  tilted.distance = 2.0;
  const Pose2D keyframe(1.0, 2.0, 0.5), mount(0.2, 0.0, 0.0);
  const auto wall = muWallOf(keyframe, tilted, mount, 500.0, 7);
  ASSERT_TRUE(wall.has_value());
  const double horizontal = std::hypot(tilted.normal.x(), tilted.normal.z());
  EXPECT_NEAR(wall->wall_normal.norm(), 1.0, 1e-12);
  EXPECT_NEAR(wall->wall_normal.x(), tilted.normal.x() / horizontal, 1e-12);
  EXPECT_NEAR(wall->wall_distance, 2.0 / horizontal, 1e-12);
  EXPECT_EQ(wall->reference_id, 7);
  // At the keyframe itself the wall's homography is the identity (μ = 0); elsewhere μ is
  // predictedMu of the camera pose in the keyframe camera frame.
  const auto at_keyframe = wallHomography1dAt(*wall, keyframe);
  ASSERT_TRUE(at_keyframe.isOk());
  EXPECT_NEAR((*at_keyframe / (*at_keyframe)(1, 1) - Eigen::Matrix2d::Identity()).norm(), 0.0, 1e-12);
  const Pose2D moved = keyframe.compose(Pose2D(0.4, 0.1, 0.05));
  const auto H = wallHomography1dAt(*wall, moved);
  ASSERT_TRUE(H.isOk());
  const CameraMount camera_mount(0.2, 0.0, 0.0);
  const double mu = *predictedMu(camera_mount.baseToCamera(Pose2D(0.4, 0.1, 0.05)), wall->wall_normal,
                                 wall->wall_distance, 500.0);
  EXPECT_NEAR((*H)(0, 1) / (*H)(1, 1), mu, 1e-9);
  EXPECT_GT(std::abs(mu), 10.0);
  ScenePlane floor;
  floor.normal = Eigen::Vector3d(0.0, 1.0, 0.0);
  EXPECT_FALSE(muWallOf(keyframe, floor, mount, 500.0, 0).has_value());
  EXPECT_FALSE(muWallOf(keyframe, std::nullopt, mount, 500.0, 0).has_value());
}

// The wall is an estimate (docs/math.md §4.11): the variance its normal's and distance's std add
// to the predicted μ is the spread of μ over walls drawn with those stds (Monte Carlo, 20000
// draws, within 5 % for stds of 0.05 rad and 5 %, where the linearization holds); none without
// them, none at the keyframe itself (μ = 0 for every wall); bad sigmas refused. In the filter a μ
// fix through an uncertain wall moves the estimate less.
TEST(LocalizationFilter, AnUncertainWallMakesItsMuUncertain) {
  MuObservation wall;
  wall.reference_pose = Pose2D(0.0, 0.0, 0.0);
  wall.camera_mount = Pose2D(0.2, 0.0, 0.0);
  wall.wall_normal = Eigen::Vector2d(0.3, 1.0).normalized();
  wall.wall_distance = 5.0;
  wall.focal_px = 700.0;
  const Pose2D behind(-1.0, 0.2, 0.03);  // a metre behind the keyframe, 20 cm aside
  EXPECT_DOUBLE_EQ(*wallModelVariance(wall, behind), 0.0);
  wall.wall_normal_sigma_rad = 0.05;
  wall.wall_distance_sigma = 0.05;
  const auto variance = wallModelVariance(wall, behind);
  ASSERT_TRUE(variance.isOk()) << variance.status().toString();
  // The spread of μ over walls drawn with those stds, the normal turned about `pivot` (a point on
  // the wall) and the distance then scaled.
  std::mt19937 random(3);
  std::normal_distribution<double> unit(0.0, 1.0);
  const auto spreadOfMu = [&](const Eigen::Vector2d& pivot) {
    double sum = 0.0, squares = 0.0;
    const int draws = 20000;
    for (int i = 0; i < draws; ++i) {
      MuObservation drawn = wall;
      const double turn = wall.wall_normal_sigma_rad * unit(random);
      drawn.wall_normal = Eigen::Vector2d(std::cos(turn) * wall.wall_normal.x() - std::sin(turn) * wall.wall_normal.y(),
                                          std::sin(turn) * wall.wall_normal.x() + std::cos(turn) * wall.wall_normal.y());
      drawn.wall_distance = drawn.wall_normal.dot(pivot) * (1.0 + wall.wall_distance_sigma * unit(random));
      const auto H = wallHomography1dAt(drawn, behind);
      EXPECT_TRUE(H.isOk());
      if (!H) return 0.0;
      const double mu = (*H)(0, 1) / (*H)(1, 1);
      sum += mu;
      squares += mu * mu;
    }
    return squares / draws - (sum / draws) * (sum / draws);
  };
  const double spread = spreadOfMu(wall.wall_distance * wall.wall_normal);
  EXPECT_GT(*variance, 0.5);  // px²: a metre behind a wall 5 m away, degrees of normal matter
  EXPECT_NEAR(*variance / spread, 1.0, 0.05) << *variance << " px² against " << spread;
  // The wall's features 4 m along it from its point nearest the camera (a facade seen obliquely):
  // the normal's error turns the wall about them, and μ's spread is another.
  const Eigen::Vector2d along(wall.wall_normal.y(), -wall.wall_normal.x());
  MuObservation oblique = wall;
  oblique.wall_pivot = wall.wall_distance * wall.wall_normal + 4.0 * along;
  const auto oblique_variance = wallModelVariance(oblique, behind);
  ASSERT_TRUE(oblique_variance.isOk()) << oblique_variance.status().toString();
  const double oblique_spread = spreadOfMu(*oblique.wall_pivot);
  EXPECT_NEAR(*oblique_variance / oblique_spread, 1.0, 0.05) << *oblique_variance << " px² against " << oblique_spread;
  EXPECT_GT(std::abs(oblique_spread / spread - 1.0), 0.2) << oblique_spread << " px² against " << spread;
  EXPECT_NEAR(*wallModelVariance(wall, wall.reference_pose), 0.0, 1e-6);
  MuObservation bad = wall;
  bad.wall_normal_sigma_rad = -0.1;
  EXPECT_EQ(wallModelVariance(bad, behind).status().code(), StatusCode::kInvalidInput);
  bad.wall_normal_sigma_rad = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(wallModelVariance(bad, behind).status().code(), StatusCode::kInvalidInput);

  // Two filters, the same confirmed μ fixes of a heading 0.25° off the estimate's (inside the
  // innovation gate of both); the one told its wall is uncertain (σφ 0.3 rad: a corner's mixed
  // surfaces) learns less from them: its heading variance stays larger and it moves less.
  struct After {
    double yaw_change = 0.0;
    double yaw_variance = 0.0;
    double wall_variance = 0.0;
  };
  const Pose2D turning(-2.0, 0.5, 0.3);  // 2 m behind the keyframe, half a metre aside, turned 17°
  auto afterFixes = [&](double normal_sigma) {
    LocalizationFilter filter;
    MuObservation fix = wall;
    fix.wall_normal_sigma_rad = normal_sigma;
    fix.wall_distance_sigma = 0.0;
    Pose2D odom(0.0, 0.0, 0.0);
    // A pose known to a centimetre and 0.2°: the fix's own variance matters against it.
    EXPECT_TRUE(filter.align(turning, odom, Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal()).isOk());
    const CameraMount mount(0.2, 0.0, 0.0);
    After after;
    for (int i = 0; i < 2; ++i) {
      odom = odom.compose(Pose2D(0.01, 0.0, 0.0));
      const Pose2D truth = turning.compose(odom);
      fix.mu = *predictedMu(mount.baseToCamera(Pose2D(truth.x, truth.y, truth.yaw + 0.0044)), fix.wall_normal,
                            fix.wall_distance, fix.focal_px);
      const Status fixed = filter.correctWithMu(fix, odom);
      EXPECT_TRUE(i == 0 || fixed.isOk()) << fixed.toString();  // the first waits for its confirmation
      after.wall_variance = *wallModelVariance(fix, turning.compose(odom));
    }
    after.yaw_change = filter.routePose(odom)->yaw - turning.yaw;
    after.yaw_variance = filter.covariance()(2, 2);
    return after;
  };
  const After certain = afterFixes(0.0);
  const After uncertain = afterFixes(0.3);
  EXPECT_GT(uncertain.wall_variance, 4.0) << uncertain.wall_variance;  // above min_mu_variance
  EXPECT_GT(std::abs(certain.yaw_change), 0.001) << certain.yaw_change;
  EXPECT_LT(std::abs(uncertain.yaw_change), std::abs(certain.yaw_change));
  EXPECT_GT(uncertain.yaw_variance, 1.2 * certain.yaw_variance)
      << uncertain.yaw_variance << " against " << certain.yaw_variance;
}

// Line landmarks of a street in the keyframe camera frame (keyframe at the route origin, camera
// looking along +x of the route) and the lines a robot at `truth` sees of them.
struct StreetScene {
  LineLandmarkObservation observation;
  std::vector<Eigen::Vector2d> positions;

  explicit StreetScene(int count, unsigned seed) {
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> side(3.0, 10.0), depth(5.0, 40.0), grey(20.0, 230.0);
    std::bernoulli_distribution left(0.5);
    observation.lens = LineCamera{707.0, 600.0};
    observation.image_width = 1200.0;
    for (int i = 0; i < count; ++i) {
      positions.emplace_back(left(rng) ? -side(rng) : side(rng), depth(rng));
      VerticalLine line;
      line.polarity = left(rng) ? EdgePolarity::kDarkLeft : EdgePolarity::kDarkRight;
      line.left_brightness = grey(rng);
      line.right_brightness = grey(rng);
      const auto x = projectLineLandmark(PlanarPose(), positions.back(), observation.lens);
      line.x = *x;
      observation.reference_lines.push_back(line);
      LineLandmark landmark;
      landmark.line = i;
      landmark.position = positions.back();
      landmark.covariance = Eigen::Matrix2d::Identity() * 1e-4;
      landmark.views = 3;
      observation.landmarks.push_back(landmark);
    }
  }

  void see(const Pose2D& truth, double noise_px, unsigned seed) {
    std::mt19937 rng(seed);
    std::normal_distribution<double> noise(0.0, noise_px);
    const CameraMount mount(0.0, 0.0, 0.0);
    const PlanarPose camera = mount.baseToCamera(truth);
    observation.current_lines.clear();
    for (std::size_t i = 0; i < positions.size(); ++i) {
      const auto x = projectLineLandmark(camera, positions[i], observation.lens);
      if (!x || *x < 0.0 || *x >= observation.image_width) continue;
      VerticalLine line = observation.reference_lines[i];
      line.x = *x + noise(rng);
      observation.current_lines.push_back(line);
    }
  }
};

TEST(LocalizationFilter, LineLandmarksCorrectHeadingAndPosition) {
  StreetScene street(40, 11);
  // The robot is 1 m past the keyframe, 8 cm to the left, turned 1.5° left; its odometry says it
  // went straight on.
  const Pose2D truth(1.0, 0.08, 0.026);
  street.see(truth, 0.5, 2);
  LocalizationFilterOptions options;
  options.line_position_sigma_m = 0.0;
  LocalizationFilter odometry(options);
  ASSERT_TRUE(odometry.align(Pose2D(0.0, 0.0, 0.0), Pose2D(0.0, 0.0, 0.0)).isOk());
  const auto used = odometry.correctWithLineLandmarks(street.observation, Pose2D(1.0, 0.0, 0.0));
  ASSERT_TRUE(used.isOk()) << used.status().toString();
  EXPECT_GE(*used, 20);
  const auto pose = odometry.routePose(Pose2D(1.0, 0.0, 0.0));
  ASSERT_TRUE(pose.isOk());
  EXPECT_NEAR(pose->x, truth.x, 0.03);
  EXPECT_NEAR(pose->y, truth.y, 0.02);
  EXPECT_NEAR(pose->yaw, truth.yaw, 0.002);
  const Eigen::Vector3d error(pose->x - truth.x, pose->y - truth.y, pose->yaw - truth.yaw);
  EXPECT_LT(error.dot(odometry.covariance().inverse() * error), 16.3);  // χ², 3 dof, 99.9 %
  EXPECT_LT(odometry.covariance()(2, 2), options.heading_fix_variance);
  EXPECT_DOUBLE_EQ(odometry.distanceSinceFix(), 0.0);
}

TEST(LocalizationFilter, LineLandmarksDropLinesThatDoNotFit) {
  StreetScene street(40, 5);
  const Pose2D truth(0.8, -0.05, -0.02);
  street.see(truth, 0.5, 3);
  // Strays: lines that look like taught ones, a few pixels beside where those should be.
  for (int i = 0; i < 6; ++i) {
    VerticalLine stray = street.observation.current_lines[static_cast<std::size_t>(3 * i)];
    stray.x += 9.0;
    street.observation.current_lines.push_back(stray);
  }
  LocalizationFilter odometry;
  ASSERT_TRUE(odometry.align(Pose2D(0.0, 0.0, 0.0), Pose2D(0.0, 0.0, 0.0)).isOk());
  ASSERT_TRUE(odometry.correctWithLineLandmarks(street.observation, Pose2D(0.8, 0.0, 0.0)).isOk());
  const auto pose = odometry.routePose(Pose2D(0.8, 0.0, 0.0));
  EXPECT_NEAR(pose->y, truth.y, 0.03);
  EXPECT_NEAR(pose->yaw, truth.yaw, 0.003);
}

TEST(LocalizationFilter, LineLandmarksRefuseTooFewLinesAndBadInput) {
  StreetScene street(4, 9);
  street.see(Pose2D(0.5, 0.0, 0.0), 0.3, 1);
  LocalizationFilter odometry;
  EXPECT_EQ(odometry.correctWithLineLandmarks(street.observation, Pose2D()).status().code(), StatusCode::kNoConsensus);
  ASSERT_TRUE(odometry.align(Pose2D(0.0, 0.0, 0.0), Pose2D(0.0, 0.0, 0.0)).isOk());
  const auto few = odometry.correctWithLineLandmarks(street.observation, Pose2D(0.5, 0.0, 0.0));
  EXPECT_EQ(few.status().code(), StatusCode::kNoConsensus);
  EXPECT_NE(few.status().message().find("min_landmark_lines"), std::string::npos) << few.status().message();
  LineLandmarkObservation broken = street.observation;
  broken.landmarks[0].line = 17;  // no such reference line
  EXPECT_EQ(odometry.correctWithLineLandmarks(broken, Pose2D(0.5, 0.0, 0.0)).status().code(), StatusCode::kInvalidInput);
  broken = street.observation;
  broken.reference_pose.yaw = NAN;
  EXPECT_EQ(odometry.correctWithLineLandmarks(broken, Pose2D(0.5, 0.0, 0.0)).status().code(), StatusCode::kInvalidInput);
}


// A pose fix (hybrid mode): the Kalman update with H = I. With diagonal P and R each component is
// the inverse-variance mean; the NIS is νᵀ(P + R)⁻¹ν; align() with a covariance starts from it.
TEST(LocalizationFilter, PoseFixIsTheKalmanUpdateWithItsInnovation) {
  LocalizationFilterOptions options;
  options.position_variance_per_metre = 0.0;
  options.heading_variance_per_metre = 0.0;
  options.heading_variance_per_radian = 0.0;
  LocalizationFilter filter(options);
  const Eigen::Matrix3d prior = Eigen::Vector3d(0.04, 0.01, 0.0025).asDiagonal();
  ASSERT_TRUE(filter.align(Pose2D(1.0, 2.0, 0.3), Pose2D(0.0, 0.0, 0.0), prior).isOk());
  EXPECT_TRUE(filter.covariance().isApprox(prior));
  const Eigen::Matrix3d R = Eigen::Vector3d(0.01, 0.01, 0.0025).asDiagonal();
  const Pose2D measured(1.1, 1.9, 0.35);
  const auto nis = filter.correctWithPose(measured, R, Pose2D(0.0, 0.0, 0.0));
  ASSERT_TRUE(nis.isOk()) << nis.status().toString();
  const double expected_nis = 0.1 * 0.1 / 0.05 + 0.1 * 0.1 / 0.02 + 0.05 * 0.05 / 0.005;
  EXPECT_NEAR(*nis, expected_nis, 1e-9);
  const auto innovation = filter.takeInnovation();
  ASSERT_TRUE(innovation);
  EXPECT_EQ(innovation->dof, 3);
  EXPECT_TRUE(innovation->accepted);
  EXPECT_NEAR(innovation->nis, expected_nis, 1e-9);
  EXPECT_FALSE(filter.takeInnovation());  // taken
  const auto pose = filter.routePose(Pose2D(0.0, 0.0, 0.0));
  ASSERT_TRUE(pose.isOk());
  EXPECT_NEAR(pose->x, (0.01 * 1.0 + 0.04 * 1.1) / 0.05, 1e-9);
  EXPECT_NEAR(pose->y, (0.01 * 2.0 + 0.01 * 1.9) / 0.02, 1e-9);
  EXPECT_NEAR(pose->yaw, 0.325, 1e-9);
  EXPECT_NEAR(filter.covariance()(0, 0), 0.04 * 0.01 / 0.05, 1e-12);
  EXPECT_NEAR(filter.covariance()(1, 1), 0.005, 1e-12);
  EXPECT_NEAR(filter.covariance()(2, 2), 0.00125, 1e-12);
  EXPECT_DOUBLE_EQ(filter.distanceSinceFix(), 0.0);
  // The yaw innovation is wrapped: a measurement at -π + 0.01 against π - 0.01 is 0.02 away.
  LocalizationFilter wrapped(options);
  ASSERT_TRUE(wrapped.align(Pose2D(0.0, 0.0, M_PI - 0.01), Pose2D(), prior).isOk());
  ASSERT_TRUE(wrapped.correctWithPose(Pose2D(0.0, 0.0, -M_PI + 0.01), R, Pose2D()).isOk());
  EXPECT_NEAR(std::abs(wrapToPi(wrapped.routePose(Pose2D())->yaw - M_PI)), 0.0, 1e-9);
}

// Repeated fixes standing still do not shrink the covariance below pose_common_fraction of a fix's
// (their shared error does not average away); a fix beyond pose_innovation_gate is refused.
TEST(LocalizationFilter, RepeatedPoseFixesKeepTheirCommonErrorAndWildOnesAreRefused) {
  LocalizationFilterOptions options;
  options.pose_common_fraction = 0.5;
  LocalizationFilter filter(options);
  const Eigen::Matrix3d R = Eigen::Vector3d(1e-4, 4e-4, 1e-5).asDiagonal();
  ASSERT_TRUE(filter.align(Pose2D(), Pose2D(), R).isOk());
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(filter.correctWithPose(Pose2D(0.001, 0.0, 0.0), R, Pose2D()).isOk());
  const Eigen::Matrix3d lacking = filter.covariance() - 0.5 * R;
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(lacking).eigenvalues().minCoeff(), -1e-15);
  EXPECT_LE(filter.covariance()(0, 0), R(0, 0));
  // Without the common share the covariance would have shrunk fifty-fold.
  LocalizationFilterOptions independent = options;
  independent.pose_common_fraction = 0.0;
  LocalizationFilter naive(independent);
  ASSERT_TRUE(naive.align(Pose2D(), Pose2D(), R).isOk());
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(naive.correctWithPose(Pose2D(), R, Pose2D()).isOk());
  EXPECT_LT(naive.covariance()(0, 0), R(0, 0) / 40.0);
  // 0.2 m off with σ ≈ 1.2 cm: NIS ≈ 270 > 22, refused (and said so) until refused_before_reset.
  const auto wild = filter.correctWithPose(Pose2D(0.2, 0.0, 0.0), R, Pose2D());
  EXPECT_EQ(wild.status().code(), StatusCode::kNoConsensus);
  EXPECT_NE(wild.status().message().find("pose_innovation_gate"), std::string::npos) << wild.status().message();
  const auto innovation = filter.takeInnovation();
  ASSERT_TRUE(innovation);
  EXPECT_FALSE(innovation->accepted);
  EXPECT_GT(innovation->nis, 100.0);
  EXPECT_EQ(filter.refusedInARow(), 1);
  EXPECT_NEAR(filter.routePose(Pose2D())->x, 0.001, 1e-3);  // unchanged
}

// The part of a fix's covariance that every fix against the keyframe shares (its plane's own
// error: RepeatEstimate::model_covariance) stays whole however many fixes are fused; only the rest
// (this image's pixel noise) is shared by pose_common_fraction.
TEST(LocalizationFilter, ThePlanesSharedErrorIsNotAveragedAway) {
  LocalizationFilterOptions options;
  options.pose_common_fraction = 0.5;
  LocalizationFilter filter(options);
  const Eigen::Matrix3d pixel = Eigen::Vector3d(1e-4, 4e-4, 1e-5).asDiagonal();
  Eigen::Matrix3d plane;  // a leaning wall: depth and heading move together
  plane << 4e-4, 0.0, 1e-5, 0.0, 1e-6, 0.0, 1e-5, 0.0, 1e-6;
  const Eigen::Matrix3d R = pixel + plane;
  ASSERT_TRUE(filter.align(Pose2D(), Pose2D(), R).isOk());
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(filter.correctWithPose(Pose2D(0.001, 0.0, 0.0), R, Pose2D(), plane).isOk());
  const Eigen::Matrix3d lacking = filter.covariance() - (plane + 0.5 * pixel);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(lacking).eigenvalues().minCoeff(), -1e-15);
  // Without it, half of the plane's share would have gone: x's variance 0.5 R = 2.5e-4 < 4.5e-4.
  LocalizationFilter fraction_only(options);
  ASSERT_TRUE(fraction_only.align(Pose2D(), Pose2D(), R).isOk());
  for (int i = 0; i < 50; ++i) ASSERT_TRUE(fraction_only.correctWithPose(Pose2D(0.001, 0.0, 0.0), R, Pose2D()).isOk());
  EXPECT_LT(fraction_only.covariance()(0, 0), 0.6 * R(0, 0));
  EXPECT_GE(filter.covariance()(0, 0), plane(0, 0) + 0.5 * pixel(0, 0) - 1e-15);
  // A shared covariance that is not finite is refused.
  const Eigen::Matrix3d bad = Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  EXPECT_EQ(filter.correctWithPose(Pose2D(), R, Pose2D(), bad).status().code(), StatusCode::kInvalidInput);
}

TEST(LocalizationFilter, PoseFixBadInputIsRefused) {
  LocalizationFilter filter;
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity() * 1e-4;
  EXPECT_EQ(filter.correctWithPose(Pose2D(), R, Pose2D()).status().code(), StatusCode::kNoConsensus);  // not aligned
  ASSERT_TRUE(filter.align(Pose2D(), Pose2D()).isOk());
  EXPECT_EQ(filter.correctWithPose(Pose2D(NAN, 0.0, 0.0), R, Pose2D()).status().code(), StatusCode::kInvalidInput);
  Eigen::Matrix3d indefinite = R;
  indefinite(2, 2) = -1.0;
  EXPECT_EQ(filter.correctWithPose(Pose2D(), indefinite, Pose2D()).status().code(), StatusCode::kInvalidInput);
  Eigen::Matrix3d asymmetric = R;
  asymmetric(0, 1) = 5e-5;
  EXPECT_EQ(filter.correctWithPose(Pose2D(), asymmetric, Pose2D()).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(filter.align(Pose2D(), Pose2D(), indefinite).code(), StatusCode::kInvalidInput);
}

// Every scalar fix leaves its innovation, accepted or refused by the gate.
TEST(LocalizationFilter, ScalarFixesLeaveTheirInnovation) {
  LocalizationFilter filter;
  ASSERT_TRUE(filter.align(Pose2D(), Pose2D()).isOk());
  ASSERT_TRUE(filter.correctHeading(0.005, Pose2D()).isOk());
  auto taken = filter.takeInnovation();
  ASSERT_TRUE(taken);
  EXPECT_TRUE(taken->accepted);
  EXPECT_EQ(taken->dof, 1);
  EXPECT_NEAR(taken->nis, 0.005 * 0.005 / (2.0 * 7.6e-5), 1e-9);
  EXPECT_FALSE(filter.correctHeading(0.5, Pose2D()).isOk());  // far beyond the 4 σ gate
  taken = filter.takeInnovation();
  ASSERT_TRUE(taken);
  EXPECT_FALSE(taken->accepted);
  EXPECT_GT(taken->nis, 16.0);
}

}  // namespace
}  // namespace homography_teach_repeat
