#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <random>

#include <Eigen/Geometry>

#include "support/geometry_fixtures.h"
#include "homography_teach_repeat/fast_hd/plane_estimation.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

using namespace homography_teach_repeat;
using test_support::expectPoseNear;
using test_support::mathCamera;
using test_support::planeFromAngles;

namespace {

std::vector<Eigen::Vector2d> referencePixels(const ScenePlane& plane, const PlanarPose& pose,
                                             unsigned seed) {
  std::mt19937_64 rng(seed);
  std::vector<Eigen::Vector2d> pixels;
  for (const auto& m : sampleVisiblePlaneMatches(mathCamera(), plane, pose, 30, &rng)) {
    pixels.push_back(m.reference);
  }
  return pixels;
}

void expectPlaneNear(const ScenePlane& actual, const ScenePlane& expected, double tolerance) {
  EXPECT_LT((actual.normal - expected.normal).norm(), tolerance);
  EXPECT_NEAR(actual.distance, expected.distance, tolerance);
}

// The pairs of consecutive cameras (poses in the frame of camera 0) with their exact odometry and
// the homography of the wall `wall_of_pair(k)` (in that frame) that pair k sees.
std::vector<ReferencePair> odometryPairs(const std::vector<PlanarPose>& cameras,
                                         const std::function<ScenePlane(std::size_t)>& wall_of_pair) {
  std::vector<ReferencePair> pairs;
  for (std::size_t k = 0; k + 1 < cameras.size(); ++k) {
    const PlanarPose motion = cameras[k].inverse().compose(cameras[k + 1]);
    const auto seen = transferPlane(wall_of_pair(k), cameras[k]);
    EXPECT_TRUE(seen.isOk()) << k;
    ReferencePair pair;
    if (seen) pair.H_next_from_current = planeInducedHomography(mathCamera(), motion, *seen);
    pair.has_odometry = true;
    pair.odometry_motion = motion;
    pairs.push_back(pair);
  }
  return pairs;
}

}  // namespace

// β ≠ 0: positive depth + planar motion leave one solution (docs/math.md §2.1), scale from d1.
TEST(PlaneEstimation, FirstPlaneFromTiltedPlane) {
  const PlanarPose motion(0.4, 0.9, 0.15);
  const ScenePlane plane = planeFromAngles(0.3, 0.15, 6.0);
  const auto result =
      estimateFirstPlane(planeInducedHomography(mathCamera(), motion, plane), mathCamera(),
                         referencePixels(plane, motion, 1), plane.distance);
  ASSERT_TRUE(result.isOk()) << result.status().toString();
  expectPlaneNear(result->plane, plane, 1e-9);
  expectPoseNear(result->motion, motion, 1e-9);
  EXPECT_GE(result->candidates_after_planar_test, 1);
  EXPECT_FALSE(result->resolved_by_odometry);  // the spurious solution tilts: no tie
}

// β = 0 (a vertical wall): two planar solutions survive; odometry chooses, none is an error.
TEST(PlaneEstimation, VerticalPlaneNeedsOdometryToBreakTheTie) {
  const PlanarPose motion(-0.5, 1.2, -0.2);
  const ScenePlane plane = planeFromAngles(-0.25, 0.0, 5.0);
  const Eigen::Matrix3d H = planeInducedHomography(mathCamera(), motion, plane);
  const auto pixels = referencePixels(plane, motion, 2);
  const auto without = estimateFirstPlane(H, mathCamera(), pixels, plane.distance);
  EXPECT_EQ(without.status().code(), StatusCode::kDegenerate);
  // Odometry over a 1.3 m step: 3 cm and 0.01 rad off (the spurious solution here is 0.15 m and
  // 0.04 rad away from the truth).
  const PlanarPose odometry(motion.x + 0.02, motion.z - 0.02, motion.theta + 0.01);
  const auto with = estimateFirstPlane(H, mathCamera(), pixels, plane.distance, &odometry);
  ASSERT_TRUE(with.isOk()) << with.status().toString();
  EXPECT_TRUE(with->resolved_by_odometry);
  EXPECT_EQ(with->candidates_after_planar_test, 2);
  expectPlaneNear(with->plane, plane, 1e-9);
  expectPoseNear(with->motion, motion, 1e-9);
}

