// What a level pinhole camera and a planar laser scanner see in a PlanarWorld.
//
// Camera: for each image column the horizontal ray through it is cast against the walls (the
// nearest hit in front of the camera wins: exact occlusion, nothing behind the camera is drawn);
// along that column the wall is a vertical line, and each pixel's height on the wall follows from
// the ray's depth, so every pixel samples the wall texture exactly where the plane-induced
// homography of that wall maps it (docs/math.md §1.2), bilinearly. Above and below the walls: ceiling
// and floor colours. Optional illumination gain, Gaussian pixel noise and blur.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/sim/planar_world.h"

namespace homography_teach_repeat {

struct RenderOptions {
  double camera_height = 0.5;  // [m] optical centre above the floor, > 0
  double noise_sigma = 0.0;    // [grey levels] Gaussian pixel noise, >= 0
  double blur_sigma = 0.0;     // [px] Gaussian blur (optics), >= 0

  void validate() const;  // throws std::invalid_argument naming the bad field
};

class WorldRenderer {
 public:
  // The camera must be an ideal pinhole (no distortion). Throws std::invalid_argument otherwise.
  WorldRenderer(const PinholeCamera& camera, const RenderOptions& options);

  // BGR8 image of a camera whose optical centre is at (camera_pose.x, camera_pose.y) with the
  // optical axis horizontal along camera_pose.yaw (world frame, REP-103). `gain` scales the
  // brightness (illumination), `rng` draws the pixel noise.
  cv::Mat render(const PlanarWorld& world, const Pose2D& camera_pose, double gain, cv::RNG& rng) const;

  const PinholeCamera& camera() const { return camera_; }

 private:
  PinholeCamera camera_;
  RenderOptions options_;
};

// Ranges of a planar scanner at `pose` (world frame): `count` beams from angle_min to angle_max
// (robot frame, CCW); beams that hit nothing within range_max get +inf (REP-117).
std::vector<float> castScan(const PlanarWorld& world, const Pose2D& pose, double angle_min,
                            double angle_max, int count, double range_max);

}  // namespace homography_teach_repeat
