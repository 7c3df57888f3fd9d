// What a level pinhole camera and a planar laser scanner see in a PlanarWorld.
//
// Camera: for each image column the horizontal ray through it is cast against the walls (the
// nearest hit in front of the camera wins: exact occlusion, nothing behind the camera is drawn);
// along that column the wall is a vertical line, and each pixel's height on the wall follows from
// the ray's depth, so every pixel samples the wall texture exactly where the plane-induced
// homography of that wall maps it (docs/math.md §1.2), bilinearly. Above and below the walls: ceiling
// and floor colours. Optional illumination gain, Gaussian pixel noise and blur.
//
// The world as a real camera sees it (docs/simulator.md, "The world as a real camera sees it"): a lens with distortion
// (the camera's plumb_bob or other model: each pixel's ray is the undistorted one), a mount that is
// not level (pitch and roll of base_link, REP-103), lamps along the walls (a brightness that
// varies along each wall), and motion blur from the robot's turning during the exposure. Any of
// the first two switches from the per-column renderer to one ray per pixel (slower, same model).
// A pixel integrates the light over its area through a lens that blurs: with texture filtering or
// supersampling the image is band-limited as a real camera's; without either each pixel samples
// one point of the scene.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <memory>
#include <vector>

#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/sim/texture_ripmap.h"

namespace homography_teach_repeat {

struct RenderOptions {
  double camera_height = 0.5;  // [m] optical centre above the floor, > 0
  double noise_sigma = 0.0;    // [grey levels] Gaussian pixel noise, >= 0
  double blur_sigma = 0.0;     // [px] Gaussian blur (optics), >= 0
  double camera_pitch = 0.0;    // [rad] camera pitch about base_link's y (REP-103: + looks down), |.| <= 0.3
  double camera_roll = 0.0;     // [rad] camera roll about base_link's x (REP-103: + right side down), |.| <= 0.3
  double exposure_time = 0.0;  // [s] >= 0: the image is blurred along the rotation of this interval
  double lamp_contrast = 0.0;  // [0, 1): wall brightness 1 + c cos(2 pi s / lamp_spacing), s along the wall
  double lamp_spacing = 3.0;   // [m] > 0: distance between two lamps along a wall
  // How a pixel sees the scene (docs/simulator.md, "What a pixel sees"). The default (texture
  // filtering): each pixel samples the wall textures blurred to its footprint (the lens's
  // blur_sigma and the pixel's area, a Gaussian mapped onto the wall) from a ripmap of each
  // texture, and pixels where two surfaces meet are integrated over their area: a band-limited
  // image as a real camera's, about 3 times the cost of one sample. Off with supersampling 1: one
  // point of the scene per pixel (fastest; a wall with more detail than the pixels aliases, and
  // the route audit's far-wall predictions miss). Off with supersampling k in 2-8: the scene at k
  // times the resolution, blurred by the lens and averaged k x k (k² times slower; the reference
  // the filtering is tested against). Texture filtering with supersampling > 1 is refused.
  int supersampling = 1;
  bool texture_filtering = true;

  void validate() const;  // throws std::invalid_argument naming the bad field
};

class WorldRenderer {
 public:
  // Throws std::invalid_argument naming a bad option.
  WorldRenderer(const PinholeCamera& camera, const RenderOptions& options);

  // BGR8 image of a camera whose optical centre is at (camera_pose.x, camera_pose.y) with the
  // optical axis along camera_pose.yaw (world frame, REP-103), tilted by the mount. `gain` scales the
  // brightness (illumination), `rng` draws the pixel noise; `yaw_rate` [rad/s] is the robot's
  // turning during the exposure (motion blur, with RenderOptions::exposure_time).
  cv::Mat render(const PlanarWorld& world, const Pose2D& camera_pose, double gain, cv::RNG& rng,
                 double yaw_rate = 0.0) const;

  const PinholeCamera& camera() const { return camera_; }
  // The optical axes (x right, y down, z forward) of this mount in base_link (columns): the
  // rotation of the camera's tf base_link -> optical frame, which the simulator publishes.
  Eigen::Matrix3d opticalToBase() const;

 private:
  PinholeCamera camera_;
  RenderOptions options_;
  // One ray per pixel (row-major) in the level optical frame, when the lens distorts or the mount
  // tilts; empty for the ideal level pinhole, which is rendered column by column.
  std::vector<Eigen::Vector3d> pixel_rays_;
  Eigen::Matrix3d level_from_camera_ = Eigen::Matrix3d::Identity();  // the tilted camera's rays to the level one's
  // With supersampling k > 1: the same camera at k times the resolution, whose samples render() averages.
  std::shared_ptr<const WorldRenderer> fine_;
  // With texture_filtering: the ripmaps of the walls' textures, built when first seen.
  std::shared_ptr<TextureRipmapCache> ripmaps_ = std::make_shared<TextureRipmapCache>();

  // The scene's colour at each pixel, one sample per pixel (before blur and noise).
  cv::Mat renderSamples(const PlanarWorld& world, const Pose2D& camera_pose, double gain) const;
};

// Ranges of a planar scanner at `pose` (world frame): `count` beams from angle_min to angle_max
// (robot frame, CCW); beams that hit nothing within range_max get +inf (REP-117).
std::vector<float> castScan(const PlanarWorld& world, const Pose2D& pose, double angle_min,
                            double angle_max, int count, double range_max);

}  // namespace homography_teach_repeat
