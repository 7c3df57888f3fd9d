#include "homography_teach_repeat/sim/planar_world.h"

#include <yaml-cpp/yaml.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <tuple>
#include <utility>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

struct FieldError : std::runtime_error {
  using std::runtime_error::runtime_error;
};

double finiteNumber(const YAML::Node& node, const std::string& field) {
  if (!node || !node.IsScalar()) throw FieldError("'" + field + "' is missing or not a number");
  double value = 0.0;
  try {
    value = node.as<double>();
  } catch (const YAML::Exception&) {
    throw FieldError("'" + field + "' is not a number");
  }
  if (!std::isfinite(value)) throw FieldError("'" + field + "' is not finite");
  return value;
}

Eigen::Vector2d point(const YAML::Node& node, const std::string& field) {
  if (!node || !node.IsSequence() || node.size() != 2) throw FieldError("'" + field + "' must be [x, y]");
  return Eigen::Vector2d(finiteNumber(node[0], field + "[0]"), finiteNumber(node[1], field + "[1]"));
}

cv::Vec3b colour(const YAML::Node& node, const std::string& field, const cv::Vec3b& fallback) {
  if (!node) return fallback;
  if (!node.IsSequence() || node.size() != 3) throw FieldError("'" + field + "' must be [B, G, R]");
  cv::Vec3b c;
  for (int k = 0; k < 3; ++k) {
    const double v = finiteNumber(node[k], field + "[" + std::to_string(k) + "]");
    if (v < 0.0 || v > 255.0) throw FieldError("'" + field + "' components must be in 0..255");
    c[k] = static_cast<unsigned char>(std::lround(v));
  }
  return c;
}

// [length, width]-style pairs of the file.
std::pair<double, double> pair(const YAML::Node& node, const std::string& field, const char* names) {
  if (!node || !node.IsSequence() || node.size() != 2) throw FieldError("'" + field + "' must be " + names);
  return {finiteNumber(node[0], field + "[0]"), finiteNumber(node[1], field + "[1]")};
}

// A box's (or a wall's) look: height, texture (relative to `folder`) and texture_size.
BoxSurface boxSurface(const YAML::Node& node, const std::string& field, const std::filesystem::path& folder) {
  BoxSurface surface;
  surface.height = finiteNumber(node["height"], field + ".height");
  std::tie(surface.texture_width, surface.texture_height) = pair(node["texture_size"], field + ".texture_size", "[w, h]");
  if (!node["texture"] || !node["texture"].IsScalar()) throw FieldError("'" + field + ".texture' is missing");
  std::filesystem::path texture = node["texture"].as<std::string>();
  if (texture.is_relative()) texture = folder / texture;
  surface.texture_path = texture.string();
  surface.texture = cv::imread(surface.texture_path, cv::IMREAD_COLOR);
  if (surface.texture.empty()) throw FieldError("'" + field + ".texture': cannot read image '" + surface.texture_path + "'");
  return surface;
}

// What is wrong with a surface's height, texture size or texture ("" when nothing).
std::string checkSurface(double height, double texture_width, double texture_height, const cv::Mat& texture) {
  if (!std::isfinite(height) || !(height > 0.0)) return "height must be > 0";
  if (!std::isfinite(texture_width) || !(texture_width > 0.0) || !std::isfinite(texture_height) ||
      !(texture_height > 0.0)) {
    return "texture_size must be > 0";
  }
  if (texture.empty() || texture.type() != CV_8UC3) return "no BGR texture image";
  return "";
}

std::string checkSurface(const BoxSurface& s) {
  return checkSurface(s.height, s.texture_width, s.texture_height, s.texture);
}

}  // namespace

