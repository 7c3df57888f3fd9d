#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include <Eigen/Eigenvalues>

#include "homography_teach_repeat/teach_repeat/repeat_localizer.h"
#include "support/synthetic_route_test.h"

using namespace homography_teach_repeat;

namespace {

// The robot pose (base = camera, mount at the origin) of a camera pose of the synthetic scene.
Pose2D basePose(const PlanarPose& camera_pose) { return cameraAxesToRep103(camera_pose); }

using RepeatLocalizerTest = test_support::SyntheticRouteTest;

}  // namespace

// Fast-HD mode along a path that is 8 cm to the side of the taught one and turned by 2°: the
// base pose in the route frame within 2 cm / 0.2°, a covariance, and the tracked keyframe moving on.
TEST_F(RepeatLocalizerTest, FastHdFollowsTheRoute) {
  RepeatOptions options;
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  EXPECT_EQ(localizer->keyframeCount(), 6);
  int last_keyframe = 0;
  for (int step = 0; step < 14; ++step) {
    const double s = 0.1 * step + 0.03;
    const PlanarPose camera_pose(0.08 * s + 0.08, s, 0.04 * s + 0.035);
    const auto estimate = localizer->localize(wall_->imageAt(camera_pose));
    ASSERT_TRUE(estimate.isOk()) << step << ": " << estimate.status().toString();
    EXPECT_FALSE(estimate->degraded);
    ASSERT_TRUE(estimate->has_pose);
    EXPECT_TRUE(estimate->covariance_known);
    const Pose2D truth = basePose(camera_pose);
    EXPECT_NEAR(estimate->base_pose.x, truth.x, 0.02) << step;
    EXPECT_NEAR(estimate->base_pose.y, truth.y, 0.02) << step;
    EXPECT_NEAR(wrapToPi(estimate->base_pose.yaw - truth.yaw), 0.0, 0.2 * M_PI / 180.0) << step;
    const Eigen::Matrix3d& c = estimate->covariance;
    EXPECT_GT(c(0, 0), 0.0);
    EXPECT_LT(std::sqrt(c(0, 0) + c(1, 1)), 0.2);
    EXPECT_GE(localizer->trackedKeyframe(), last_keyframe);
    last_keyframe = localizer->trackedKeyframe();
  }
  EXPECT_GE(last_keyframe, 4);
}

// μ mode: the heading relative to the keyframe from vertical lines (pure rotation at a keyframe).
TEST_F(RepeatLocalizerTest, MuModeGivesTheHeading) {
  RepeatOptions options;
  options.mode = RepeatMode::kMu;
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  const Route& r = localizer->route();
  for (const double yaw : {-0.06, 0.03, 0.08}) {
    localizer->setTrackedKeyframe(2);
    const PlanarPose keyframe_camera = rep103ToCameraAxes(r.keyframes[2].pose);
    const PlanarPose turned(keyframe_camera.x, keyframe_camera.z, keyframe_camera.theta + yaw);
    const auto estimate = localizer->localize(wall_->imageAt(turned));
    ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
    EXPECT_FALSE(estimate->has_pose);
    EXPECT_EQ(estimate->keyframe, 2);
    EXPECT_NEAR(estimate->heading_correction, yaw, 0.15 * M_PI / 180.0);
  }
}

// μ mode gives no position, so tracking moves on from a position known otherwise (the
// heading-aided odometry of repeat_node): to the keyframe nearest that position, never back.
TEST_F(RepeatLocalizerTest, MuModeTrackingFollowsAnExternalPosition) {
  RepeatOptions options;
  options.mode = RepeatMode::kMu;
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  const Route& r = localizer->route();
  localizer->setTrackedKeyframe(0);
  localizer->advanceTrackingTo(r.keyframes[3].pose);
  EXPECT_EQ(localizer->trackedKeyframe(), 3);
  localizer->advanceTrackingTo(r.keyframes[1].pose);  // never backwards
  EXPECT_EQ(localizer->trackedKeyframe(), 3);
  localizer->advanceTrackingTo(Pose2D(NAN, 0.0, 0.0));
  EXPECT_EQ(localizer->trackedKeyframe(), 3);
  localizer->advanceTrackingTo(r.keyframes.back().pose);
  EXPECT_EQ(localizer->trackedKeyframe(), localizer->keyframeCount() - 1);
}