// The same tie broken by a third view of the plane from the first image (no odometry).
TEST(PlaneEstimation, VerticalPlaneTieBrokenByThirdView) {
  const PlanarPose motion(-0.5, 1.2, -0.2);
  const PlanarPose motion3(0.6, 2.0, 0.25);
  const ScenePlane plane = planeFromAngles(-0.25, 0.0, 5.0);
  const Eigen::Matrix3d H21 = planeInducedHomography(mathCamera(), motion, plane);
  const Eigen::Matrix3d H31 = planeInducedHomography(mathCamera(), motion3, plane);
  const auto result = estimateFirstPlane(H21, mathCamera(), referencePixels(plane, motion, 4),
                                         plane.distance, nullptr, &H31);
  ASSERT_TRUE(result.isOk()) << result.status().toString();
  EXPECT_TRUE(result->resolved_by_third_view);
  expectPlaneNear(result->plane, plane, 1e-9);
  expectPoseNear(result->motion, motion, 1e-9);
}

TEST(PlaneEstimation, FirstPlaneFailures) {
  const PlanarPose motion(0.4, 0.9, 0.15);
  const ScenePlane plane = planeFromAngles(0.3, 0.15, 6.0);
  const Eigen::Matrix3d H = planeInducedHomography(mathCamera(), motion, plane);
  const auto pixels = referencePixels(plane, motion, 3);
  EXPECT_EQ(estimateFirstPlane(H, mathCamera(), pixels, 0.0).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(estimateFirstPlane(H, mathCamera(), {}, 6.0).status().code(),
            StatusCode::kInvalidInput);
  // A camera that pitches (not a planar motion): no solution passes the planar test.
  Eigen::Matrix3d pitch;
  pitch = Eigen::AngleAxisd(0.5, Eigen::Vector3d::UnitX());
  const Eigen::Matrix3d H_pitch = mathCamera().K() * pitch * mathCamera().Kinverse() * H;
  EXPECT_EQ(estimateFirstPlane(H_pitch, mathCamera(), pixels, 6.0).status().code(),
            StatusCode::kDegenerate);
}

// docs/math.md §2.2: the transferred plane is the plane seen from the next camera.
TEST(PlaneEstimation, TransferPlaneMatchesDirectGeometry) {
  const ScenePlane plane = planeFromAngles(0.3, 0.2, 6.0);
  const PlanarPose pose(0.7, 1.5, 0.35);
  const auto next = transferPlane(plane, pose);
  ASSERT_TRUE(next.isOk());
  // A point of the plane, expressed in the next camera's frame, satisfies n2·X2 = d2.
  for (const Eigen::Vector3d& X1 : {Eigen::Vector3d(0.2, 0.1, 0.0), Eigen::Vector3d(-1.0, 0.4, 0.0)}) {
    Eigen::Vector3d point = X1;
    point.z() = (plane.distance - plane.normal.x() * point.x() - plane.normal.y() * point.y()) /
                plane.normal.z();
    const Eigen::Vector3d X2 = pose.rotation21() * (point - pose.centre());
    EXPECT_NEAR(next->normal.dot(X2), next->distance, 1e-12);
  }
  EXPECT_NEAR(next->normal.norm(), 1.0, 1e-12);
  const PlanarPose behind(plane.normal.x() * 7.0, plane.normal.z() * 7.0, 0.0);
  EXPECT_EQ(transferPlane(plane, behind).status().code(), StatusCode::kDegenerate);
}

// docs/math.md §2.3-2.4: the second plane from the homology of the two plane homographies.
TEST(PlaneEstimation, SecondPlaneFromHomology) {
  const PlanarPose motion(0.6, 1.1, -0.2);
  const ScenePlane first = planeFromAngles(0.3, 0.1, 6.0);
  const ScenePlane second = planeFromAngles(-0.7, 0.0, 4.0);
  const auto result = estimateSecondPlane(
      3.0 * planeInducedHomography(mathCamera(), motion, first),
      -0.5 * planeInducedHomography(mathCamera(), motion, second), mathCamera(), first, motion);
  ASSERT_TRUE(result.isOk()) << result.status().toString();
  expectPlaneNear(*result, second, 1e-9);
  EXPECT_EQ(estimateSecondPlane(planeInducedHomography(mathCamera(), PlanarPose(0, 0, 0.1), first),
                                planeInducedHomography(mathCamera(), PlanarPose(0, 0, 0.1), second),
                                mathCamera(), first, PlanarPose(0, 0, 0.1))
                .status()
                .code(),
            StatusCode::kDegenerate);
}

// A taught route of four references: planes and motions everywhere from the first distance.
TEST(PlaneEstimation, PlanesAlongRoute) {
  // β = 0 (a vertical wall): the first pair is a tie, broken by the second pair (third view).
  const ScenePlane plane0 = planeFromAngles(0.2, 0.0, 8.0);
  const std::vector<PlanarPose> steps{PlanarPose(0.3, 1.0, 0.1), PlanarPose(-0.2, 0.8, -0.15),
                                      PlanarPose(0.1, 0.9, 0.05)};
  std::vector<ReferencePair> pairs;
  std::vector<ScenePlane> truth{plane0};
  for (std::size_t k = 0; k < steps.size(); ++k) {
    ReferencePair pair;
    pair.H_next_from_current = planeInducedHomography(mathCamera(), steps[k], truth.back());
    pair.reference_pixels = referencePixels(truth.back(), steps[k], 10 + k);
    truth.push_back(*transferPlane(truth.back(), steps[k]));
    pairs.push_back(pair);
  }
  const auto route = estimatePlanesAlongRoute(pairs, mathCamera(), plane0.distance);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  ASSERT_EQ(route->planes.size(), 4u);
  for (std::size_t k = 0; k < truth.size(); ++k) expectPlaneNear(route->planes[k], truth[k], 1e-9);
  for (std::size_t k = 0; k < steps.size(); ++k) expectPoseNear(route->motions[k], steps[k], 1e-9);
  EXPECT_EQ(estimatePlanesAlongRoute({}, mathCamera(), 8.0).status().code(),
            StatusCode::kTooFewPoints);
}

// docs/math.md §2.4's form without the homology: the plane from a homography and the known metric
// motion, at any scale and sign of H; a pure rotation is refused.
TEST(PlaneEstimation, PlaneFromHomographyAndKnownMotion) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const double alpha = 0.6 * u(rng), beta = 0.2 * u(rng);
    const ScenePlane plane{Eigen::Vector3d(std::cos(beta) * std::sin(alpha), std::sin(beta),
                                           std::cos(beta) * std::cos(alpha)),
                           2.0 + 3.0 * (u(rng) + 1.0)};
    const PlanarPose motion(0.4 * u(rng), 0.5 * u(rng) + 0.6, 0.3 * u(rng));
    const Eigen::Matrix3d H = -3.7 * planeInducedHomography(mathCamera(), motion, plane);
    const auto estimated = planeFromHomographyAndMotion(H, mathCamera(), motion);
    ASSERT_TRUE(estimated.isOk()) << estimated.status().toString();
    EXPECT_NEAR((estimated->normal - plane.normal).norm(), 0.0, 1e-9) << trial;
    EXPECT_NEAR(estimated->distance, plane.distance, 1e-9 * plane.distance) << trial;
  }
  const PlanarPose rotation(0.0, 0.0, 0.3);
  const ScenePlane wall{Eigen::Vector3d::UnitZ(), 3.0};
  EXPECT_EQ(planeFromHomographyAndMotion(planeInducedHomography(mathCamera(), rotation, wall), mathCamera(),
                                         rotation, 0.1)
                .status()
                .code(),
            StatusCode::kDegenerate);
}