std::vector<Wall> boxWalls(const std::string& name, const Eigen::Vector2d& centre, double length, double width,
                           double yaw, const BoxSurface& surface) {
  const Eigen::Vector2d along(std::cos(yaw), std::sin(yaw)), across(-std::sin(yaw), std::cos(yaw));
  // Counter-clockwise seen from above: a viewer outside each side reads its texture left to right.
  const std::array<Eigen::Vector2d, 4> corners{
      centre + 0.5 * length * along - 0.5 * width * across, centre + 0.5 * length * along + 0.5 * width * across,
      centre - 0.5 * length * along + 0.5 * width * across, centre - 0.5 * length * along - 0.5 * width * across};
  static const std::array<const char*, 4> kSides{"front", "left", "back", "right"};
  std::vector<Wall> walls;
  for (std::size_t i = 0; i < 4; ++i) {
    Wall wall;
    wall.name = name + "." + kSides[i];
    wall.start = corners[i];
    wall.end = corners[(i + 1) % 4];
    wall.height = surface.height;
    wall.texture = surface.texture;
    wall.texture_path = surface.texture_path;
    wall.texture_width = surface.texture_width;
    wall.texture_height = surface.texture_height;
    wall.see_over = true;
    walls.push_back(std::move(wall));
  }
  return walls;
}

double distanceToBox(const Eigen::Vector2d& point, const Pose2D& pose, double length, double width) {
  const double dx = point.x() - pose.x, dy = point.y() - pose.y;
  const double c = std::cos(pose.yaw), s = std::sin(pose.yaw);
  const double along = std::abs(c * dx + s * dy) - 0.5 * length;
  const double across = std::abs(-s * dx + c * dy) - 0.5 * width;
  return std::hypot(std::max(along, 0.0), std::max(across, 0.0));
}

