#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "homography_teach_repeat/sim/differential_drive.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/sim/waypoint_driver.h"
#include "homography_teach_repeat/sim/world_renderer.h"
#include "homography_teach_repeat/teach_repeat/keyframe_store.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;
using test_support::syntheticCalibration;

// Each keyframe keeps only the features on its own plane (docs/nodes/repeat_node.md, "Wrong-wall
// protection"): a route taught diagonally towards a corner of the simulated room sees two walls in
// every image, and a feature of the other wall near the corner moves almost as the keyframe's
// plane predicts to the nearest keyframe. Checked against the rendered world: the depth at which
// the keyframe's plane puts each kept feature against the true depth of what its ray hits.
TEST(KeyframeStore, KeepsOnlyTheFeaturesOnTheKeyframesPlane) {
  const auto world = loadPlanarWorld(std::string(HTR_TEST_DATA_DIR) + "/worlds/small_room.yaml");
  if (!world) GTEST_SKIP() << "world textures unavailable (opencv-doc): " << world.status().toString();
  const std::string directory =
      (std::filesystem::temp_directory_path() / ("htr_keyframe_store_test_" + std::to_string(::getpid()))).string();

  RenderOptions render;
  render.camera_height = 0.6;
  render.noise_sigma = 2.0;
  render.blur_sigma = 0.5;
  const PinholeCamera camera(syntheticCalibration());
  const WorldRenderer renderer(camera, render);
  const Pose2D mount(0.2, 0.0, 0.0);
  TeachOptions options;
  options.route_directory = directory;
  options.overwrite = true;
  options.features.type = FeatureType::kAkaze;
  options.features.max_features = 1500;
  options.keyframes.distance = 0.25;
  options.planes_from_odometry = true;
  auto session = TeachSession::start(options, syntheticCalibration(), mount);
  ASSERT_TRUE(session.isOk()) << session.status().toString();
  // From the room's south-east towards its north-west corner, seeing the north and the west wall.
  const Pose2D start(2.6, 0.6, 2.4);
  DifferentialDriveSim robot(start, OdometryErrorModel(), DriveLimits());
  WaypointDriver driver({Eigen::Vector2d(1.4, 1.6)}, WaypointDriverOptions());
  std::vector<Pose2D> cameras;  // the true camera pose of each keyframe
  cv::RNG rng(1);
  const Status driven = driveWaypoints(driver, robot, 0.01, 0.1, 100.0, [&](const DifferentialDriveSim& sim, double t) {
    const Pose2D camera_pose = sim.truth().compose(mount);
    const auto stored = session->offer(renderer.render(*world, camera_pose, 1.0, rng), sim.odometry(), t);
    if (!stored) return stored.status();
    if (*stored) cameras.push_back(camera_pose);
    return Status::ok();
  });
  ASSERT_TRUE(driven.isOk()) << driven.toString();
  ASSERT_TRUE(session->finish().isOk());
  auto route = loadRoute(directory);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  ASSERT_EQ(route->keyframes.size(), cameras.size());
  ASSERT_GE(cameras.size(), 4u);

  RepeatOptions repeat;
  repeat.mode = RepeatMode::kFastHd;
  const auto store = KeyframeStore::load(*route, repeat);
  ASSERT_TRUE(store.isOk()) << store.status().toString();
  int kept = 0, off_plane = 0;
  for (int k = 0; k < store->size(); ++k) {
    const KeyframeReference& reference = store->at(k);
    ASSERT_TRUE(reference.plane.has_value());
    const Pose2D& c = cameras[static_cast<std::size_t>(k)];
    int keyframe_off = 0;
    for (const cv::KeyPoint& keypoint : reference.features.keypoints) {
      const Eigen::Vector3d ray((keypoint.pt.x - camera.cx()) / camera.fx(), (keypoint.pt.y - camera.cy()) / camera.fy(), 1.0);
      const double plane_depth = reference.plane->distance / reference.plane->normal.dot(ray);
      // The camera looks along its x axis in the world; image x grows to its right.
      const double bearing = std::atan2(-ray.x(), 1.0);
      const auto hit = castRay(*world, Eigen::Vector2d(c.x, c.y),
                               Eigen::Vector2d(std::cos(c.yaw + bearing), std::sin(c.yaw + bearing)), 1e-9);
      if (!hit) continue;
      const double true_depth = hit->range * std::cos(bearing);
      ++kept;
      if (std::abs(plane_depth / true_depth - 1.0) > 0.05) {
        ++keyframe_off;
      }
    }
    off_plane += keyframe_off;
    std::printf("keyframe %d: %zu features kept, %d of them off its plane\n", k, reference.features.keypoints.size(),
                keyframe_off);
  }
  ASSERT_GT(kept, 0);
  // Kept when they matched the plane at the nearest neighbour only: 98 of 2554 off the plane (3.8 %);
  // at every neighbour that matched them (up to three either side): 97 of 3925 (2.5 %). What
  // remains lies on the other wall within ~60 px of the corner, near the focus of expansion of the
  // motion towards it, where no neighbour shows the difference (docs/nodes/repeat_node.md).
  EXPECT_LT(off_plane, 0.03 * kept) << off_plane << " of " << kept << " kept features are not on their keyframe's plane";
  EXPECT_GT(kept, 3000);
  std::filesystem::remove_all(directory);
}