// Round a corner: two walls, a turn in place between them. Each leg's keyframes get their own
// wall from the odometry; the keyframes of the turn inherit the transferred plane.
TEST(PlaneEstimation, PlanesFromOdometryAcrossTwoWalls) {
  // Leg 1 faces the wall z = 5 (frame of keyframe 0); then the camera turns 90° left in place and
  // faces the wall x = -4 of frame 0.
  const ScenePlane wall_a{Eigen::Vector3d::UnitZ(), 5.0};
  const ScenePlane wall_b{-Eigen::Vector3d::UnitX(), 4.0};
  std::vector<PlanarPose> cameras = {PlanarPose(0, 0, 0), PlanarPose(0, 0.5, 0), PlanarPose(0, 1.0, 0),
                                     PlanarPose(0, 1.0, M_PI / 4), PlanarPose(0, 1.0, M_PI / 2),
                                     PlanarPose(-0.5, 1.0, M_PI / 2), PlanarPose(-1.0, 1.0, M_PI / 2)};
  std::vector<ReferencePair> pairs = odometryPairs(cameras, [&](std::size_t k) { return k >= 3 ? wall_b : wall_a; });
  pairs[1].has_homography = false;  // a failed pair: filled by transfer
  const auto result = estimatePlanesFromOdometry(pairs, mathCamera());
  ASSERT_TRUE(result.isOk()) << result.status().toString();
  ASSERT_EQ(result->planes.size(), cameras.size());
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    // Keyframes 0..3 see wall a (3 is the turn's start, transferred), 4.. see wall b.
    const auto truth = transferPlane(k <= 3 ? wall_a : wall_b, cameras[k]);
    ASSERT_TRUE(truth.isOk());
    EXPECT_NEAR((result->planes[k].normal - truth->normal).norm(), 0.0, 1e-6) << k;
    EXPECT_NEAR(result->planes[k].distance, truth->distance, 1e-6) << k;
  }
}

