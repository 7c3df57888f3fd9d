// RepeatPipeline: a frame's whole path without ROS (repeat_node only converts and publishes), the
// μ loop (localizer -> filter -> prediction -> localizer) included.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <vector>

#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"
#include "support/synthetic_route_test.h"

using namespace homography_teach_repeat;

namespace {

class RepeatPipelineTest : public test_support::SyntheticRouteTest {
 protected:
  static PinholeCamera camera() { return PinholeCamera(test_support::syntheticCalibration()); }
  // The camera on the taught path at arc length s [m], `lateral` [m] to its right.
  static PlanarPose pathCamera(double s, double lateral = 0.0) { return PlanarPose(0.08 * s + lateral, s, 0.04 * s); }
  // 14 frames 0.1 m apart along the taught path with odometry whose heading drifts by 0.003 rad
  // per frame (0.03 rad/m); `on_frame(step, truth, odom, result)` sees each frame's outcome.
  template <typename OnFrame>
  static void driveWithBiasedOdometry(RepeatPipeline& pipeline, const OnFrame& on_frame) {
    constexpr double kHeadingBiasPerStep = 0.003;  // [rad] per 0.1 m
    Pose2D odom = cameraAxesToRep103(pathCamera(0.0));
    Pose2D previous_truth = odom;
    for (int step = 0; step < 14; ++step) {
      const double stamp = 200.0 + 0.1 * step;
      const PlanarPose camera_pose = pathCamera(0.1 * step);
      const Pose2D truth = cameraAxesToRep103(camera_pose);
      Pose2D increment = previous_truth.inverse().compose(truth);
      if (step > 0) increment.yaw += kHeadingBiasPerStep;
      odom = odom.compose(increment);
      previous_truth = truth;
      ASSERT_TRUE(pipeline.addOdometry(stamp, odom).isOk());
      on_frame(step, truth, odom, pipeline.processFrame(stamp, wall_->imageAt(camera_pose), camera()));
    }
  }
};

double yawError(const Pose2D& a, const Pose2D& b) { return std::abs(wrapToPi(a.yaw - b.yaw)); }

}  // namespace

// fast_hd: the visual pose with its covariance and the map -> odom alignment; a pose that
// disagrees with the odometry's motion is refused by the gate (counted, no pose).
TEST_F(RepeatPipelineTest, FastHdPosesPassTheOdometryGateUntilTheOdometryDisagrees) {
  auto pipeline = RepeatPipeline::create(route(), RepeatPipelineOptions());
  ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
  const Pose2D odom_origin(5.0, -2.0, 0.7);  // the odometry frame is anywhere
  for (int step = 0; step < 8; ++step) {
    const double stamp = 100.0 + 0.1 * step;
    const PlanarPose camera_pose = pathCamera(0.1 * step + 0.03, 0.04);
    const Pose2D truth = cameraAxesToRep103(camera_pose);
    ASSERT_TRUE(pipeline->addOdometry(stamp, odom_origin.compose(truth)).isOk());
    const RepeatFrameResult result = pipeline->processFrame(stamp, wall_->imageAt(camera_pose), camera());
    ASSERT_TRUE(result.status.isOk()) << step << ": " << result.status.toString();
    ASSERT_TRUE(result.pose && result.covariance && result.map_to_odom && result.timing);
    EXPECT_NEAR(result.pose->x, truth.x, 0.02);
    EXPECT_NEAR(result.pose->y, truth.y, 0.02);
    // map -> odom is the inverse of the odometry origin.
    EXPECT_NEAR(result.map_to_odom->compose(odom_origin).x, 0.0, 0.02);
    EXPECT_NEAR(wrapToPi(result.map_to_odom->compose(odom_origin).yaw), 0.0, 0.01);
  }
  // The odometry says the robot jumped 0.5 m sideways: the image says it did not.
  const PlanarPose camera_pose = pathCamera(0.83, 0.04);
  const Pose2D jumped = cameraAxesToRep103(camera_pose).compose(Pose2D(0.0, 0.5, 0.0));
  ASSERT_TRUE(pipeline->addOdometry(100.8, odom_origin.compose(jumped)).isOk());
  const RepeatFrameResult refused = pipeline->processFrame(100.8, wall_->imageAt(camera_pose), camera());
  EXPECT_EQ(refused.status.code(), StatusCode::kNoConsensus) << refused.status.toString();
  EXPECT_FALSE(refused.pose);
  EXPECT_FALSE(refused.estimate);
  EXPECT_EQ(pipeline->statistics().gated, 1u);
  EXPECT_EQ(pipeline->statistics().failures, 1u);
  EXPECT_EQ(pipeline->statistics().frames, 9u);
}