// Where the teach run turned in place the keyframes share a position: tracking follows the heading.
TEST_F(RepeatLocalizerTest, MuTrackingFollowsATurnInPlace) {
  Route turning = route();
  const Pose2D corner = turning.keyframes[2].pose;
  for (int k = 3; k < 6; ++k) {
    turning.keyframes[static_cast<std::size_t>(k)].pose = Pose2D(corner.x, corner.y, corner.yaw + 0.4 * (k - 2));
  }
  RepeatOptions options;
  options.mode = RepeatMode::kMu;
  options.closed_route_gap = 0.0;
  auto localizer = RepeatLocalizer::create(turning, options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  localizer->setTrackedKeyframe(2);
  localizer->advanceTrackingTo(Pose2D(corner.x, corner.y, corner.yaw + 0.05));
  EXPECT_EQ(localizer->trackedKeyframe(), 2);
  localizer->advanceTrackingTo(Pose2D(corner.x, corner.y, corner.yaw + 0.85));
  EXPECT_EQ(localizer->trackedKeyframe(), 4);
}

// μ mode: keyframes the teach run took turning in place give no heading fix (docs/math.md §4.5: the
// translation coupling is large against the near walls of a corner); the first keyframe never
// counts as one.
TEST_F(RepeatLocalizerTest, MuModeSkipsTurnKeyframes) {
  Route turning = route();
  const Pose2D corner = turning.keyframes[2].pose;
  turning.keyframes[3].pose = Pose2D(corner.x, corner.y, corner.yaw + 0.4);
  RepeatOptions options;
  options.mode = RepeatMode::kMu;
  options.neighbour_search = 0;
  options.closed_route_gap = 0.0;
  auto localizer = RepeatLocalizer::create(turning, options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  EXPECT_FALSE(localizer->isTurnKeyframe(0));
  EXPECT_FALSE(localizer->isTurnKeyframe(1));
  EXPECT_TRUE(localizer->isTurnKeyframe(2));  // where the teach run started turning
  EXPECT_TRUE(localizer->isTurnKeyframe(3));
  const PlanarPose camera = rep103ToCameraAxes(turning.keyframes[2].pose);
  localizer->setTrackedKeyframe(3);
  const auto skipped = localizer->localize(wall_->imageAt(camera));
  ASSERT_FALSE(skipped.isOk());
  EXPECT_EQ(skipped.status().code(), StatusCode::kNoConsensus);
  EXPECT_NE(skipped.status().message().find("turned in place"), std::string::npos) << skipped.status().toString();
  options.mu_skip_turn_keyframes = false;
  auto all = RepeatLocalizer::create(turning, options);
  ASSERT_TRUE(all.isOk());
  all->setTrackedKeyframe(2);
  EXPECT_TRUE(all->localize(wall_->imageAt(camera)).isOk());
}

// μ mode with the heading the odometry predicts: only keyframes facing that way are tried.
TEST_F(RepeatLocalizerTest, MuModeTriesOnlyKeyframesFacingThePredictedHeading) {
  RepeatOptions options;
  options.mode = RepeatMode::kMu;
  options.neighbour_search = 0;
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  const Pose2D keyframe = localizer->route().keyframes[2].pose;
  const PlanarPose camera = rep103ToCameraAxes(keyframe);
  const PlanarPose turned(camera.x, camera.z, camera.theta + 0.03);
  const cv::Mat image = wall_->imageAt(turned);
  localizer->setTrackedKeyframe(2);
  const auto near = localizer->localize(image, Pose2D(keyframe.x, keyframe.y, keyframe.yaw + 0.03));
  ASSERT_TRUE(near.isOk()) << near.status().toString();
  EXPECT_NEAR(near->heading_correction, 0.03, 0.15 * M_PI / 180.0);
  const auto far = localizer->localize(image, Pose2D(keyframe.x, keyframe.y, keyframe.yaw + 0.5));
  ASSERT_FALSE(far.isOk());
  EXPECT_EQ(far.status().code(), StatusCode::kNoConsensus);
  EXPECT_TRUE(localizer->localize(image, Pose2D(keyframe.x, keyframe.y, NAN)).isOk());  // no usable prior: every keyframe
  options.mu_max_reference_angle = 0.0;
  EXPECT_FALSE(RepeatLocalizer::create(route(), options).isOk());
}

// A loop (last keyframe near the first): tracking wraps from the last keyframe to the first, so
// a second lap is localized; an open route never wraps.
TEST_F(RepeatLocalizerTest, ClosedRouteTrackingWrapsAround) {
  Route loop = route();
  const Pose2D first = loop.keyframes.front().pose;
  loop.keyframes.back().pose = Pose2D(first.x - 0.3, first.y, first.yaw);
  EXPECT_TRUE(isClosedRoute(loop, 1.0));
  EXPECT_FALSE(isClosedRoute(route(), 1.0));
  RepeatOptions options;
  options.mode = RepeatMode::kMu;
  auto closed = RepeatLocalizer::create(loop, options);
  ASSERT_TRUE(closed.isOk()) << closed.status().toString();
  EXPECT_TRUE(closed->closedRoute());
  closed->setTrackedKeyframe(closed->keyframeCount() - 1);
  closed->advanceTrackingTo(first);
  EXPECT_EQ(closed->trackedKeyframe(), 0);
  options.closed_route_gap = 0.0;  // disabled
  auto open = RepeatLocalizer::create(loop, options);
  ASSERT_TRUE(open.isOk());
  EXPECT_FALSE(open->closedRoute());
  open->setTrackedKeyframe(open->keyframeCount() - 1);
  open->advanceTrackingTo(first);
  EXPECT_EQ(open->trackedKeyframe(), open->keyframeCount() - 1);
}

TEST_F(RepeatLocalizerTest, ClassicModeBaseline) {
  RepeatOptions options;
  options.mode = RepeatMode::kClassic;
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk());
  const PlanarPose camera_pose(0.1, 0.35, 0.03);
  const auto estimate = localizer->localize(wall_->imageAt(camera_pose));
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_FALSE(estimate->covariance_known);
  EXPECT_NEAR(estimate->base_pose.x, basePose(camera_pose).x, 0.05);
  EXPECT_NEAR(estimate->base_pose.y, basePose(camera_pose).y, 0.05);
}

// Start anywhere on the route: the best-matching keyframe is found.
TEST_F(RepeatLocalizerTest, GlobalInitialization) {
  auto localizer = RepeatLocalizer::create(route(), RepeatOptions());
  ASSERT_TRUE(localizer.isOk());
  const PlanarPose camera_pose(0.08 * 1.2, 1.2, 0.04 * 1.2);
  const auto estimate = localizer->initializeGlobally(wall_->imageAt(camera_pose));
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_GE(localizer->trackedKeyframe(), 3);
  EXPECT_NEAR(estimate->base_pose.x, basePose(camera_pose).x, 0.02);
}

// Every keyframe failing (here: a min_inliers no keyframe reaches after a strong turn) falls back
// to the last good frame as a temporary reference, flagged degraded; a frame of another scene
// gives a failure status and no pose.
TEST_F(RepeatLocalizerTest, LostTrackingUsesTheTemporaryReferenceThenFails) {
  RepeatOptions options;
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk());
  ASSERT_TRUE(localizer->localize(wall_->imageAt(PlanarPose(0.02, 0.05, 0.01))).isOk());
  // Another wall texture: nothing matches, not even the temporary reference.
  const cv::Mat other = test_support::makeTexture(640, 480, 99);
  const auto lost = localizer->localize(other);
  EXPECT_FALSE(lost.isOk());
  // Bad images.
  EXPECT_EQ(localizer->localize(cv::Mat()).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(localizer->localize(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0))).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_FALSE(localizer->localize(cv::Mat(480, 640, CV_8UC1, cv::Scalar(90))).isOk());
}

