// The seasonal heading fix of the repeat: KeyframeShiftHeading against a route's stored keyframe
// images, and RepeatPipeline (hybrid and μ) taking it where a frame has no Fast-HD pose and no μ fix.
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <filesystem>

#include "homography_teach_repeat/teach_repeat/keyframe_shift_heading.h"
#include "homography_teach_repeat/teach_repeat/repeat_pipeline.h"
#include "support/synthetic_route_test.h"

using namespace homography_teach_repeat;

namespace {

constexpr double kDegree = M_PI / 180.0;

class KeyframeShiftHeadingTest : public test_support::SyntheticRouteTest {
 protected:
  static PinholeCamera camera() { return PinholeCamera(test_support::syntheticCalibration()); }
  // The camera on the taught path at arc length s [m], `lateral` [m] to its right, turned `turn`
  // [rad] from the path's heading (camera axes, docs/math.md §1.1).
  static PlanarPose pathCamera(double s, double turn = 0.0) { return PlanarPose(0.08 * s, s, 0.04 * s + turn); }

  // Hybrid with Fast-HD and μ unable to give a fix (their consensus thresholds out of reach): the
  // seasonal heading fix is all there is, as on a route revisited in another season.
  static RepeatPipelineOptions onlyShiftHeading() {
    RepeatPipelineOptions options;
    options.localization.mode = RepeatMode::kHybrid;
    options.localization.min_inliers = 100000;
    options.localization.heading.min_inliers = 100000;
    options.shift_heading_period = 0.0;
    return options;
  }

  // `frames` frames 0.1 m apart along the taught path, the odometry's heading drifting 0.003 rad
  // per frame; returns the last frame's heading errors [rad] of the odometry and of the pose, and
  // counts the frames whose fixes were `fix`.
  struct Drive {
    double odometry_error = 0.0, pose_error = 0.0;
    int fixes = 0, poses = 0;
  };
  static Drive driveWithBiasedOdometry(RepeatPipeline& pipeline, const std::string& fix, int frames = 14) {
    Drive drive;
    Pose2D odom = cameraAxesToRep103(pathCamera(0.0));
    Pose2D previous_truth = odom;
    for (int step = 0; step < frames; ++step) {
      const double stamp = 300.0 + 0.1 * step;
      const PlanarPose camera_pose = pathCamera(0.1 * step);
      const Pose2D truth = cameraAxesToRep103(camera_pose);
      Pose2D increment = previous_truth.inverse().compose(truth);
      if (step > 0) increment.yaw += 0.003;
      odom = odom.compose(increment);
      previous_truth = truth;
      EXPECT_TRUE(pipeline.addOdometry(stamp, odom).isOk());
      const RepeatFrameResult result = pipeline.processFrame(stamp, wall_->imageAt(camera_pose), camera());
      if (result.fixes == fix) ++drive.fixes;
      if (!result.pose) continue;
      ++drive.poses;
      drive.odometry_error = std::abs(wrapToPi(odom.yaw - truth.yaw));
      drive.pose_error = std::abs(wrapToPi(result.pose->yaw - truth.yaw));
      EXPECT_LT(std::hypot(result.pose->x - truth.x, result.pose->y - truth.y), 0.05) << step;
    }
    return drive;
  }
};

}  // namespace

// μ against a keyframe's stored image reads the camera's turn: atan(μ/f) is the yaw of the current
// camera relative to the keyframe's (REP-103, counter-clockwise positive), within 0.1°.
TEST_F(KeyframeShiftHeadingTest, MeasuresTheTurnFromTheKeyframe) {
  const Route r = route();
  KeyframeShiftHeading shift(r, camera());
  for (const double turn : {-3.0 * kDegree, 2.0 * kDegree}) {
    const auto current = shift.describe(wall_->imageAt(pathCamera(0.0, turn)));
    ASSERT_TRUE(current.isOk()) << current.status().toString();
    const auto fix = shift.measure(0, *current);
    ASSERT_TRUE(fix.isOk()) << fix.status().toString();
    const double relative_yaw =
        wrapToPi(cameraAxesToRep103(pathCamera(0.0, turn)).yaw - cameraAxesToRep103(pathCamera(0.0)).yaw);
    EXPECT_NEAR(std::atan(fix->mu / camera().fx()), relative_yaw, 0.1 * kDegree) << turn;
    EXPECT_FALSE(fix->ambiguous);
    EXPECT_GT(fix->variance, 0.0);
  }
  EXPECT_EQ(shift.cachedKeyframes(), 1);  // the keyframe described once
}