// fast_hd, frames without a pose (a covered camera): the tracked keyframe follows the odometry
// from the last accepted pose, and after search_all_after failures every keyframe is tried; a
// search that finds nothing leaves the tracking where it was.
TEST_F(RepeatPipelineTest, LostFramesFollowTheOdometryAndSearchTheWholeRoute) {
  RepeatPipelineOptions options;
  options.localization.neighbour_search = 0;
  options.search_all_after = 4;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
  const cv::Mat covered(480, 640, CV_8UC1, cv::Scalar(90));
  double stamp = 400.0;
  auto frame = [&](double s, bool seen) {
    stamp += 0.1;
    const PlanarPose camera_pose = pathCamera(s);
    EXPECT_TRUE(pipeline->addOdometry(stamp, cameraAxesToRep103(camera_pose)).isOk());
    return pipeline->processFrame(stamp, seen ? wall_->imageAt(camera_pose) : covered, camera());
  };
  ASSERT_TRUE(frame(0.0, true).pose);
  EXPECT_EQ(pipeline->localizer().trackedKeyframe(), 0);
  // Covered for 1 m: no pose, but the search moves along the route with the odometry.
  for (int i = 1; i <= 4; ++i) EXPECT_FALSE(frame(0.25 * i, false).pose);
  EXPECT_GE(pipeline->localizer().trackedKeyframe(), 3);
  EXPECT_EQ(pipeline->statistics().searches_all, 0u);
  const int followed = pipeline->localizer().trackedKeyframe();
  // After four failures in a row the next frame searches every keyframe; covered, it finds none
  // and leaves the tracking as it was.
  EXPECT_FALSE(frame(1.0, false).pose);
  EXPECT_EQ(pipeline->statistics().searches_all, 1u);
  EXPECT_EQ(pipeline->statistics().found_by_search_all, 0u);
  EXPECT_EQ(pipeline->localizer().trackedKeyframe(), followed);
  // Uncovered after eight failures: the second whole-route search finds the pose.
  for (int i = 0; i < 3; ++i) EXPECT_FALSE(frame(1.0, false).pose);
  const RepeatFrameResult back = frame(1.0, true);
  ASSERT_TRUE(back.pose) << back.status.toString();
  EXPECT_EQ(pipeline->statistics().searches_all, 2u);
  EXPECT_EQ(pipeline->statistics().found_by_search_all, 1u);
  EXPECT_EQ(pipeline->statistics().failures_in_a_row, 0u);
  const Pose2D truth = cameraAxesToRep103(pathCamera(1.0));
  EXPECT_NEAR(back.pose->x, truth.x, 0.02);
  EXPECT_NEAR(back.pose->y, truth.y, 0.02);
}

// Without following the odometry the search stays at the keyframe where the camera was covered.
TEST_F(RepeatPipelineTest, WithoutFollowingTheOdometryTheSearchStaysBehind) {
  RepeatPipelineOptions options;
  options.follow_odometry_distance = 0.0;
  options.search_all_after = 0;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk());
  const cv::Mat covered(480, 640, CV_8UC1, cv::Scalar(90));
  ASSERT_TRUE(pipeline->addOdometry(500.0, cameraAxesToRep103(pathCamera(0.0))).isOk());
  ASSERT_TRUE(pipeline->processFrame(500.0, wall_->imageAt(pathCamera(0.0)), camera()).pose);
  for (int i = 1; i <= 4; ++i) {
    ASSERT_TRUE(pipeline->addOdometry(500.0 + 0.1 * i, cameraAxesToRep103(pathCamera(0.25 * i))).isOk());
    EXPECT_FALSE(pipeline->processFrame(500.0 + 0.1 * i, covered, camera()).pose);
  }
  EXPECT_EQ(pipeline->localizer().trackedKeyframe(), 0);
  EXPECT_EQ(pipeline->statistics().searches_all, 0u);
}