double Person::pathLength() const {
  double length = 0.0;
  for (std::size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  return length;
}

Pose2D Person::poseAt(double time) const {
  // The point `s` metres along the path and the direction of the leg it is on.
  auto along = [&](double s, bool backwards) {
    Eigen::Vector2d direction(1.0, 0.0);
    for (std::size_t i = 1; i < path.size(); ++i) {
      const Eigen::Vector2d leg = path[i] - path[i - 1];
      const double n = leg.norm();
      if (n < 1e-9) continue;
      direction = leg / n;
      if (s <= n || i + 1 == path.size()) {
        const Eigen::Vector2d p = path[i - 1] + std::clamp(s, 0.0, n) * direction;
        if (backwards) direction = -direction;
        return Pose2D(p.x(), p.y(), std::atan2(direction.y(), direction.x()));
      }
      s -= n;
    }
    return Pose2D(path.front().x(), path.front().y(), 0.0);
  };
  const double length = pathLength();
  const double walk = length / speed;
  const double cycle = 2.0 * walk + pause_at_start + pause_at_end;
  if (time <= start_time) return along(0.0, false);
  const double t = std::fmod(time - start_time, cycle);
  if (t < walk) return along(speed * t, false);
  if (t < walk + pause_at_end) return along(length, false);
  if (t < 2.0 * walk + pause_at_end) return along(length - speed * (t - walk - pause_at_end), true);
  return along(0.0, true);
}

double Person::turnedBackAt(double time) const {
  const double walk = pathLength() / speed;
  const double cycle = 2.0 * walk + pause_at_start + pause_at_end;
  if (time <= start_time) return time;
  const double t = std::fmod(time - start_time, cycle);
  // The outbound leg at t and the return leg at 2 walk + pause_at_end − t are at the same point.
  const bool walking = t < walk || (t >= walk + pause_at_end && t < 2.0 * walk + pause_at_end);
  return walking ? time - t + (2.0 * walk + pause_at_end - t) : time;
}

double Illumination::gainAt(double time) const {
  return 1.0 + amplitude * std::sin(2.0 * M_PI * time / period);
}

Status PlanarWorld::validate() const {
  auto bad = [&](const std::string& what) {
    return Status(StatusCode::kInvalidInput, "world '" + source + "': " + what);
  };
  if (walls.empty()) return bad("no walls");
  for (std::size_t i = 0; i < walls.size(); ++i) {
    const Wall& w = walls[i];
    const std::string name = "walls[" + std::to_string(i) + "]" + (w.name.empty() ? "" : " (" + w.name + ")");
    if (!w.start.allFinite() || !w.end.allFinite()) return bad(name + ": start/end not finite");
    if (!(w.length() > 1e-6)) return bad(name + ": zero-length wall (start == end)");
    if (std::string problem = checkSurface(w.height, w.texture_width, w.texture_height, w.texture); !problem.empty()) {
      return bad(problem.insert(0, name + ": "));
    }
  }
  if (!std::isfinite(illumination.amplitude) || illumination.amplitude < 0.0 || illumination.amplitude >= 1.0) {
    return bad("illumination.amplitude must be in [0, 1)");
  }
  if (!std::isfinite(illumination.period) || !(illumination.period > 0.0)) {
    return bad("illumination.period must be > 0");
  }
  for (std::size_t i = 0; i < camera_covered.size(); ++i) {
    const CoveredRegion& r = camera_covered[i];
    const std::string name = "camera_covered[" + std::to_string(i) + "]" + (r.name.empty() ? "" : " (" + r.name + ")");
    if (!r.min.allFinite() || !r.max.allFinite()) return bad(name + ": min/max not finite");
    if (!(r.min.array() < r.max.array()).all()) return bad(name + ": min must be below max in x and y");
  }
  for (std::size_t i = 0; i < clutter.size(); ++i) {
    const ClutterBox& c = clutter[i];
    const std::string name = "clutter[" + std::to_string(i) + "]" + (c.name.empty() ? "" : " (" + c.name + ")");
    if (!c.centre.allFinite() || !std::isfinite(c.yaw)) return bad(name + ": centre/yaw not finite");
    if (!std::isfinite(c.length) || !(c.length > 0.0) || !std::isfinite(c.width) || !(c.width > 0.0)) {
      return bad(name + ": size must be > 0");
    }
    if (std::string problem = checkSurface(c.surface); !problem.empty()) return bad(problem.insert(0, name + ": "));
  }
  for (std::size_t i = 0; i < people.size(); ++i) {
    const Person& p = people[i];
    const std::string name = "people[" + std::to_string(i) + "]" + (p.name.empty() ? "" : " (" + p.name + ")");
    if (p.path.size() < 2) return bad(name + ": path needs at least two points");
    for (const auto& point : p.path) {
      if (!point.allFinite()) return bad(name + ": path point not finite");
    }
    if (!(p.pathLength() > 1e-6)) return bad(name + ": path of zero length (a person must walk somewhere)");
    if (!std::isfinite(p.speed) || !(p.speed > 0.0) || p.speed > 3.0) return bad(name + ": speed must be in (0, 3] m/s");
    if (!std::isfinite(p.pause_at_start) || p.pause_at_start < 0.0 || !std::isfinite(p.pause_at_end) ||
        p.pause_at_end < 0.0) {
      return bad(name + ": pause must be >= 0");
    }
    if (!std::isfinite(p.start_time) || p.start_time < 0.0) return bad(name + ": start_time must be >= 0");
    if (!std::isfinite(p.depth) || !(p.depth > 0.0) || !std::isfinite(p.width) || !(p.width > 0.0)) {
      return bad(name + ": size must be > 0");
    }
    if (std::string problem = checkSurface(p.surface); !problem.empty()) return bad(problem.insert(0, name + ": "));
  }
  return Status::ok();
}

PlanarWorld PlanarWorld::withClutter() const {
  PlanarWorld world = *this;
  for (const ClutterBox& c : clutter) {
    for (Wall& wall : boxWalls(c.name, c.centre, c.length, c.width, c.yaw, c.surface)) world.walls.push_back(std::move(wall));
  }
  world.clutter.clear();
  return world;
}

PlanarWorld PlanarWorld::withPeople(const std::vector<Pose2D>& poses) const {
  PlanarWorld world = *this;
  for (std::size_t i = 0; i < people.size() && i < poses.size(); ++i) {
    const Person& person = people[i];
    const Pose2D& pose = poses[i];
    for (Wall& wall : boxWalls(person.name, Eigen::Vector2d(pose.x, pose.y), person.depth, person.width, pose.yaw,
                               person.surface)) {
      world.walls.push_back(std::move(wall));
    }
  }
  world.people.clear();
  return world;
}

Crowd::Crowd(std::vector<Person> people, const CrowdOptions& options)
    : people_(std::move(people)),
      clocks_(people_.size(), 0.0),
      yielded_(people_.size(), 0.0),
      standing_(people_.size(), 0.0),
      options_(options) {}

void Crowd::advance(double time, double dt, const Pose2D& robot) {
  if (!started_) {
    std::fill(clocks_.begin(), clocks_.end(), time);
    previous_robot_ = robot;
    started_ = true;
  }
  const Eigen::Vector2d robot_position(robot.x, robot.y);
  // In the robot's frame: x ahead of it, y beside its line.
  const Pose2D to_robot_frame = robot.inverse();
  // Below this [m/s] the robot counts as standing: people cross in front of a robot that waits.
  constexpr double kRobotMoving = 0.05;
  const bool robot_moving =
      dt > 0.0 && -to_robot_frame.transformPoint(Eigen::Vector2d(previous_robot_.x, previous_robot_.y)).x() > kRobotMoving * dt;
  previous_robot_ = robot;
  const double width = options_.yield_width;
  for (std::size_t i = 0; i < people_.size(); ++i) {
    const Pose2D now = people_[i].poseAt(clocks_[i]);
    const Pose2D next = people_[i].poseAt(clocks_[i] + dt);
    const Eigen::Vector2d step(next.x - now.x, next.y - now.y), to_robot = robot_position - Eigen::Vector2d(now.x, now.y);
    bool stands = false;
    if (step.norm() > 0.0) {
      // Would walk into the robot: it is in their lane ahead.
      const Eigen::Vector2d direction = step.normalized();
      const double along = direction.dot(to_robot);
      const double across = std::abs(direction.x() * to_robot.y() - direction.y() * to_robot.x());
      stands = along > 0.0 && along < options_.yield_distance && across < width;
      // Would step into the path of the robot driving towards them: wait at its edge.
      const Eigen::Vector2d here = to_robot_frame.transformPoint(Eigen::Vector2d(now.x, now.y));
      const Eigen::Vector2d there = to_robot_frame.transformPoint(Eigen::Vector2d(next.x, next.y));
      stands = stands || (robot_moving && here.x() > -width && here.x() < options_.yield_distance + width &&
                          std::abs(here.y()) >= width && std::abs(there.y()) < width);
    }
    if (!stands) {
      standing_[i] = 0.0;
      clocks_[i] += dt;
      continue;
    }
    yielded_[i] += dt;
    standing_[i] += dt;
    // Both waiting for the other: the person gives way, back where they came from.
    if (standing_[i] >= options_.yield_patience) {
      clocks_[i] = people_[i].turnedBackAt(clocks_[i]);
      standing_[i] = 0.0;
    }
  }
}

std::vector<Pose2D> Crowd::poses() const {
  std::vector<Pose2D> poses;
  for (std::size_t i = 0; i < people_.size(); ++i) poses.push_back(people_[i].poseAt(clocks_[i]));
  return poses;
}

bool PlanarWorld::cameraCoveredAt(const Eigen::Vector2d& position) const {
  for (const CoveredRegion& region : camera_covered) {
    if (region.contains(position)) return true;
  }
  return false;
}

Expected<PlanarWorld> PlanarWorld::withAppearance(int variant) const {
  if (variant < 0) {
    return Status(StatusCode::kInvalidInput, "world '" + source + "': appearance variant " + std::to_string(variant) +
                                                 " (must be >= 0; 0 is the world as taught)");
  }
  PlanarWorld changed = *this;
  bool any = variant == 0;
  for (Wall& wall : changed.walls) {
    if (variant == 0 || static_cast<std::size_t>(variant) > wall.variants.size()) continue;
    wall.texture = wall.variants[static_cast<std::size_t>(variant - 1)];
    wall.texture_path = wall.variant_paths[static_cast<std::size_t>(variant - 1)];
    any = true;
  }
  if (!any) {
    return Status(StatusCode::kInvalidInput, "world '" + source + "': no wall has appearance variant " +
                                                 std::to_string(variant) + " (its walls' 'variants' lists are shorter)");
  }
  return changed;
}

Expected<PlanarWorld> loadPlanarWorld(const std::string& path) {
  PlanarWorld world;
  world.source = path;
  auto bad = [&](const std::string& what) {
    return Status(StatusCode::kInvalidInput, "world '" + path + "': " + what);
  };
  YAML::Node root;
  try {
    root = YAML::LoadFile(path);
  } catch (const YAML::BadFile&) {
    return bad("cannot be read");
  } catch (const YAML::Exception& e) {
    return bad(std::string("not valid YAML: ") + e.what());
  }
  const std::filesystem::path folder = std::filesystem::path(path).parent_path();
  try {
    if (!root.IsMap()) throw FieldError("the top level must be a map");
    const double version = finiteNumber(root["format_version"], "format_version");
    if (version != 1.0) throw FieldError("unknown format_version " + std::to_string(version) + " (this build reads 1)");
    world.floor_colour = colour(root["floor_colour"], "floor_colour", world.floor_colour);
    world.ceiling_colour = colour(root["ceiling_colour"], "ceiling_colour", world.ceiling_colour);
    if (const YAML::Node light = root["illumination"]) {
      world.illumination.amplitude = finiteNumber(light["amplitude"], "illumination.amplitude");
      world.illumination.period = finiteNumber(light["period"], "illumination.period");
    }
    if (const YAML::Node covered = root["camera_covered"]) {
      if (!covered.IsSequence()) throw FieldError("'camera_covered' must be a list of {min: [x, y], max: [x, y]}");
      for (std::size_t i = 0; i < covered.size(); ++i) {
        const std::string field = "camera_covered[" + std::to_string(i) + "]";
        CoveredRegion region;
        if (covered[i]["name"]) region.name = covered[i]["name"].as<std::string>();
        region.min = point(covered[i]["min"], field + ".min");
        region.max = point(covered[i]["max"], field + ".max");
        world.camera_covered.push_back(std::move(region));
      }
    }
    if (const YAML::Node clutter = root["clutter"]) {
      if (!clutter.IsSequence()) throw FieldError("'clutter' must be a list of boxes");
      for (std::size_t i = 0; i < clutter.size(); ++i) {
        const std::string field = "clutter[" + std::to_string(i) + "]";
        const YAML::Node node = clutter[i];
        ClutterBox box;
        box.name = node["name"] ? node["name"].as<std::string>() : field;
        box.centre = point(node["centre"], field + ".centre");
        std::tie(box.length, box.width) = pair(node["size"], field + ".size", "[length, width]");
        if (node["yaw"]) box.yaw = finiteNumber(node["yaw"], field + ".yaw");
        box.surface = boxSurface(node, field, folder);
        world.clutter.push_back(std::move(box));
      }
    }
    if (const YAML::Node people = root["people"]) {
      if (!people.IsSequence()) throw FieldError("'people' must be a list");
      for (std::size_t i = 0; i < people.size(); ++i) {
        const std::string field = "people[" + std::to_string(i) + "]";
        const YAML::Node node = people[i];
        Person person;
        person.name = node["name"] ? node["name"].as<std::string>() : field;
        const YAML::Node path = node["path"];
        if (!path || !path.IsSequence()) throw FieldError("'" + field + ".path' must be a list of [x, y]");
        for (std::size_t k = 0; k < path.size(); ++k) {
          person.path.push_back(point(path[k], field + ".path[" + std::to_string(k) + "]"));
        }
        if (node["speed"]) person.speed = finiteNumber(node["speed"], field + ".speed");
        if (const YAML::Node pause = node["pause"]) {
          if (pause.IsSequence()) {
            std::tie(person.pause_at_start, person.pause_at_end) = pair(pause, field + ".pause", "[at_start, at_end]");
          } else {
            person.pause_at_start = person.pause_at_end = finiteNumber(pause, field + ".pause");
          }
        }
        if (node["start_time"]) person.start_time = finiteNumber(node["start_time"], field + ".start_time");
        if (node["size"]) std::tie(person.depth, person.width) = pair(node["size"], field + ".size", "[depth, width]");
        person.surface = boxSurface(node, field, folder);
        world.people.push_back(std::move(person));
      }
    }
    const YAML::Node walls = root["walls"];
    if (!walls || !walls.IsSequence() || walls.size() == 0) throw FieldError("'walls' must be a non-empty list");
    for (std::size_t i = 0; i < walls.size(); ++i) {
      const YAML::Node node = walls[i];
      const std::string field = "walls[" + std::to_string(i) + "]";
      Wall wall;
      if (node["name"]) wall.name = node["name"].as<std::string>();
      wall.start = point(node["start"], field + ".start");
      wall.end = point(node["end"], field + ".end");
      BoxSurface surface = boxSurface(node, field, folder);  // a wall's look is read as a box's
      wall.height = surface.height;
      wall.texture = std::move(surface.texture);
      wall.texture_path = std::move(surface.texture_path);
      wall.texture_width = surface.texture_width;
      wall.texture_height = surface.texture_height;
      if (const YAML::Node variants = node["variants"]) {
        if (!variants.IsSequence()) throw FieldError("'" + field + ".variants' must be a list of image files");
        for (std::size_t k = 0; k < variants.size(); ++k) {
          const std::string variant_field = field + ".variants[" + std::to_string(k) + "]";
          if (!variants[k].IsScalar()) throw FieldError("'" + variant_field + "' must be an image file");
          std::filesystem::path variant = variants[k].as<std::string>();
          if (variant.is_relative()) variant = folder / variant;
          cv::Mat image = cv::imread(variant.string(), cv::IMREAD_COLOR);
          if (image.empty()) throw FieldError("'" + variant_field + "': cannot read image '" + variant.string() + "'");
          wall.variant_paths.push_back(variant.string());
          wall.variants.push_back(std::move(image));
        }
      }
      world.walls.push_back(std::move(wall));
    }
  } catch (const FieldError& e) {
    return bad(e.what());
  } catch (const YAML::Exception& e) {
    return bad(std::string("malformed field: ") + e.what());
  }
  const Status valid = world.validate();
  if (!valid.isOk()) return valid;
  return world;
}

std::optional<RayHit> castRay(const PlanarWorld& world, const Eigen::Vector2d& origin,
                              const Eigen::Vector2d& direction, double min_range) {
  std::optional<RayHit> best;
  for (std::size_t i = 0; i < world.walls.size(); ++i) {
    const Wall& w = world.walls[i];
    const Eigen::Vector2d edge = w.end - w.start;
    // origin + t d = start + s e  ->  [d, -e] [t, s]^T = start - origin
    const double det = direction.x() * (-edge.y()) - direction.y() * (-edge.x());
    if (std::abs(det) < 1e-12) continue;  // parallel
    const Eigen::Vector2d rhs = w.start - origin;
    const double t = (rhs.x() * (-edge.y()) - rhs.y() * (-edge.x())) / det;
    const double s = (direction.x() * rhs.y() - direction.y() * rhs.x()) / det;
    if (t <= min_range || s < 0.0 || s > 1.0) continue;
    if (!best || t < best->range) best = RayHit{static_cast<int>(i), t, s * edge.norm()};
  }
  return best;
}

}  // namespace homography_teach_repeat