// Frame A is turned 0.12 rad from keyframe 0, frame B 0.24 rad: with min_inliers between what B
// and A get against the keyframe, A localizes on the keyframe, B fails there and localizes on A
// (the temporary reference, the same 0.12 rad apart), flagged degraded.
TEST_F(RepeatLocalizerTest, DegradedWhenOnlyTheLastFrameMatches) {
  const PlanarPose a(0.0, 0.0, 0.12), b(0.0, 0.0, 0.24);
  RepeatOptions probe;
  probe.neighbour_search = 0;
  probe.max_degraded_frames = 0;
  auto permissive = RepeatLocalizer::create(route(), probe);
  ASSERT_TRUE(permissive.isOk());
  const auto on_a = permissive->localize(wall_->imageAt(a));
  permissive->setTrackedKeyframe(0);
  const auto on_b = permissive->localize(wall_->imageAt(b));
  ASSERT_TRUE(on_a.isOk() && on_b.isOk());
  ASSERT_GT(on_a->inliers, on_b->inliers + 20) << "the turn must cost keyframe inliers";

  RepeatOptions strict;
  strict.neighbour_search = 0;
  strict.min_inliers = (on_a->inliers + on_b->inliers) / 2;
  auto localizer = RepeatLocalizer::create(route(), strict);
  ASSERT_TRUE(localizer.isOk());
  const auto first = localizer->localize(wall_->imageAt(a));
  ASSERT_TRUE(first.isOk() && first->covariance_known);
  localizer->setTrackedKeyframe(0);
  const auto estimate = localizer->localize(wall_->imageAt(b));
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_TRUE(estimate->degraded);
  // B's pose is measured against A's estimate: A's uncertainty is in B's covariance.
  ASSERT_TRUE(estimate->covariance_known);
  const Eigen::Matrix3d excess = estimate->covariance - first->covariance;
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(excess).eigenvalues().minCoeff(), -1e-12)
      << "covariance of B:\n" << estimate->covariance << "\nof A:\n" << first->covariance;
  EXPECT_EQ(estimate->keyframe, 0);
  EXPECT_NEAR(estimate->base_pose.x, basePose(b).x, 0.03);
  EXPECT_NEAR(estimate->base_pose.y, basePose(b).y, 0.03);
  EXPECT_NEAR(wrapToPi(estimate->base_pose.yaw - b.theta), 0.0, 0.01);
  // With no temporary reference allowed, the same frame is a failure, never a pose.
  RepeatOptions no_fallback = strict;
  no_fallback.max_degraded_frames = 0;
  auto strict_only = RepeatLocalizer::create(route(), no_fallback);
  ASSERT_TRUE(strict_only->localize(wall_->imageAt(a)).isOk());
  strict_only->setTrackedKeyframe(0);
  EXPECT_EQ(strict_only->localize(wall_->imageAt(b)).status().code(), StatusCode::kNoConsensus);
}