// fast_hd: every search starts at the keyframe nearest where the odometry has carried the robot
// since the last pose (as hybrid's starts at the filter's prediction), not at the last pose's
// keyframe: a robot that moved 0.6 m between two frames is matched against the keyframe it is at.
TEST_F(RepeatPipelineTest, FastHdSearchStartsWhereTheOdometryHasCarriedTheRobot) {
  const Route taught = route();
  auto nearestKeyframe = [&](const Pose2D& pose) {
    int nearest = 0;
    for (int k = 1; k < static_cast<int>(taught.keyframes.size()); ++k) {
      const Pose2D& at = taught.keyframes[static_cast<std::size_t>(k)].pose;
      const Pose2D& best = taught.keyframes[static_cast<std::size_t>(nearest)].pose;
      if (std::hypot(at.x - pose.x, at.y - pose.y) < std::hypot(best.x - pose.x, best.y - pose.y)) nearest = k;
    }
    return nearest;
  };
  for (const double follow : {5.0, 0.0}) {
    RepeatPipelineOptions options;
    options.localization.neighbour_search = 0;  // only the keyframe the search starts at
    options.follow_odometry_distance = follow;
    auto pipeline = RepeatPipeline::create(taught, options);
    ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
    const Pose2D start = cameraAxesToRep103(pathCamera(0.0));
    ASSERT_TRUE(pipeline->addOdometry(600.0, start).isOk());
    const RepeatFrameResult first = pipeline->processFrame(600.0, wall_->imageAt(pathCamera(0.0)), camera());
    ASSERT_TRUE(first.estimate) << first.status.toString();
    EXPECT_EQ(first.estimate->keyframe, 0);
    const Pose2D moved = cameraAxesToRep103(pathCamera(0.6));
    const int ahead = nearestKeyframe(moved);
    ASSERT_GE(ahead, 2);  // keyframes 0.25-0.3 m apart
    ASSERT_TRUE(pipeline->addOdometry(600.1, moved).isOk());
    const RepeatFrameResult second = pipeline->processFrame(600.1, wall_->imageAt(pathCamera(0.6)), camera());
    ASSERT_TRUE(second.estimate) << follow << ": " << second.status.toString();
    // Without following the odometry (0: never) the search stays at keyframe 0, 0.6 m behind.
    EXPECT_EQ(second.estimate->keyframe, follow > 0.0 ? ahead : 0) << follow;
  }
}

// The μ loop: odometry with a heading bias of 0.03 rad/m, corrected frame by frame by μ through
// the keyframe wall's model; the filter's prediction guides the next frame's line matching and
// moves the tracked keyframe on. The published heading stays far closer to the truth than the
// odometry's.
TEST_F(RepeatPipelineTest, MuLoopCorrectsTheOdometryHeading) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kMu;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
  int fixes = 0, poses = 0;
  double odometry_error = 0.0, filter_error = 0.0;
  driveWithBiasedOdometry(*pipeline, [&](int step, const Pose2D& truth, const Pose2D& odom, const RepeatFrameResult& result) {
    if (result.estimate) ++fixes;
    if (!result.pose) return;
    ++poses;
    ASSERT_TRUE(result.covariance);
    EXPECT_GT(result.covariance->trace(), 0.0);
    odometry_error = yawError(odom, truth);  // the odometry frame starts aligned with the route's
    filter_error = yawError(*result.pose, truth);
    // Measured: at most 0.57° and 2.3 cm over the run (the odometry: 2.2° at the end).
    EXPECT_LT(filter_error, 0.8 * M_PI / 180.0) << step;
    EXPECT_LT(std::hypot(result.pose->x - truth.x, result.pose->y - truth.y), 0.04) << step;
  });
  EXPECT_GE(fixes, 10);
  EXPECT_GE(poses, 13);
  EXPECT_GT(odometry_error, 0.035);  // 0.039 rad: the bias the filter works against
  EXPECT_LT(filter_error, 0.3 * odometry_error);  // measured 0.008 rad
  EXPECT_GE(pipeline->localizer().trackedKeyframe(), 4);  // moved on from the filter's pose
}

