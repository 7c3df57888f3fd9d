#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <utility>

#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/trifocal/trifocal_localizer.h"
#include "homography_teach_repeat/sim/world_renderer.h"

using namespace homography_teach_repeat;

namespace {

PinholeCamera camera() {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 400.0;
  c.cx = 319.5;
  c.cy = 239.5;
  return PinholeCamera(c);
}

// The room and one renderer for every test: the renderer prefilters each texture once (its ripmap
// cache), which under the sanitizers took ~10 s per renderer.
class TrifocalLocalizerTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    auto world = loadPlanarWorld(std::string(HTR_TEST_DATA_DIR) + "/worlds/small_room.yaml");
    if (world) world_ = std::make_unique<PlanarWorld>(std::move(*world));
    load_status_ = world.status().toString();
  }
  static void TearDownTestSuite() {
    renderer_.reset();
    world_.reset();
  }
  void SetUp() override {
    if (!world_) GTEST_SKIP() << "world textures unavailable (opencv-doc): " << load_status_;
  }
  // A view of the robot at `truth` (camera at base_link), with odometry `odometry`.
  TrifocalView view(TrifocalLocalizer& localizer, const Pose2D& truth, const Pose2D& odometry) {
    if (!renderer_) renderer_ = std::make_unique<WorldRenderer>(camera(), RenderOptions{});
    cv::RNG rng(1);
    const cv::Mat image = renderer_->render(*world_, truth, 1.0, rng);
    auto features = localizer.extract(image);
    EXPECT_TRUE(features.isOk()) << features.status().toString();
    return TrifocalView{*features, odometry};
  }
  inline static std::unique_ptr<PlanarWorld> world_;
  inline static std::unique_ptr<WorldRenderer> renderer_;
  inline static std::string load_status_;
};

}  // namespace

// A robot driving across the 3.5 x 3 m room, odometry 2 % long (the metric scale comes from it)
// and 0.02 rad per view off (vision corrects that): the poses within 3 cm / 0.8° of the truth,
// the landmarks on the walls.
TEST_F(TrifocalLocalizerTest, LocalizesThreeViewsOfTheSimulatedRoom) {
  TrifocalLocalizer localizer(camera(), CameraMount(0.0, 0.0, 0.0), TrifocalLocalizerOptions{});
  const Pose2D truth[3] = {Pose2D(0.8, 0.7, 0.7), Pose2D(1.2, 0.95, 0.62), Pose2D(1.6, 1.15, 0.5)};
  TrifocalView views[3];
  for (int k = 0; k < 3; ++k) {
    const Pose2D relative = truth[0].inverse().compose(truth[k]);
    const Pose2D odometry = truth[0].compose(Pose2D(1.02 * relative.x, 1.02 * relative.y, relative.yaw + 0.02 * k));
    views[k] = view(localizer, truth[k], odometry);
  }
  const auto result = localizer.localize(views[0], views[1], views[2]);
  ASSERT_TRUE(result.isOk()) << result.status().toString();
  EXPECT_GE(result->inliers, 30);
  for (int k = 1; k < 3; ++k) {
    EXPECT_NEAR(result->base_poses[k].x, truth[k].x, 0.03) << k;
    EXPECT_NEAR(result->base_poses[k].y, truth[k].y, 0.03) << k;
    EXPECT_NEAR(wrapToPi(result->base_poses[k].yaw - truth[k].yaw), 0.0, 0.8 * M_PI / 180.0) << k;
  }
  // Landmarks: on the walls (x = 0 or 3.5, y = 0 or 3), median distance under 8 cm (2-3 m away).
  ASSERT_GE(result->landmarks.size(), 20U);
  std::vector<double> distances;
  for (const auto& p : result->landmarks) {
    distances.push_back(std::min({std::abs(p.x()), std::abs(p.x() - 3.5), std::abs(p.y()), std::abs(p.y() - 3.0)}));
  }
  std::nth_element(distances.begin(), distances.begin() + static_cast<std::ptrdiff_t>(distances.size() / 2),
                   distances.end());
  EXPECT_LT(distances[distances.size() / 2], 0.08);
}