// The temporary reference keeps only the features on the keyframe's plane (docs/reliability.md,
// "Temporary reference"): frame A shows the taught wall with a box in front of it (a texture the
// keyframe never saw); frame B shows only that box. Matched against A's whole image, B would give
// a pose from the box's features read as the wall's; kept to A's inliers, the temporary reference
// has none of the box's, and B gets no pose.
TEST_F(RepeatLocalizerTest, TheTemporaryReferenceKeepsOnlyThePlanesFeatures) {
  const PlanarPose a(0.02, 0.05, 0.01);
  cv::Mat with_box = wall_->imageAt(a);
  const cv::Rect box(20, 120, 260, 240);
  test_support::makeTexture(box.width, box.height, 77).copyTo(with_box(box));
  cv::Mat only_box(with_box.size(), with_box.type(), cv::Scalar(128));
  with_box(box).copyTo(only_box(box));

  RepeatOptions options;
  options.neighbour_search = 0;
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk());
  const auto on_a = localizer->localize(with_box);
  ASSERT_TRUE(on_a.isOk()) << on_a.status().toString();
  ASSERT_FALSE(on_a->degraded);
  const auto on_b = localizer->localize(only_box);
  EXPECT_FALSE(on_b.isOk() && on_b->has_pose)
      << "a pose from the box's features, keyframe " << on_b->keyframe << (on_b->degraded ? " (degraded)" : "");
}

TEST(RepeatLocalizer, RouteWithoutPlanesNeedsMuMode) {
  Route route;
  route.directory = "/nonexistent";
  route.info.camera = test_support::syntheticCalibration();
  RouteKeyframe k;
  route.keyframes.push_back(k);
  EXPECT_EQ(RepeatLocalizer::create(route, RepeatOptions()).status().code(),
            StatusCode::kInvalidInput);
  Route empty = route;
  empty.keyframes.clear();
  EXPECT_EQ(RepeatLocalizer::create(empty, RepeatOptions()).status().code(), StatusCode::kInvalidInput);
  RepeatOptions bad;
  bad.min_inliers = 2;
  EXPECT_EQ(RepeatLocalizer::create(route, bad).status().code(), StatusCode::kInvalidInput);
  EXPECT_THROW(repeatModeFromString("fast"), std::invalid_argument);
}