// The same loop with the keyframe lines triangulated into landmarks when the route is loaded: the
// filter's fixes come from every line against its own depth instead of one μ.
TEST_F(RepeatPipelineTest, MuLoopWithLineLandmarksCorrectsTheOdometryHeading) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kMu;
  options.localization.mu_line_landmarks = true;
  // The test wall is dense with edges of similar grey (70-115 lines per keyframe): along a nearly
  // straight path a line's depth is its only unknown, and most lines fit several candidates in the
  // keyframes 0.25 m on; those are left out, 1-8 landmarks per keyframe remain.
  options.mu_filter.min_landmark_lines = 3;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
  int with_landmarks = 0;
  for (int k = 0; k < pipeline->localizer().keyframeCount(); ++k) {
    if (pipeline->localizer().reference(k).line_landmarks.size() >= 3) ++with_landmarks;
  }
  ASSERT_GE(with_landmarks, pipeline->localizer().keyframeCount() / 2);
  int landmark_fixes = 0;
  double odometry_error = 0.0, filter_error = 0.0;
  driveWithBiasedOdometry(*pipeline, [&](int step, const Pose2D& truth, const Pose2D& odom, const RepeatFrameResult& result) {
    if (result.estimate && result.estimate->line_landmark_fix) ++landmark_fixes;
    if (!result.pose) return;
    odometry_error = yawError(odom, truth);
    filter_error = yawError(*result.pose, truth);
    EXPECT_LT(filter_error, 0.8 * M_PI / 180.0) << step;
    EXPECT_LT(std::hypot(result.pose->x - truth.x, result.pose->y - truth.y), 0.04) << step;
  });
  EXPECT_GE(landmark_fixes, 10);
  EXPECT_GT(odometry_error, 0.035);
  EXPECT_LT(filter_error, 0.3 * odometry_error);
}

// μ mode, frames without a fix: the filter carries the pose on odometry alone (its covariance
// growing) while within max_unaided_distance; 0 means never.
TEST_F(RepeatPipelineTest, MuFramesWithoutAFixUseTheOdometryWithinTheDistanceAllowed) {
  for (const double allowed : {3.0, 0.0}) {
    RepeatPipelineOptions options;
    options.localization.mode = RepeatMode::kMu;
    options.max_unaided_distance = allowed;
    auto pipeline = RepeatPipeline::create(route(), options);
    ASSERT_TRUE(pipeline.isOk());
    std::optional<Eigen::Matrix3d> last_covariance;
    for (int step = 0; step < 3; ++step) {
      const double stamp = 300.0 + 0.1 * step;
      const PlanarPose camera_pose = pathCamera(0.1 * step);
      ASSERT_TRUE(pipeline->addOdometry(stamp, cameraAxesToRep103(camera_pose)).isOk());
      const auto result = pipeline->processFrame(stamp, wall_->imageAt(camera_pose), camera());
      if (result.covariance) last_covariance = result.covariance;
    }
    ASSERT_TRUE(last_covariance);
    // The camera sees a blank wall 0.2 m further on.
    const PlanarPose camera_pose = pathCamera(0.4);
    ASSERT_TRUE(pipeline->addOdometry(300.4, cameraAxesToRep103(camera_pose)).isOk());
    const auto blind = pipeline->processFrame(300.4, cv::Mat(480, 640, CV_8UC1, cv::Scalar(90)), camera());
    EXPECT_FALSE(blind.status.isOk());
    EXPECT_FALSE(blind.estimate);
    if (allowed > 0.0) {
      ASSERT_TRUE(blind.pose && blind.covariance) << blind.warning;
      EXPECT_NEAR(blind.pose->y, cameraAxesToRep103(camera_pose).y, 0.05);
      EXPECT_GT(blind.covariance->trace(), last_covariance->trace());
    } else {
      EXPECT_FALSE(blind.pose);
      EXPECT_NE(blind.warning.find("max_unaided_distance is 0"), std::string::npos) << blind.warning;
    }
  }
}

// μ needs the odometry at the image's stamp: without it the frame fails, saying so.
TEST_F(RepeatPipelineTest, MuWithoutOdometryFails) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kMu;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk());
  const auto result = pipeline->processFrame(1.0, wall_->imageAt(pathCamera(0.0)), camera());
  EXPECT_EQ(result.status.code(), StatusCode::kInvalidInput);
  EXPECT_NE(result.status.message().find("odometry"), std::string::npos) << result.status.toString();
  EXPECT_FALSE(result.pose);
}

