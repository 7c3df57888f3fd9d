#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/fast_hd/plane_estimation.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;

namespace {
using test_support::makeTemporaryDirectory;
using test_support::SyntheticWall;
CameraCalibration calibration() { return test_support::syntheticCalibration(); }
}  // namespace

// Six keyframes along a gently turning path towards the wall; the planes estimated at the end
// agree with the truth propagated to every keyframe (docs/math.md §2.2).
TEST(TeachSession, StoresKeyframesAndEstimatesPlanes) {
  const std::string dir = makeTemporaryDirectory("htr_teach_test");
  TeachOptions options;
  options.route_directory = dir;
  options.features.type = FeatureType::kAkaze;
  options.keyframes.distance = 0.25;
  options.first_plane_distance = 4.0;
  auto session = TeachSession::start(options, calibration(), Pose2D(0.0, 0.0, 0.0));
  ASSERT_TRUE(session.isOk()) << session.status().toString();
  const SyntheticWall scene;
  std::vector<PlanarPose> camera_poses;
  int stored = 0;
  for (int step = 0; step <= 15; ++step) {
    const double s = 0.1 * step;  // 10 cm per image: every third image is a keyframe
    const PlanarPose camera_pose(0.08 * s, s, 0.04 * s);
    const Pose2D base = cameraAxesToRep103(camera_pose);  // mount at the base origin
    const auto offered = session->offer(scene.imageAt(camera_pose), base, 10.0 + step);
    ASSERT_TRUE(offered.isOk()) << offered.status().toString();
    if (*offered) {
      camera_poses.push_back(camera_pose);
      ++stored;
    }
  }
  EXPECT_EQ(stored, 6);
  const auto report = session->finish();
  ASSERT_TRUE(report.isOk()) << report.status().toString();
  for (const auto& m : report->messages) ADD_FAILURE() << m;
  EXPECT_EQ(report->planes, 6);
  const auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  ASSERT_EQ(route->keyframes.size(), 6u);
  for (std::size_t k = 0; k < camera_poses.size(); ++k) {
    const auto truth = transferPlane(scene.plane, camera_poses[k]);
    ASSERT_TRUE(truth.isOk());
    ASSERT_TRUE(route->keyframes[k].plane.has_value()) << k;
    const ScenePlane& p = *route->keyframes[k].plane;
    // The first normal comes from a 0.3 m baseline at 4 m: about a degree of error.
    EXPECT_LT(std::acos(std::min(1.0, p.normal.dot(truth->normal))), 2.0 * M_PI / 180.0) << k;
    EXPECT_NEAR(p.distance, truth->distance, 0.03 * truth->distance) << k;
  }
  std::filesystem::remove_all(dir);
}

TEST(TeachSession, BadInputAndTooFewKeyframes) {
  const std::string dir = makeTemporaryDirectory("htr_teach_test");
  TeachOptions options;
  options.route_directory = dir;
  options.first_plane_distance = 3.0;
  auto session = TeachSession::start(options, calibration(), Pose2D());
  ASSERT_TRUE(session.isOk());
  const SyntheticWall scene;
  EXPECT_EQ(session->offer(cv::Mat(), Pose2D(), 1.0).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(session->offer(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0)), Pose2D(), 1.0).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(session->offer(scene.imageAt(PlanarPose()), Pose2D(std::nan(""), 0, 0), 1.0)
                .status()
                .code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(session->offer(cv::Mat(480, 640, CV_32FC1, cv::Scalar(0)), Pose2D(), 1.0).status().code(),
            StatusCode::kInvalidInput);
  ASSERT_TRUE(*session->offer(scene.imageAt(PlanarPose()), Pose2D(), 1.0));
  EXPECT_EQ(session->finish().status().code(), StatusCode::kTooFewPoints);
  TeachOptions bad = options;
  bad.keyframes.angle = -1.0;
  EXPECT_EQ(TeachSession::start(bad, calibration(), Pose2D()).status().code(),
            StatusCode::kInvalidInput);
  std::filesystem::remove_all(dir);
}