// Frames 1 cm apart past keyframe 1: with max_tracked_frames 2 the two frames after a detected
// one take its inliers on by optical flow, the third is detected again; tracked poses are as
// accurate as detected ones (~1 mm, 0.02° here).
TEST_F(RepeatLocalizerTest, FramesBetweenDetectionsAreTracked) {
  RepeatOptions options;
  options.max_tracked_frames = 2;
  options.background_detection = false;  // test_background_detection.cpp
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  localizer->setTrackedKeyframe(1);
  const std::vector<bool> tracked{false, true, true, false, true, true, false};
  for (std::size_t step = 0; step < tracked.size(); ++step) {
    const double s = 0.31 + 0.01 * static_cast<double>(step);
    const PlanarPose camera_pose(0.08 * s + 0.06, s, 0.04 * s + 0.035);
    const auto estimate = localizer->localize(wall_->imageAt(camera_pose));
    ASSERT_TRUE(estimate.isOk()) << step << ": " << estimate.status().toString();
    EXPECT_EQ(estimate->tracked, tracked[step]) << step;
    EXPECT_EQ(localizer->lastTiming().tracked, tracked[step]) << step;
    EXPECT_EQ(localizer->lastTiming().references_tried, 1) << step;
    expectAccurateAgainstKeyframe1(*estimate, camera_pose, step);
  }
}

// A frame turned 0.2 rad (~100 px of image motion) after a detected one: the optical flow loses
// the points (forward-backward check), the frame is detected instead, and the pose is right.
TEST_F(RepeatLocalizerTest, TrackingFallsBackToDetection) {
  auto localizer = RepeatLocalizer::create(route(), RepeatOptions());
  ASSERT_TRUE(localizer.isOk());
  localizer->setTrackedKeyframe(1);
  ASSERT_TRUE(localizer->localize(wall_->imageAt(PlanarPose(0.085, 0.31, 0.047))).isOk());
  const PlanarPose turned(0.085, 0.32, 0.247);
  const auto estimate = localizer->localize(wall_->imageAt(turned));
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_FALSE(estimate->tracked);
  EXPECT_FALSE(localizer->lastTiming().tracked);
  EXPECT_NEAR(estimate->base_pose.x, basePose(turned).x, 0.005);
  EXPECT_NEAR(estimate->base_pose.y, basePose(turned).y, 0.005);
  EXPECT_NEAR(wrapToPi(estimate->base_pose.yaw - basePose(turned).yaw), 0.0, 0.1 * M_PI / 180.0);
  // An image of another wall after a detected frame: tracking and detection fail, no pose.
  ASSERT_TRUE(localizer->localize(wall_->imageAt(PlanarPose(0.085, 0.33, 0.047))).isOk());
  EXPECT_FALSE(localizer->localize(test_support::makeTexture(640, 480, 99)).isOk());
}

TEST_F(RepeatLocalizerTest, TrackingOffDetectsEveryFrame) {
  RepeatOptions options;
  options.max_tracked_frames = 0;
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk());
  localizer->setTrackedKeyframe(1);
  for (int step = 0; step < 3; ++step) {
    const double s = 0.31 + 0.01 * step;
    const auto estimate = localizer->localize(wall_->imageAt(PlanarPose(0.08 * s + 0.06, s, 0.04 * s + 0.035)));
    ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
    EXPECT_FALSE(estimate->tracked);
    EXPECT_FALSE(localizer->lastTiming().tracked);
    EXPECT_GT(localizer->lastTiming().extraction_ms, 0.0);
  }
  RepeatOptions bad;
  bad.max_tracked_frames = -1;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
  bad = RepeatOptions();
  bad.tracking_tolerance_px = 0.0;
  EXPECT_THROW(bad.validate(), std::invalid_argument);
}

