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
//   clutter:                         # optional: textured boxes standing off the walls (crates,
//     - name: crates                 # pillars, shelves; a low one is a partial occluder the
//       centre: [x, y]               # camera sees over), shown only where the simulator's
//       size: [length, width]        # parameter `clutter` is true (things moved in after the
//       yaw: 0.0                     # teach run); size [m] > 0 along and across yaw [rad]
//       height: 0.5                  # [m] > 0
//       texture: fruits.jpg
//       texture_size: [w, h]
//   people:                          # optional: people walking a path back and forth at walking
//     - name: visitor                # speed, seen by the camera and the laser where the
//       path: [[x, y], [x, y], ...]  # simulator's `people` is true; the path has a length > 0
//       speed: 1.2                   # [m/s] in (0, 3]
//       pause: [1.0, 8.0]            # [s] >= 0 standing at the path's first and last point
//       start_time: 20.0             # [simulated s] >= 0: stands at the first point until then
//       size: [0.3, 0.5]             # [m] > 0 footprint along and across the walking direction
//       height: 1.75                 # [m] > 0
//       texture: person.jpg
//       texture_size: [w, h]
// Clutter and people are boxes whose four sides are walls (`see_over`: a ray passing above one
// goes on to what is behind it); docs/simulator.md, "The world as a real camera sees it".
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <optional>
#include <limits>
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
  // A side of an object standing in the room (clutter, a person): a ray above its top goes on to
  // what is behind it. The room's walls reach the ceiling: above them the ceiling is seen.
  bool see_over = false;

  double length() const { return (end - start).norm(); }
};

// The look of a box's sides: one texture tiled around it from a corner and up from the floor.
struct BoxSurface {
  double height = 1.0;  // [m] > 0
  cv::Mat texture;      // BGR8
  std::string texture_path;
  double texture_width = 1.0;   // [m]
  double texture_height = 1.0;  // [m]
};

// A textured box standing on the floor (clutter): its footprint is `length` along `yaw` and
// `width` across, centred on `centre`.
struct ClutterBox {
  std::string name;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  double length = 0.5;  // [m] > 0
  double width = 0.5;   // [m] > 0
  double yaw = 0.0;     // [rad]
  BoxSurface surface;
};

// A person walking `path` from its first point to its last and back, again and again, at `speed`,
// standing `pause_at_start` / `pause_at_end` seconds at the ends, and standing at the first point
// until `start_time`. Body: a box of `depth` along the walking direction and `width` across.
struct Person {
  std::string name;
  std::vector<Eigen::Vector2d> path;
  double speed = 1.2;           // [m/s]
  double pause_at_start = 0.0;  // [s]
  double pause_at_end = 0.0;    // [s]
  double start_time = 0.0;      // [simulated s]
  double depth = 0.3;           // [m]
  double width = 0.5;           // [m]
  BoxSurface surface;

  double pathLength() const;
  // Where the person stands at simulated time `time` [s] (x, y) and which way they face (yaw:
  // the direction of the leg they are on, or last walked).
  Pose2D poseAt(double time) const;
  // A time at which the person stands where they stand at `time` but walks the other way (their
  // path's other leg); `time` itself while they pause at an end or have not started.
  double turnedBackAt(double time) const;
};

// Distance [m] from `point` to the footprint of a box centred at (pose.x, pose.y), `length` along
// pose.yaw and `width` across (0 inside): how close a robot came to a person or a crate.
double distanceToBox(const Eigen::Vector2d& point, const Pose2D& pose, double length, double width);

// The four sides of a box with footprint centre `centre`, `length` along `yaw`, `width` across, as
// walls listed counter-clockwise seen from above (each texture reads left to right from outside).
std::vector<Wall> boxWalls(const std::string& name, const Eigen::Vector2d& centre, double length, double width,
                           double yaw, const BoxSurface& surface);

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
  std::vector<ClutterBox> clutter;  // not in `walls` until withClutter()
  std::vector<Person> people;       // not in `walls`: withPeople(poses)
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
  // The world with its clutter standing in it (the boxes' sides added to `walls`).
  PlanarWorld withClutter() const;
  // The world with person i's body added to `walls` at poses[i] (a Crowd's poses()).
  PlanarWorld withPeople(const std::vector<Pose2D>& poses) const;
};

// How people give way to the robot (Crowd), as pedestrians do: a person stands
//  - while the robot's centre is in their lane ahead, within yield_distance [m] along the way they
//    walk and yield_width [m] across it (they would walk into it), and
//  - before stepping into the path of a robot that drives towards them: while their next step would
//    take them from outside to within yield_width of the line the robot drives along, the robot
//    moving forwards and between yield_width behind and yield_distance + yield_width before them
//    (they wait at the edge of its path until it has gone by, rather than step in front of it).
// Someone already in its path walks on out of it; someone who would pass beside the robot walks on.
// After standing yield_patience [s] in a row for it (the robot may be waiting for them too: neither
// would ever move) a person turns back the way they came. yield_width is the robot's radius, half
// the person's width and a margin.
struct CrowdOptions {
  double yield_distance = 1.0;
  double yield_width = 0.55;
  double yield_patience = std::numeric_limits<double>::infinity();
};

class Crowd {
 public:
  Crowd(std::vector<Person> people, const CrowdOptions& options);
  // From `time` to `time + dt` [simulated s], the robot (base_link) at `robot`; its speed is taken
  // from the previous call's pose.
  void advance(double time, double dt, const Pose2D& robot);
  std::vector<Pose2D> poses() const;
  // [s] how long person i has stood for the robot so far.
  double yieldedSeconds(std::size_t i) const { return yielded_.at(i); }

 private:
  std::vector<Person> people_;
  std::vector<double> clocks_;
  std::vector<double> yielded_;
  std::vector<double> standing_;  // [s] stood for the robot in a row
  CrowdOptions options_;
  Pose2D previous_robot_;
  bool started_ = false;
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