// Bad input: a camera of another size, a failed conversion, a start keyframe off the route, bad
// options; each refused with a status, never a pose.
TEST_F(RepeatPipelineTest, BadInputIsRefusedWithAReason) {
  auto pipeline = RepeatPipeline::create(route(), RepeatPipelineOptions());
  ASSERT_TRUE(pipeline.isOk());
  CameraCalibration small = test_support::syntheticCalibration();
  small.width = 320;
  small.height = 240;
  const auto other_camera = pipeline->processFrame(1.0, wall_->imageAt(pathCamera(0.0)), PinholeCamera(small));
  EXPECT_EQ(other_camera.status.code(), StatusCode::kInvalidInput);
  EXPECT_NE(other_camera.status.message().find("taught at 640x480"), std::string::npos) << other_camera.status.toString();
  const auto no_image =
      pipeline->processFrame(1.1, Expected<cv::Mat>(Status(StatusCode::kInvalidInput, "encoding 'yuv' unsupported")), camera());
  EXPECT_EQ(no_image.status.message(), "encoding 'yuv' unsupported");
  EXPECT_FALSE(other_camera.pose || no_image.pose);
  EXPECT_EQ(pipeline->statistics().failures, 2u);

  RepeatPipelineOptions off_route;
  off_route.start_keyframe = 6;
  EXPECT_EQ(RepeatPipeline::create(route(), off_route).status().code(), StatusCode::kInvalidInput);
  RepeatPipelineOptions negative;
  negative.max_unaided_distance = -1.0;
  EXPECT_EQ(RepeatPipeline::create(route(), negative).status().code(), StatusCode::kInvalidInput);
}

// Started anywhere (start_keyframe -1): the first frame finds its keyframe among all.
TEST_F(RepeatPipelineTest, GlobalInitializationOnTheFirstFrame) {
  RepeatPipelineOptions options;
  options.start_keyframe = -1;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk());
  const PlanarPose camera_pose = pathCamera(1.0, 0.03);
  ASSERT_TRUE(pipeline->addOdometry(5.0, cameraAxesToRep103(camera_pose)).isOk());
  const auto result = pipeline->processFrame(5.0, wall_->imageAt(camera_pose), camera());
  ASSERT_TRUE(result.status.isOk()) << result.status.toString();
  EXPECT_GE(result.estimate->keyframe, 3);
  EXPECT_NEAR(result.pose->y, cameraAxesToRep103(camera_pose).y, 0.02);
}

// Reconfiguration keeps the tracked keyframe; options the route cannot support are refused and
// the old ones stay.
TEST_F(RepeatPipelineTest, ReconfigureKeepsTheTrackedKeyframe) {
  RepeatPipelineOptions options;
  options.start_keyframe = 3;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk());
  RepeatOptions mu = options.localization;
  mu.mode = RepeatMode::kMu;
  ASSERT_TRUE(pipeline->reconfigure(mu).isOk());
  EXPECT_EQ(pipeline->localizer().trackedKeyframe(), 3);
  EXPECT_EQ(pipeline->options().localization.mode, RepeatMode::kMu);
  RepeatOptions bad = mu;
  bad.min_inliers = 2;
  EXPECT_EQ(pipeline->reconfigure(bad).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(pipeline->options().localization.min_inliers, mu.min_inliers);
}

// hybrid with hybrid_fuse_both: one filter takes the Fast-HD pose of every frame (the synthetic
// route has a plane at every keyframe) and the μ fixes where the lines give them; the published
// pose is the filter's, its covariance no larger than a single Fast-HD pose's, and the heading
// stays far closer to the truth than the odometry's.
TEST_F(RepeatPipelineTest, HybridFusesFastHdAndMuInOneFilter) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kHybrid;
  options.hybrid_fuse_both = true;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
  EXPECT_TRUE(pipeline->hybridNotes().empty()) << pipeline->hybridNotes();
  ASSERT_NE(pipeline->lineLocalizer(), nullptr);
  int fast_hd_fixes = 0, mu_fixes = 0, ok = 0;
  double odometry_error = 0.0, filter_error = 0.0;
  driveWithBiasedOdometry(*pipeline, [&](int step, const Pose2D& truth, const Pose2D& odom, const RepeatFrameResult& result) {
    ASSERT_TRUE(result.pose && result.covariance) << step << ": " << result.status.toString() << " " << result.warning;
    if (result.fixes.find("fast_hd") != std::string::npos) ++fast_hd_fixes;
    if (result.fixes.find("mu") != std::string::npos) ++mu_fixes;
    if (result.integrity.level == IntegrityLevel::kOk) ++ok;
    if (result.estimate && result.estimate->has_pose && result.estimate->covariance_known) {
      // The filter's position variance: at most the measurement's (it adds the odometry's).
      const double filter_variance = result.covariance->topLeftCorner<2, 2>().trace();
      const double measured_variance = result.estimate->covariance.topLeftCorner<2, 2>().trace();
      EXPECT_LE(filter_variance, measured_variance * 1.0001) << step;
    }
    odometry_error = yawError(odom, truth);
    filter_error = yawError(*result.pose, truth);
    EXPECT_LT(std::hypot(result.pose->x - truth.x, result.pose->y - truth.y), 0.02) << step;
    EXPECT_LT(filter_error, 0.5 * M_PI / 180.0) << step;
  });
  EXPECT_GE(fast_hd_fixes, 12);
  EXPECT_GE(mu_fixes, 1);
  EXPECT_GE(ok, 12);
  EXPECT_GT(odometry_error, 0.035);
  EXPECT_LT(filter_error, 0.2 * odometry_error);
}

