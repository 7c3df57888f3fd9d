// A world of vertical textured walls on a flat floor, for the camera simulator (planar_world_sim)
// and the closed-loop demo. Walls are 2D segments seen from above (REP-103 world frame: x, y on
// the floor, z up) with a height and a texture of known metric size, tiled along the wall from its
// start point and up from the floor. The image of a textured plane is a homography of its texture
// (docs/math.md §1.2), so a camera in this world sees exactly what the homography model assumes.
//
// World file (YAML), validated on load with the file and field of any problem:
//   format_version: 1
//   floor_colour: [B, G, R]          # 0..255, optional (default [70, 70, 70])
//   ceiling_colour: [B, G, R]        # optional (default [200, 200, 200])
//   illumination: {amplitude: 0.2, period: 60.0}   # optional: gain 1 + a sin(2 pi t / period)
//   camera_covered:                  # optional: where the camera sees nothing (a hand or a sheet over
//     - {name: hand, min: [x, y], max: [x, y]}   # the lens) while base_link is inside the box [m]
//   walls:
//     - name: north                  # optional, used in messages
//       start: [x, y]                # [m]
//       end: [x, y]                  # [m], not equal to start
//       height: 2.5                  # [m] > 0
//       texture: graf1.png           # relative to the world file's folder, or absolute
//       texture_size: [w, h]         # [m] > 0: metric size of one copy of the texture
//       variants: [poster.png, ...]  # optional: the wall's appearance in other runs (a poster
//                                    # replaced, a wall repainted), same texture_size; a run
//                                    # chooses variant k (PlanarWorld::withAppearance, sim
//                                    # parameter appearance_variant): the k-th of this list, and
//                                    # the texture itself on walls with fewer variants
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct Wall {
  std::string name;
  Eigen::Vector2d start = Eigen::Vector2d::Zero();
  Eigen::Vector2d end = Eigen::Vector2d::Zero();
  double height = 2.5;        // [m]
  cv::Mat texture;            // BGR8
  std::string texture_path;
  double texture_width = 1.0;   // [m] of one texture copy along the wall
  double texture_height = 1.0;  // [m] of one texture copy up the wall
  std::vector<cv::Mat> variants;  // BGR8: the wall's other appearances (`variants` of the file)
  std::vector<std::string> variant_paths;

  double length() const { return (end - start).norm(); }
};

struct Illumination {
  double amplitude = 0.0;  // relative gain change, [0, 1)
  double period = 60.0;    // [s] > 0
  double gainAt(double time) const;
};

// A box of the floor (min < max, world frame [m]) where the camera is covered.
struct CoveredRegion {
  std::string name;
  Eigen::Vector2d min = Eigen::Vector2d::Zero();
  Eigen::Vector2d max = Eigen::Vector2d::Zero();
  bool contains(const Eigen::Vector2d& position) const {
    return (position.array() >= min.array()).all() && (position.array() <= max.array()).all();
  }
};

struct PlanarWorld {
  std::vector<Wall> walls;
  std::vector<CoveredRegion> camera_covered;
  cv::Vec3b floor_colour{70, 70, 70};
  cv::Vec3b ceiling_colour{200, 200, 200};
  Illumination illumination;
  std::string source;  // file it was loaded from (for messages)

  // Checks every wall (finite end points, non-zero length, height and texture size > 0, a
  // texture image), the illumination and the covered regions (finite, min < max). Status
  // kInvalidInput naming the wall or region and field.
  Status validate() const;
  // Whether the camera of a robot whose base_link is at `position` is covered.
  bool cameraCoveredAt(const Eigen::Vector2d& position) const;
  // The world with appearance `variant` (0: as taught; k > 0: every wall with at least k variants
  // shows its k-th). kInvalidInput for a negative variant or one that no wall has.
  Expected<PlanarWorld> withAppearance(int variant) const;
};

// Loads and validates a world file. Status kInvalidInput naming the file and the field (a missing
// or unreadable texture, a zero-length wall, a NaN, an unknown format_version, ...).
Expected<PlanarWorld> loadPlanarWorld(const std::string& path);

struct RayHit {
  int wall = -1;
  double range = 0.0;  // ray parameter t: the hit is origin + t * direction
  double along = 0.0;  // [m] from the wall's start point
};

// The nearest wall hit by the horizontal ray origin + t * direction, t > min_range (none when no
// wall is hit). `direction` need not be unit: `range` is in units of it.
std::optional<RayHit> castRay(const PlanarWorld& world, const Eigen::Vector2d& origin,
                              const Eigen::Vector2d& direction, double min_range = 1e-9);

}  // namespace homography_teach_repeat