// Odometry that disagrees with what the images show (view 3 turned 0.3 rad more than the truth):
// the triplet is refused instead of published; with the default gate off (huge tolerances) the
// same views localize, and view 3's heading follows the images, not odometry (> 0.2 rad from it).
TEST_F(TrifocalLocalizerTest, RefusesATripletThatDisagreesWithItsOdometryPrior) {
  const Pose2D truth[3] = {Pose2D(0.8, 0.7, 0.7), Pose2D(1.2, 0.95, 0.62), Pose2D(1.6, 1.15, 0.5)};
  TrifocalLocalizerOptions options;
  TrifocalLocalizer localizer(camera(), CameraMount(0.0, 0.0, 0.0), options);
  TrifocalView views[3];
  for (int k = 0; k < 3; ++k) views[k] = view(localizer, truth[k], truth[k]);
  views[2].odometry.yaw += 0.3;
  const auto refused = localizer.localize(views[0], views[1], views[2]);
  ASSERT_FALSE(refused.isOk());
  EXPECT_EQ(refused.status().code(), StatusCode::kNoConsensus);
  EXPECT_NE(refused.status().message().find("odometry prior"), std::string::npos) << refused.status().toString();
  options.max_prior_heading_disagreement = M_PI;
  options.max_prior_disagreement_fraction = 100.0;
  const TrifocalLocalizer permissive(camera(), CameraMount(0.0, 0.0, 0.0), options);
  const auto accepted = permissive.localize(views[0], views[1], views[2]);
  ASSERT_TRUE(accepted.isOk()) << accepted.status().toString();
  EXPECT_GT(std::abs(wrapToPi(accepted->base_poses[2].yaw - views[2].odometry.yaw)), 0.2);
  options.max_prior_heading_disagreement = 0.0;
  EXPECT_THROW(TrifocalLocalizer(camera(), CameraMount(0.0, 0.0, 0.0), options), std::invalid_argument);
}

TEST_F(TrifocalLocalizerTest, BadInput) {
  TrifocalLocalizer localizer(camera(), CameraMount(0.0, 0.0, 0.0), TrifocalLocalizerOptions{});
  EXPECT_EQ(localizer.extract(cv::Mat()).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(localizer.extract(cv::Mat(100, 100, CV_8UC1, cv::Scalar(0))).status().code(), StatusCode::kInvalidInput);
  const Pose2D a(0.8, 0.7, 0.7), b(1.2, 0.95, 0.62), c(1.6, 1.15, 0.5);
  const TrifocalView first = view(localizer, a, a), second = view(localizer, b, b), third = view(localizer, c, c);
  // The robot did not move between two views: no baseline, no scale.
  TrifocalView still = second;
  still.odometry = a;
  EXPECT_EQ(localizer.localize(first, still, third).status().code(), StatusCode::kDegenerate);
  TrifocalView nan = third;
  nan.odometry.x = NAN;
  EXPECT_EQ(localizer.localize(first, second, nan).status().code(), StatusCode::kInvalidInput);
  // A view without texture: too few three-view matches.
  TrifocalView blank = third;
  blank.features = *localizer.extract(cv::Mat(480, 640, CV_8UC1, cv::Scalar(90)));
  const auto status = localizer.localize(first, second, blank).status().code();
  EXPECT_TRUE(status == StatusCode::kTooFewPoints || status == StatusCode::kNoConsensus) << static_cast<int>(status);
  TrifocalLocalizerOptions bad;
  bad.min_inliers = 3;
  EXPECT_THROW(TrifocalLocalizer(camera(), CameraMount(0.0, 0.0, 0.0), bad), std::invalid_argument);
}
