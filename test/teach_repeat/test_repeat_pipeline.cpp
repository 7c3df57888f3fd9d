// RepeatPipeline: a frame's whole path without ROS (repeat_node only converts and publishes), the
// μ loop (localizer -> filter -> prediction -> localizer) included.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
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
// growing) while within mu_max_unaided_distance; 0 means never.
TEST_F(RepeatPipelineTest, MuFramesWithoutAFixUseTheOdometryWithinTheDistanceAllowed) {
  for (const double allowed : {3.0, 0.0}) {
    RepeatPipelineOptions options;
    options.localization.mode = RepeatMode::kMu;
    options.mu_max_unaided_distance = allowed;
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
      EXPECT_NE(blind.warning.find("mu_max_unaided_distance is 0"), std::string::npos) << blind.warning;
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
  negative.mu_max_unaided_distance = -1.0;
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