// docs/math.md §2.6: a keyframe whose next pair turns takes its plane from the straight pair
// before it. The turning pair's homography is made wrong on purpose (the plane it sees tilted 5°,
// as a turn's homography misleads §2.4 in the simulator's gallery): the keyframe gets the true
// plane, carried from the pair before; with the margin negative it keeps the turning pair's; a
// keyframe whose pair before turned as much keeps its own pair's.
TEST(PlaneEstimation, AKeyframeBeforeATurnTakesTheStraighterPair) {
  const ScenePlane wall{Eigen::Vector3d::UnitZ(), 5.0};
  const std::vector<PlanarPose> cameras = {PlanarPose(0, 0, 0), PlanarPose(0, 0.5, 0), PlanarPose(0, 1.0, 0),
                                           PlanarPose(0.1, 1.5, 0.4), PlanarPose(0.3, 1.9, 0.8)};
  const ScenePlane misread{Eigen::Vector3d(std::sin(0.087), 0.0, std::cos(0.087)), 5.0};
  const std::vector<ReferencePair> pairs = odometryPairs(cameras, [&](std::size_t k) { return k == 2 ? misread : wall; });
  const auto truth = transferPlane(wall, cameras[2]);
  const auto misread_at_2 = transferPlane(misread, cameras[2]);
  ASSERT_TRUE(truth.isOk() && misread_at_2.isOk());

  const auto chosen = estimatePlanesFromOdometry(pairs, mathCamera());
  ASSERT_TRUE(chosen.isOk()) << chosen.status().toString();
  EXPECT_NEAR((chosen->planes[2].normal - truth->normal).norm(), 0.0, 1e-6);
  EXPECT_NEAR(chosen->planes[2].distance, truth->distance, 1e-6);
  // Keyframe 3: the pair before it (the misread turn, 0.4 rad) turned as much as its own: its own.
  const auto truth_3 = transferPlane(wall, cameras[3]);
  ASSERT_TRUE(truth_3.isOk());
  EXPECT_NEAR((chosen->planes[3].normal - truth_3->normal).norm(), 0.0, 1e-6);

  OdometryPlaneOptions always_next;
  always_next.straighter_pair_margin = -1.0;
  const auto next = estimatePlanesFromOdometry(pairs, mathCamera(), always_next);
  ASSERT_TRUE(next.isOk()) << next.status().toString();
  EXPECT_NEAR((next->planes[2].normal - misread_at_2->normal).norm(), 0.0, 1e-6);
}