// hybrid: a tracked fix (the previous frame's matches followed by optical flow) carries that
// frame's matching errors on: it is not a new measurement of them, so the filter claims no less
// than the tracked fix itself does (docs/math.md §7.1).
TEST_F(RepeatPipelineTest, HybridClaimsNoLessThanATrackedFix) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kHybrid;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
  int tracked = 0, detected = 0;
  driveWithBiasedOdometry(*pipeline, [&](int step, const Pose2D&, const Pose2D&, const RepeatFrameResult& result) {
    ASSERT_TRUE(result.pose && result.covariance) << step << ": " << result.status.toString();
    if (!result.estimate || !result.estimate->has_pose || result.fixes.find("fast_hd") == std::string::npos) return;
    const Eigen::Matrix3d lacking = result.estimate->covariance - *result.covariance;
    const double largest = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(lacking).eigenvalues().maxCoeff();
    const double scale = result.estimate->covariance.diagonal().maxCoeff();
    if (result.estimate->tracked) {
      ++tracked;
      EXPECT_LE(largest, 1e-9 * scale) << step;  // P ⪰ R
    } else {
      ++detected;
    }
  });
  EXPECT_GE(tracked, 3);
  EXPECT_GE(detected, 3);
}

// hybrid by default (hybrid_fuse_both false): a μ fix only in a frame without a Fast-HD pose; beside
// a pose it is measured through the same plane, and the filter would take its error as independent.
TEST_F(RepeatPipelineTest, HybridTakesMuOnlyWhereThereIsNoPose) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kHybrid;
  ASSERT_FALSE(options.hybrid_fuse_both);
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
  int fast_hd_fixes = 0;
  driveWithBiasedOdometry(*pipeline, [&](int step, const Pose2D&, const Pose2D&, const RepeatFrameResult& result) {
    if (result.fixes.find("fast_hd") == std::string::npos) return;
    ++fast_hd_fixes;
    EXPECT_EQ(result.fixes.find("mu"), std::string::npos) << step << ": " << result.fixes;
  });
  EXPECT_GE(fast_hd_fixes, 12);
}

// hybrid, the camera covered: the filter carries the pose on odometry (its covariance growing),
// the integrity turns DEGRADED when no fix came for degraded_time_without_fix and LOST (no pose)
// beyond max_unaided_distance; uncovered, the search finds the route again where the odometry
// says the robot now is, and the pose is OK again.
TEST_F(RepeatPipelineTest, HybridBridgesACoveredCameraAndRecovers) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kHybrid;
  options.localization.neighbour_search = 0;  // only the keyframe the filter's pose is at
  options.max_unaided_distance = 0.55;
  options.integrity.degraded_time_without_fix = 2.0;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
  const cv::Mat covered(480, 640, CV_8UC1, cv::Scalar(90));
  double stamp = 600.0;
  auto frame = [&](double s, bool seen) {
    stamp += 0.5;  // a slow robot: 0.2 m/s
    const PlanarPose camera_pose = pathCamera(s);
    EXPECT_TRUE(pipeline->addOdometry(stamp, cameraAxesToRep103(camera_pose)).isOk());
    return pipeline->processFrame(stamp, seen ? wall_->imageAt(camera_pose) : covered, camera());
  };
  const RepeatFrameResult first = frame(0.0, true);
  ASSERT_TRUE(first.pose && first.covariance) << first.status.toString();
  EXPECT_EQ(first.integrity.level, IntegrityLevel::kOk) << first.integrity.reason;
  Eigen::Matrix3d previous = *first.covariance;
  std::vector<IntegrityLevel> levels;
  for (int i = 1; i <= 6; ++i) {
    const RepeatFrameResult blind = frame(0.1 * i, false);
    EXPECT_FALSE(blind.status.isOk());
    EXPECT_TRUE(blind.fixes.empty());
    levels.push_back(blind.integrity.level);
    if (0.1 * i <= 0.55) {
      ASSERT_TRUE(blind.pose && blind.covariance) << i << ": " << blind.warning;
      EXPECT_NEAR(blind.pose->y, cameraAxesToRep103(pathCamera(0.1 * i)).y, 0.01);  // exact odometry here
      EXPECT_GT(blind.covariance->trace(), previous.trace());
      previous = *blind.covariance;
    } else {
      EXPECT_FALSE(blind.pose);
      EXPECT_EQ(blind.integrity.level, IntegrityLevel::kLost);
      EXPECT_NE(blind.integrity.reason.find("no pose"), std::string::npos) << blind.integrity.reason;
    }
  }
  // 0.5 s, 1.0 s: OK; from 2.5 s without a fix: DEGRADED; beyond max_unaided_distance: LOST.
  EXPECT_EQ(levels[0], IntegrityLevel::kOk);
  EXPECT_EQ(levels[4], IntegrityLevel::kDegraded);
  EXPECT_EQ(levels[5], IntegrityLevel::kLost);
  // Uncovered 0.8 m on: the filter's pose (carried by the odometry beyond the distance allowed)
  // moved the search to the keyframe there.
  const RepeatFrameResult back = frame(0.8, true);
  ASSERT_TRUE(back.pose) << back.status.toString();
  EXPECT_EQ(back.fixes.substr(0, 7), "fast_hd");
  EXPECT_NEAR(back.pose->y, cameraAxesToRep103(pathCamera(0.8)).y, 0.02);
  EXPECT_EQ(back.integrity.level, IntegrityLevel::kOk) << back.integrity.reason;
}