// The cache keeps the most recently used keyframes; a keyframe out of range, an image of another
// size and an unreadable keyframe image are errors naming what is wrong (the image is read again on
// the next call).
TEST_F(KeyframeShiftHeadingTest, CacheAndBadInput) {
  KeyframeShiftHeadingOptions options;
  options.cache_size = 2;
  const std::string copy = test_support::makeTemporaryDirectory("htr_shift_route");
  std::filesystem::copy(directory_, copy, std::filesystem::copy_options::recursive);
  auto r = loadRoute(copy);
  ASSERT_TRUE(r.isOk()) << r.status().toString();
  KeyframeShiftHeading shift(*r, camera(), options);
  const auto current = shift.describe(wall_->imageAt(pathCamera(0.25)));
  ASSERT_TRUE(current.isOk());
  for (const int k : {0, 1, 2}) EXPECT_TRUE(shift.measure(k, *current).isOk()) << k;
  EXPECT_EQ(shift.cachedKeyframes(), 2);

  EXPECT_EQ(shift.measure(99, *current).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(shift.describe(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0))).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(shift.describe(cv::Mat()).status().code(), StatusCode::kInvalidInput);
  // A covered lens: refused at once, naming why.
  const auto blank = shift.describe(cv::Mat(480, 640, CV_8UC1, cv::Scalar(90)));
  EXPECT_EQ(blank.status().code(), StatusCode::kTooFewPoints);
  EXPECT_NE(blank.status().message().find("no texture"), std::string::npos) << blank.status().message();

  const std::string image = copy + "/" + r->keyframes[3].image_file;
  std::filesystem::resize_file(image, 100);  // a copy cut short
  const auto broken = shift.measure(3, *current);
  ASSERT_FALSE(broken.isOk());
  EXPECT_EQ(broken.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(broken.status().message().find(r->keyframes[3].image_file), std::string::npos) << broken.status().message();
  std::filesystem::remove_all(copy);
}

// The filter modes (hybrid, μ) where neither Fast-HD nor μ gives a fix (another season): the
// seasonal heading fixes start the filter at the start keyframe and hold the heading that the
// odometry loses (0.003 rad per 0.1 m); the same after a switch at run time (dynamic_reconfigure)
// from fast_hd, which has no seasonal fix; without them there is no pose at all (nothing aligns the
// filter).
TEST_F(KeyframeShiftHeadingTest, TheFilterModesTakeTheShiftHeadingWhereNothingElseFixes) {
  for (const RepeatMode mode : {RepeatMode::kHybrid, RepeatMode::kMu}) {
    SCOPED_TRACE(mode == RepeatMode::kHybrid ? "hybrid" : "mu");
    RepeatPipelineOptions options = onlyShiftHeading();
    options.localization.mode = mode;
    auto with = RepeatPipeline::create(route(), options);
    ASSERT_TRUE(with.isOk()) << with.status().toString();
    const Drive fixed = driveWithBiasedOdometry(*with, "shift");
    EXPECT_GE(fixed.fixes, 12);
    EXPECT_EQ(with->statistics().shift_heading_fixes, static_cast<unsigned>(fixed.fixes));
    EXPECT_EQ(fixed.poses, 14);
    EXPECT_GT(fixed.odometry_error, 0.035);
    EXPECT_LT(fixed.pose_error, 0.3 * fixed.odometry_error);

    RepeatPipelineOptions fast_hd = options;
    fast_hd.localization.mode = RepeatMode::kFastHd;
    auto switched = RepeatPipeline::create(route(), fast_hd);
    ASSERT_TRUE(switched.isOk());
    ASSERT_TRUE(switched->reconfigure(options.localization).isOk());
    // (Shorter drives where the first frames decide: under the sanitizers a frame takes ~0.3 s.)
    EXPECT_GE(driveWithBiasedOdometry(*switched, "shift", 6).fixes, 5);

    options.shift_heading = false;
    auto without = RepeatPipeline::create(route(), options);
    ASSERT_TRUE(without.isOk());
    const Drive blind = driveWithBiasedOdometry(*without, "shift", 4);
    EXPECT_EQ(blind.fixes, 0);
    EXPECT_EQ(blind.poses, 0);
  }
}

// At most one attempt per shift_heading_period: the frames in between carry the pose on odometry
// and say why there was no fix.
TEST_F(KeyframeShiftHeadingTest, OneAttemptPerPeriod) {
  RepeatPipelineOptions options = onlyShiftHeading();
  options.shift_heading_period = 0.35;
  auto pipeline = RepeatPipeline::create(route(), options);
  ASSERT_TRUE(pipeline.isOk());
  const Drive drive = driveWithBiasedOdometry(*pipeline, "shift");
  EXPECT_EQ(drive.poses, 14);
  EXPECT_GE(drive.fixes, 3);  // frames 0, 4, 8, 12 at 0.1 s apart
  EXPECT_LE(drive.fixes, 4);

  options.shift_heading_period = -1.0;
  EXPECT_EQ(RepeatPipeline::create(route(), options).status().code(), StatusCode::kInvalidInput);
}

// The route audit's view of the seasonal fix: every keyframe's features and its vote against the
// next keyframe (the last against the previous); an unreadable keyframe image is named, not fatal.
TEST_F(KeyframeShiftHeadingTest, AuditCountsFeaturesAndTheVoteToTheNextKeyframe) {
  const Route r = route();
  const auto audits = auditShiftHeading(r, camera());
  ASSERT_EQ(audits.size(), r.keyframes.size());
  for (const ShiftHeadingAudit& a : audits) {
    EXPECT_TRUE(a.problem.empty()) << a.keyframe << ": " << a.problem;
    EXPECT_GT(a.features, 500) << a.keyframe;
    EXPECT_GT(a.support, 50) << a.keyframe;
  }
  EXPECT_EQ(audits.front().neighbour, 1);
  EXPECT_EQ(audits.back().neighbour, static_cast<int>(r.keyframes.size()) - 2);

  const std::string copy = test_support::makeTemporaryDirectory("htr_shift_audit");
  std::filesystem::copy(directory_, copy, std::filesystem::copy_options::recursive);
  auto broken = loadRoute(copy);
  ASSERT_TRUE(broken.isOk());
  std::filesystem::resize_file(copy + "/" + broken->keyframes[1].image_file, 100);
  const auto with_broken = auditShiftHeading(*broken, camera());
  ASSERT_EQ(with_broken.size(), r.keyframes.size());
  EXPECT_NE(with_broken[1].problem.find(broken->keyframes[1].image_file), std::string::npos) << with_broken[1].problem;
  EXPECT_EQ(with_broken[1].features, 0);
  EXPECT_FALSE(with_broken[0].problem.empty());  // its vote was against keyframe 1
  EXPECT_TRUE(with_broken[2].problem.empty()) << with_broken[2].problem;
  std::filesystem::remove_all(copy);
}

// A place whose taught view no longer matches (here: its image blanked) but that a repeat run
// learned again (an experience): the fix comes from the experience, relative to its pose.
TEST_F(KeyframeShiftHeadingTest, AnExperienceGivesTheFixWhereTheTaughtViewNoLongerMatches) {
  const std::string copy = test_support::makeTemporaryDirectory("htr_shift_experience");
  std::filesystem::copy(directory_, copy, std::filesystem::copy_options::recursive);
  auto r = loadRoute(copy);
  ASSERT_TRUE(r.isOk());
  cv::imwrite(copy + "/" + r->keyframes[0].image_file, cv::Mat(480, 640, CV_8UC1, cv::Scalar(128)));
  const PlanarPose learned_camera = pathCamera(0.0, 1.0 * kDegree);
  const cv::Mat learned_image = wall_->imageAt(learned_camera);
  FeatureOptions features;
  features.type = r->info.feature_type;
  const auto learned_features = FeatureExtractor(features).extract(learned_image);
  ASSERT_TRUE(learned_features.isOk());
  const Eigen::Matrix3d covariance = Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal();
  ASSERT_TRUE(addExperience(*r, 0, learned_image, *learned_features, cameraAxesToRep103(learned_camera), covariance, 50.0)
                  .isOk());

  KeyframeShiftHeading shift(*r, camera());
  const auto current = shift.describe(wall_->imageAt(pathCamera(0.0, 3.0 * kDegree)));
  ASSERT_TRUE(current.isOk());
  EXPECT_FALSE(shift.measure(0, *current).isOk());  // the blank taught view
  const auto view = shift.measureViews(0, *current);
  ASSERT_TRUE(view.isOk()) << view.status().toString();
  EXPECT_EQ(view->experience, r->keyframes[0].experiences.front().id);
  EXPECT_DOUBLE_EQ(view->view_yaw_variance, 1e-5);
  const double yaw = wrapToPi(view->view_pose.yaw + std::atan(view->fix.mu / camera().fx()));
  EXPECT_NEAR(wrapToPi(yaw - cameraAxesToRep103(pathCamera(0.0, 3.0 * kDegree)).yaw), 0.0, 0.1 * kDegree);
  EXPECT_EQ(shift.measureViews(99, *current).status().code(), StatusCode::kInvalidInput);
  std::filesystem::remove_all(copy);
}