// docs/math.md §2.6: a closed route's closing corner. Round a room of four walls, turning left in
// place at each corner; at the end the camera turns from the last leg's wall towards the first
// leg's. Without the closing motion both keyframes of that turn keep the last leg's wall (filled
// forwards); with it the one facing nearer the first keyframe's heading takes the first keyframe's
// wall, carried back, and the one facing nearer the last leg keeps that leg's.
TEST(PlaneEstimation, TheClosingCornerOfALoopFacesTheFirstWall) {
  // In the frame of camera 0: walls z = 5 (faced at heading 0), x = -4 (π/2), z = -3 (π), x = 3 (3π/2).
  const std::vector<ScenePlane> walls = {ScenePlane{Eigen::Vector3d::UnitZ(), 5.0}, ScenePlane{-Eigen::Vector3d::UnitX(), 4.0},
                                         ScenePlane{-Eigen::Vector3d::UnitZ(), 3.0}, ScenePlane{Eigen::Vector3d::UnitX(), 3.0}};
  const double q = M_PI / 2;
  const std::vector<PlanarPose> cameras = {
      PlanarPose(0, 0, 0),          PlanarPose(0, 0.5, 0),        PlanarPose(0, 1, 0),         PlanarPose(0, 1, q / 2),
      PlanarPose(0, 1, q),          PlanarPose(-0.5, 1, q),       PlanarPose(-1, 1, q),        PlanarPose(-1, 1, 1.5 * q),
      PlanarPose(-1, 1, 2 * q),     PlanarPose(-1, 0.5, 2 * q),   PlanarPose(-1, 0, 2 * q),    PlanarPose(-1, 0, 2.5 * q),
      PlanarPose(-1, 0, 3 * q),     PlanarPose(-0.5, 0, 3 * q),   PlanarPose(0, 0, 3 * q),
      PlanarPose(0, 0, 3 * q + M_PI / 6), PlanarPose(0, 0, 3 * q + M_PI / 3)};  // the closing corner
  auto faced = [&](std::size_t k) {
    return walls[static_cast<std::size_t>(std::lround(cameras[k].theta / q)) % walls.size()];
  };
  const std::vector<ReferencePair> pairs = odometryPairs(cameras, faced);
  OdometryPlaneOptions closed;
  closed.closing_motion = cameras.back().inverse().compose(cameras.front());
  ASSERT_NEAR(closed.closing_motion->theta, M_PI / 6, 1e-12);
  const auto open_route = estimatePlanesFromOdometry(pairs, mathCamera());
  const auto loop = estimatePlanesFromOdometry(pairs, mathCamera(), closed);
  ASSERT_TRUE(open_route.isOk()) << open_route.status().toString();
  ASSERT_TRUE(loop.isOk()) << loop.status().toString();
  const std::size_t n = cameras.size();
  auto expectWall = [&](const ScenePlane& plane, const ScenePlane& wall, std::size_t k, const char* what) {
    const auto truth = transferPlane(wall, cameras[k]);
    ASSERT_TRUE(truth.isOk());
    EXPECT_NEAR((plane.normal - truth->normal).norm(), 0.0, 1e-6) << what << " keyframe " << k;
    EXPECT_NEAR(plane.distance, truth->distance, 1e-6) << what << " keyframe " << k;
  };
  for (const std::size_t k : {n - 2, n - 1}) expectWall(open_route->planes[k], walls[3], k, "open");
  expectWall(loop->planes[n - 2], walls[3], n - 2, "loop");  // 30° from the last leg, 60° from the first
  expectWall(loop->planes[n - 1], walls[0], n - 1, "loop");  // 60° from the last leg, 30° from the first
  for (std::size_t k = 0; k + 2 < n; ++k) {  // the rest of the route as without the closing motion
    EXPECT_NEAR((loop->planes[k].normal - open_route->planes[k].normal).norm(), 0.0, 1e-12) << k;
  }
}

// docs/math.md §2.5: the second camera tilted (pitch, roll) relative to the first. The planar-motion
// formula reads the tilt as a wrong plane; the tilt-aware one recovers plane and tilt, for forward
// and sideways motion, at any scale and sign of H; the same call on level data reports no tilt.
TEST(PlaneEstimation, PlaneAndTiltFromHomographyAndKnownMotion) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    const double alpha = 0.6 * u(rng), beta = 0.3 * u(rng);
    const ScenePlane plane{Eigen::Vector3d(std::cos(beta) * std::sin(alpha), std::sin(beta),
                                           std::cos(beta) * std::cos(alpha)),
                           2.0 + 3.0 * (u(rng) + 1.0)};
    const PlanarPose motion = trial % 2 == 0 ? PlanarPose(0.1 * u(rng), 1.0 + 0.5 * u(rng), 0.2 * u(rng))
                                             : PlanarPose(0.8 + 0.2 * u(rng), 0.2 * u(rng), 0.2 * u(rng));
    const double pitch = 0.03 * u(rng), roll = 0.03 * u(rng);
    const Eigen::Matrix3d T = (Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) *
                               Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
                                  .toRotationMatrix();
    const PinholeCamera& camera = mathCamera();
    const Eigen::Matrix3d H =
        -2.3 * camera.K() * T * camera.Kinverse() * planeInducedHomography(camera, motion, plane);
    const auto estimated = planeAndTiltFromHomographyAndMotion(H, camera, motion);
    ASSERT_TRUE(estimated.isOk()) << trial << ": " << estimated.status().toString();
    EXPECT_NEAR((estimated->plane.normal - plane.normal).norm(), 0.0, 1e-9) << trial;
    EXPECT_NEAR(estimated->plane.distance, plane.distance, 1e-9 * plane.distance) << trial;
    EXPECT_NEAR(estimated->pitch, pitch, 1e-10) << trial;
    EXPECT_NEAR(estimated->roll, roll, 1e-10) << trial;
    // Without the tilt the plane is wrong: what the constant-mount teach run used to store.
    const auto planar = planeFromHomographyAndMotion(H, camera, motion);
    if (planar && std::hypot(pitch, roll) > 0.01) {
      EXPECT_GT((planar->normal - plane.normal).norm() + std::abs(planar->distance - plane.distance), 1e-3) << trial;
    }
  }
  const PlanarPose forward(0.0, 1.0, 0.0);
  const ScenePlane wall{Eigen::Vector3d(-0.6, 0.0, 0.8), 5.0};
  const auto level = planeAndTiltFromHomographyAndMotion(planeInducedHomography(mathCamera(), forward, wall),
                                                         mathCamera(), forward);
  ASSERT_TRUE(level.isOk()) << level.status().toString();
  EXPECT_LT((level->tilt() - Eigen::Matrix3d::Identity()).norm(), 1e-12);
  // A pure rotation does not see the plane; a tilt beyond max_tilt is refused.
  const PlanarPose rotation(0.0, 0.0, 0.3);
  EXPECT_EQ(planeAndTiltFromHomographyAndMotion(planeInducedHomography(mathCamera(), rotation, wall), mathCamera(),
                                                rotation, 0.1)
                .status()
                .code(),
            StatusCode::kDegenerate);
  const Eigen::Matrix3d big_pitch = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()).toRotationMatrix();
  EXPECT_EQ(planeAndTiltFromHomographyAndMotion(mathCamera().K() * big_pitch * mathCamera().Kinverse() *
                                                    planeInducedHomography(mathCamera(), forward, wall),
                                                mathCamera(), forward)
                .status()
                .code(),
            StatusCode::kDegenerate);
}