// The caller's check (the odometry gate) vets each reference's pose inside the localizer: a pose
// refused from the tracked keyframe lets its neighbour try; a tracked frame whose pose is refused
// is detected afresh; when every pose is refused, the failure names the check's reason.
TEST_F(RepeatLocalizerTest, ARefusedPoseLetsTheNeighbourTry) {
  RepeatOptions options;
  options.max_degraded_frames = 0;  // no temporary reference: only keyframes
  auto localizer = RepeatLocalizer::create(route(), options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  localizer->setTrackedKeyframe(1);
  const PlanarPose camera_pose(0.085, 0.31, 0.047);
  std::vector<int> asked;
  const RepeatLocalizer::PoseCheck refuse_keyframe_1 = [&](const RepeatEstimate& estimate) {
    asked.push_back(estimate.keyframe);
    return estimate.keyframe == 1 ? Status(StatusCode::kNoConsensus, "refused by the test") : Status::ok();
  };
  const auto estimate = localizer->localize(wall_->imageAt(camera_pose), std::nullopt, refuse_keyframe_1);
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_NE(estimate->keyframe, 1);
  ASSERT_GE(asked.size(), 2U);
  EXPECT_EQ(asked.front(), 1);
  const Pose2D truth = basePose(camera_pose);
  EXPECT_NEAR(estimate->base_pose.x, truth.x, 0.01);
  EXPECT_NEAR(estimate->base_pose.y, truth.y, 0.01);

  // The next frame would be tracked against that keyframe; refusing it makes a detection.
  const int used = estimate->keyframe;
  const RepeatLocalizer::PoseCheck refuse_tracked = [&](const RepeatEstimate& candidate) {
    return candidate.tracked || candidate.keyframe == used ? Status(StatusCode::kNoConsensus, "refused by the test")
                                                            : Status::ok();
  };
  const auto next = localizer->localize(wall_->imageAt(PlanarPose(0.085, 0.32, 0.047)), std::nullopt, refuse_tracked);
  ASSERT_TRUE(next.isOk()) << next.status().toString();
  EXPECT_FALSE(next->tracked);
  EXPECT_NE(next->keyframe, used);

  // Every pose refused: the first one (the tracked keyframe's) comes back, for the caller to judge.
  const int tracked = localizer->trackedKeyframe();
  const RepeatLocalizer::PoseCheck refuse_all = [](const RepeatEstimate& candidate) {
    return candidate.tracked ? Status::ok() : Status(StatusCode::kNoConsensus, "refused by the test");
  };
  localizer->setTrackedKeyframe(tracked);  // forget the tracked points: detect
  const auto first = localizer->localize(wall_->imageAt(PlanarPose(0.085, 0.33, 0.047)), std::nullopt, refuse_all);
  ASSERT_TRUE(first.isOk()) << first.status().toString();
  EXPECT_EQ(first->keyframe, tracked);
}

// plane_sigma_from_neighbours: the synthetic route's keyframes all see the same wall, so each
// plane agrees with its neighbours' carried into its frame, and the covariance grows only by what
// the neighbours' fixes show (docs/math.md §3.10: the teach run's planes about 1 % off, 1.8 times
// the pixels' alone here); a route whose keyframe 1 plane is turned by 0.2 rad says so in that
// keyframe's covariance (the plane's term: its neighbours disagree).
TEST_F(RepeatLocalizerTest, PlaneUncertaintyFromTheNeighbours) {
  const PlanarPose camera_pose(0.085, 0.31, 0.047);
  RepeatOptions plain;
  plain.neighbour_search = 0;
  plain.plane_sigma_from_neighbours = false;
  plain.pose.common_shift_sigma_px = 0.0;  // the pixel noise alone: no model covariance
  RepeatOptions measured = plain;
  measured.plane_sigma_from_neighbours = true;
  auto reference = RepeatLocalizer::create(route(), plain);
  auto consistent = RepeatLocalizer::create(route(), measured);
  ASSERT_TRUE(reference.isOk() && consistent.isOk());
  reference->setTrackedKeyframe(1);
  consistent->setTrackedKeyframe(1);
  const auto a = reference->localize(wall_->imageAt(camera_pose));
  const auto b = consistent->localize(wall_->imageAt(camera_pose));
  ASSERT_TRUE(a.isOk() && b.isOk());
  EXPECT_NEAR(b->base_pose.x, a->base_pose.x, 1e-9);  // the pose does not change
  EXPECT_LT(b->covariance.trace(), 2.5 * a->covariance.trace());

  Route tilted = route();
  ScenePlane& plane = *tilted.keyframes[1].plane;
  const double c = std::cos(0.2), s = std::sin(0.2);
  plane.normal = Eigen::Vector3d(c * plane.normal.x() - s * plane.normal.z(), 0.0,
                                 s * plane.normal.x() + c * plane.normal.z()).normalized();
  auto disagreeing = RepeatLocalizer::create(tilted, measured);
  ASSERT_TRUE(disagreeing.isOk());
  disagreeing->setTrackedKeyframe(1);
  const auto d = disagreeing->localize(wall_->imageAt(camera_pose));
  ASSERT_TRUE(d.isOk()) << d.status().toString();
  EXPECT_GT(d->covariance.trace(), 4.0 * a->covariance.trace());
  // That growth is the estimate's model covariance (route frame), the part every fix against the
  // keyframe shares (docs/math.md §7.1); without a plane error there is none.
  EXPECT_EQ(a->model_covariance, Eigen::Matrix3d::Zero());
  EXPECT_GT(d->model_covariance.trace(), 2.0 * a->covariance.trace());
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(d->covariance - d->model_covariance).eigenvalues().minCoeff(),
            -1e-12);
}