// hybrid, a camera that sees nothing it knows at 30 Hz: after a Fast-HD search without a pose the
// next one waits fast_hd_retry_period (the filter carries the pose meanwhile); with 0 every frame
// searches. Seen again, the robot is found within the period.
TEST_F(RepeatPipelineTest, HybridRetriesAFailedSearchAfterItsPeriod) {
  const cv::Mat covered(480, 640, CV_8UC1, cv::Scalar(90));
  for (const double period : {0.25, 0.0}) {
    SCOPED_TRACE(period);
    RepeatPipelineOptions options;
    options.localization.mode = RepeatMode::kHybrid;
    options.search_all_after = 0;
    options.fast_hd_retry_period = period;
    auto pipeline = RepeatPipeline::create(route(), options);
    ASSERT_TRUE(pipeline.isOk()) << pipeline.status().toString();
    double stamp = 800.0;
    double s = 0.0;
    auto frame = [&](bool seen) {
      stamp += 1.0 / 30.0;
      s += 0.01;
      const PlanarPose camera_pose = pathCamera(s);
      EXPECT_TRUE(pipeline->addOdometry(stamp, cameraAxesToRep103(camera_pose)).isOk());
      return pipeline->processFrame(stamp, seen ? wall_->imageAt(camera_pose) : covered, camera());
    };
    ASSERT_EQ(frame(true).fixes.substr(0, 7), "fast_hd");
    int searched = 0;
    for (int i = 0; i < 15; ++i) {  // 0.5 s
      const RepeatFrameResult blind = frame(false);
      EXPECT_TRUE(blind.fixes.empty());
      ASSERT_TRUE(blind.pose) << "the filter carries the pose";
      if (blind.timing) {
        ++searched;
      } else {
        EXPECT_NE(blind.status.message().find("fast_hd_retry_period"), std::string::npos) << blind.status.toString();
      }
    }
    if (period > 0.0) {
      EXPECT_EQ(searched, 2) << "frames 1 and 9 (0.27 s later)";
    } else {
      EXPECT_EQ(searched, 15);
    }
    int frames_to_fix = 1;
    while (frame(true).fixes.substr(0, 7) != "fast_hd" && frames_to_fix < 30) ++frames_to_fix;
    EXPECT_LE(frames_to_fix, 8) << "found again within the period (0.25 s: 8 frames)";
  }
}