// ratePlaneMatches: a wall's matches lie on its plane (with parallax where the camera moved across
// it), a wall twice as far does not; a turn in place predicts no parallax and confirms nothing; a
// tilted neighbour's matches miss the planar-motion prediction unless the pair's tilt is fitted.
TEST(PlaneEstimation, MatchesRatedAgainstTheKeyframesPlane) {
  const PinholeCamera& camera = mathCamera();
  const ScenePlane wall{Eigen::Vector3d(0.0, 0.0, 1.0), 5.0};
  const ScenePlane far_wall{Eigen::Vector3d(0.0, 0.0, 1.0), 10.0};
  const PlanarPose sideways(0.5, 0.3, 0.05);
  std::mt19937_64 rng(3);
  PointMatches matches = sampleVisiblePlaneMatches(camera, wall, sideways, 30, &rng);
  for (const PointMatch& far : sampleVisiblePlaneMatches(camera, far_wall, sideways, 10, &rng)) matches.push_back(far);
  const double tolerance = 2.0;
  const auto ratings = ratePlaneMatches(matches, camera, sideways, wall, tolerance, std::nullopt);
  ASSERT_EQ(ratings.size(), matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i) {
    EXPECT_EQ(ratings[i], i < 30 ? PlaneMatchRating::kOnWithParallax : PlaneMatchRating::kOffThePlane) << i;
  }

  const PlanarPose turn(0.0, 0.0, 0.2);
  PointMatches turned = sampleVisiblePlaneMatches(camera, wall, turn, 10, &rng);
  for (const PointMatch& far : sampleVisiblePlaneMatches(camera, far_wall, turn, 10, &rng)) turned.push_back(far);
  for (const PlaneMatchRating rating : ratePlaneMatches(turned, camera, turn, wall, tolerance, std::nullopt)) {
    EXPECT_EQ(rating, PlaneMatchRating::kOnWithoutParallax);
  }

  // The neighbour pitched by 0.02 rad: ~10 px off the planar prediction.
  const Eigen::Matrix3d T = camera.K() * Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitX()).toRotationMatrix() *
                            camera.Kinverse();
  PointMatches tilted = sampleVisiblePlaneMatches(camera, wall, sideways, 40, &rng);
  for (PointMatch& match : tilted) match.current = applyHomography(T, match.current);
  const auto level = ratePlaneMatches(tilted, camera, sideways, wall, tolerance, std::nullopt);
  EXPECT_EQ(std::count(level.begin(), level.end(), PlaneMatchRating::kOffThePlane), 40);
  const auto fitted = ratePlaneMatches(tilted, camera, sideways, wall, tolerance, RobustHomographyOptions{});
  EXPECT_EQ(std::count(fitted.begin(), fitted.end(), PlaneMatchRating::kOnWithParallax), 40);
}
