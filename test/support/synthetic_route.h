// A taught route over an exact synthetic scene for the core tests: a textured wall, images that
// are exact plane warps of it (docs/math.md §1.2), recorded through TeachSession.
#pragma once

#include <cmath>
#include <cstdlib>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"
#include "support/test_images.h"

namespace homography_teach_repeat {
namespace test_support {

inline CameraCalibration syntheticCalibration() {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = c.fy = 500.0;
  c.cx = 319.5;
  c.cy = 239.5;
  return c;
}

// A wall texture: blobs and corners for the point features, plus full-height vertical bands
// (door and window frames) for the vertical lines of the μ mode.
inline cv::Mat wallTexture() {
  cv::Mat texture = makeTexture(640, 480, 3);
  cv::RNG rng(11);
  for (int x = 20; x < 620; x += rng.uniform(35, 70)) {
    const int width = rng.uniform(6, 18);
    texture(cv::Rect(x, 30, width, 420)).setTo(cv::Scalar(rng.uniform(0, 2) == 0 ? 20 : 235));
  }
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0.6);
  return texture;
}

struct SyntheticWall {
  cv::Mat texture = wallTexture();
  ScenePlane plane{Eigen::Vector3d(std::sin(0.3), 0.0, std::cos(0.3)), 4.0};
  // The image of a camera at `camera_pose` (in the frame of the camera that sees the texture
  // fronto-... exactly as image 0).
  cv::Mat imageAt(const PlanarPose& camera_pose) const {
    return warp(texture, planeInducedHomography(PinholeCamera(syntheticCalibration()), camera_pose, plane));
  }
};

inline std::string makeTemporaryDirectory(const char* prefix) {
  std::string pattern = std::string("/tmp/") + prefix + "_XXXXXX";
  return std::string(::mkdtemp(pattern.data()));
}

// Teaches `steps` images 10 cm apart along a gently turning path (a keyframe every 0.25 m), with
// the camera mounted at the base origin, into `directory` (a new temporary one when empty);
// returns the route directory. Throws std::runtime_error on any failure.
inline std::string teachSyntheticRoute(const SyntheticWall& wall, FeatureType type, int steps = 16,
                                       std::string directory = "") {
  TeachOptions options;
  options.route_directory = directory.empty() ? makeTemporaryDirectory("htr_synthetic_route") : directory;
  options.overwrite = true;
  options.features.type = type;
  options.keyframes.distance = 0.25;
  options.first_plane_distance = wall.plane.distance;
  options.planes_from_odometry = false;  // the paper's single plane with this scale
  auto session = TeachSession::start(options, syntheticCalibration(), Pose2D(0.0, 0.0, 0.0));
  if (!session) throw std::runtime_error(session.status().toString());
  for (int step = 0; step < steps; ++step) {
    const double s = 0.1 * step;
    const PlanarPose camera_pose(0.08 * s, s, 0.04 * s);
    const auto offered = session->offer(wall.imageAt(camera_pose), cameraAxesToRep103(camera_pose), 10.0 + step);
    if (!offered) throw std::runtime_error(offered.status().toString());
  }
  const auto report = session->finish();
  if (!report) throw std::runtime_error(report.status().toString());
  return options.route_directory;
}

}  // namespace test_support
}  // namespace homography_teach_repeat