// hybrid, the odometry jumps 0.5 m (a kidnapped robot, seen from the other side): the Fast-HD
// poses are refused by the odometry gate and the integrity says DEGRADED at once; when
// gate_switch_after refused poses agree with each other the filter starts again from them.
TEST_F(RepeatPipelineTest, HybridAfterAKidnappingIsDegradedUntilVisionTakesOver) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kHybrid;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk());
  double stamp = 700.0;
  for (int step = 0; step < 4; ++step) {
    stamp += 0.1;
    const PlanarPose camera_pose = pathCamera(0.1 * step);
    ASSERT_TRUE(pipeline->addOdometry(stamp, cameraAxesToRep103(camera_pose)).isOk());
    const auto result = pipeline->processFrame(stamp, wall_->imageAt(camera_pose), camera());
    ASSERT_TRUE(result.pose);
    EXPECT_EQ(result.integrity.level, IntegrityLevel::kOk) << result.integrity.reason;
  }
  const Pose2D jump(0.0, 0.5, 0.0);
  int degraded = 0, step = 4;
  RepeatFrameResult result;
  for (; step < 14; ++step) {
    stamp += 0.1;
    const PlanarPose camera_pose = pathCamera(0.1 * step);
    ASSERT_TRUE(pipeline->addOdometry(stamp, cameraAxesToRep103(camera_pose).compose(jump)).isOk());
    result = pipeline->processFrame(stamp, wall_->imageAt(camera_pose), camera());
    ASSERT_TRUE(result.pose);
    const Pose2D truth = cameraAxesToRep103(camera_pose);
    const double error = std::hypot(result.pose->x - truth.x, result.pose->y - truth.y);
    if (error < 0.03) break;  // the filter started again from vision
    EXPECT_NE(result.integrity.level, IntegrityLevel::kOk) << step << ": " << error << " m off";
    ++degraded;
  }
  EXPECT_LT(step, 14) << "vision never took over";
  // gate_switch_after 5: the fifth refused pose is the new reference.
  EXPECT_GE(degraded, 3);
  EXPECT_LE(degraded, 5);
  EXPECT_EQ(result.fixes.substr(0, 7), "fast_hd");
}

// hybrid on a route without planes runs on μ alone and on a route without lines on Fast-HD alone,
// saying what is missing; a route with neither is refused.
TEST_F(RepeatPipelineTest, HybridRunsOnWhatTheRouteHas) {
  RepeatPipelineOptions options;
  options.localization.mode = RepeatMode::kHybrid;
  Route without_planes = route();
  for (auto& keyframe : without_planes.keyframes) keyframe.plane.reset();
  auto mu_only = RepeatPipeline::create(without_planes, options);
  ASSERT_TRUE(mu_only.isOk()) << mu_only.status().toString();
  EXPECT_NE(mu_only->hybridNotes().find("no planes"), std::string::npos) << mu_only->hybridNotes();
  EXPECT_EQ(mu_only->lineLocalizer(), nullptr);
  int mu_fixes = 0;
  driveWithBiasedOdometry(*mu_only, [&](int, const Pose2D&, const Pose2D&, const RepeatFrameResult& result) {
    if (result.fixes == "mu") ++mu_fixes;
    EXPECT_EQ(result.fixes.find("fast_hd"), std::string::npos);
  });
  EXPECT_GE(mu_fixes, 8);

  const std::string copy = test_support::makeTemporaryDirectory("htr_route_without_lines");
  std::filesystem::copy(directory_, copy, std::filesystem::copy_options::recursive | std::filesystem::copy_options::overwrite_existing);
  for (const auto& file : std::filesystem::recursive_directory_iterator(copy)) {
    if (file.path().string().find(".lines.yml") != std::string::npos) std::ofstream(file.path()) << "lines: []\n";
  }
  auto copied = loadRoute(copy);
  ASSERT_TRUE(copied.isOk()) << copied.status().toString();
  auto fast_hd_only = RepeatPipeline::create(*copied, options);
  ASSERT_TRUE(fast_hd_only.isOk()) << fast_hd_only.status().toString();
  EXPECT_NE(fast_hd_only->hybridNotes().find("no mu fixes"), std::string::npos) << fast_hd_only->hybridNotes();
  int pose_fixes = 0;
  driveWithBiasedOdometry(*fast_hd_only, [&](int, const Pose2D&, const Pose2D&, const RepeatFrameResult& result) {
    if (result.fixes == "fast_hd") ++pose_fixes;
  });
  EXPECT_GE(pose_fixes, 12);

  Route neither = *copied;
  for (auto& keyframe : neither.keyframes) keyframe.plane.reset();
  const auto refused = RepeatPipeline::create(neither, options);
  EXPECT_EQ(refused.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(refused.status().message().find("neither planes nor vertical lines"), std::string::npos)
      << refused.status().toString();
  std::filesystem::remove_all(copy);
}