// Routes that learn: the wall was repainted after the teach run (another texture on the same
// plane), so no taught view matches. An experience of keyframe 2 (a view of the repainted wall near
// it, with its estimated pose and covariance) makes that place localizable again: the pose within
// 2 cm / 0.3°, from experience 1, with the experience's uncertainty in its covariance.
TEST_F(RepeatLocalizerTest, AnExperienceRecognizesARepaintedPlace) {
  test_support::SyntheticWall repainted;
  repainted.texture = test_support::makeTexture(640, 480, 77);
  const std::string copy = test_support::makeTemporaryDirectory("htr_experience_route");
  std::filesystem::copy(directory_, copy, std::filesystem::copy_options::recursive |
                                              std::filesystem::copy_options::overwrite_existing);
  auto learned = loadRoute(copy);
  ASSERT_TRUE(learned.isOk()) << learned.status().toString();
  const PlanarPose keyframe_camera = rep103ToCameraAxes(learned->keyframes[2].pose);
  const PlanarPose current(keyframe_camera.x + 0.04, keyframe_camera.z + 0.05, keyframe_camera.theta + 0.02);
  {
    RepeatOptions options;
    auto localizer = RepeatLocalizer::create(*learned, options);
    ASSERT_TRUE(localizer.isOk());
    localizer->setTrackedKeyframe(2);
    EXPECT_FALSE(localizer->localize(repainted.imageAt(current)).isOk());  // the taught views fail
  }
  // The experience: the repainted wall from 3 cm beside keyframe 2, with a 1 cm / 0.2° uncertainty.
  const PlanarPose experience_camera(keyframe_camera.x - 0.03, keyframe_camera.z, keyframe_camera.theta - 0.01);
  const cv::Mat experience_image = repainted.imageAt(experience_camera);
  FeatureExtractor extractor(FeatureOptions{learned->info.feature_type, 1500});
  const auto features = extractor.extract(experience_image);
  ASSERT_TRUE(features.isOk());
  const Eigen::Matrix3d learned_covariance = Eigen::Vector3d(1e-4, 1e-4, std::pow(0.2 * M_PI / 180.0, 2)).asDiagonal();
  ASSERT_TRUE(addExperience(*learned, 2, experience_image, *features, basePose(experience_camera), learned_covariance, 50.0)
                  .isOk());
  const auto reloaded = loadRoute(copy);
  ASSERT_TRUE(reloaded.isOk()) << reloaded.status().toString();
  ASSERT_EQ(reloaded->keyframes[2].experiences.size(), 1u);
  RepeatOptions options;
  auto localizer = RepeatLocalizer::create(*reloaded, options);
  ASSERT_TRUE(localizer.isOk()) << localizer.status().toString();
  EXPECT_EQ(localizer->experienceCount(), 1);
  localizer->setTrackedKeyframe(2);
  const auto estimate = localizer->localize(repainted.imageAt(current));
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_EQ(estimate->keyframe, 2);
  EXPECT_EQ(estimate->experience, 1);
  const Pose2D truth = basePose(current);
  EXPECT_NEAR(estimate->base_pose.x, truth.x, 0.02);
  EXPECT_NEAR(estimate->base_pose.y, truth.y, 0.02);
  EXPECT_NEAR(wrapToPi(estimate->base_pose.yaw - truth.yaw), 0.0, 0.3 * M_PI / 180.0);
  EXPECT_GE(estimate->covariance(0, 0) + estimate->covariance(1, 1), 2e-4);  // the experience's part
  // Without experiences (use_experiences false) the place stays unrecognized.
  options.use_experiences = false;
  auto blind = RepeatLocalizer::create(*reloaded, options);
  ASSERT_TRUE(blind.isOk());
  blind->setTrackedKeyframe(2);
  EXPECT_FALSE(blind->localize(repainted.imageAt(current)).isOk());
  std::filesystem::remove_all(copy);
}
