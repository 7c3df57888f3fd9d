#include "homography_teach_repeat/sim/planar_world.h"

#include <yaml-cpp/yaml.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
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

}  // namespace

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
    if (!std::isfinite(w.height) || !(w.height > 0.0)) return bad(name + ": height must be > 0");
    if (!std::isfinite(w.texture_width) || !(w.texture_width > 0.0) || !std::isfinite(w.texture_height) ||
        !(w.texture_height > 0.0)) {
      return bad(name + ": texture_size must be > 0");
    }
    if (w.texture.empty() || w.texture.type() != CV_8UC3) return bad(name + ": no BGR texture image");
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
  return Status::ok();
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
    const YAML::Node walls = root["walls"];
    if (!walls || !walls.IsSequence() || walls.size() == 0) throw FieldError("'walls' must be a non-empty list");
    for (std::size_t i = 0; i < walls.size(); ++i) {
      const YAML::Node node = walls[i];
      const std::string field = "walls[" + std::to_string(i) + "]";
      Wall wall;
      if (node["name"]) wall.name = node["name"].as<std::string>();
      wall.start = point(node["start"], field + ".start");
      wall.end = point(node["end"], field + ".end");
      wall.height = finiteNumber(node["height"], field + ".height");
      const YAML::Node size = node["texture_size"];
      if (!size || !size.IsSequence() || size.size() != 2) throw FieldError("'" + field + ".texture_size' must be [w, h]");
      wall.texture_width = finiteNumber(size[0], field + ".texture_size[0]");
      wall.texture_height = finiteNumber(size[1], field + ".texture_size[1]");
      if (!node["texture"] || !node["texture"].IsScalar()) throw FieldError("'" + field + ".texture' is missing");
      std::filesystem::path texture = node["texture"].as<std::string>();
      if (texture.is_relative()) texture = folder / texture;
      wall.texture_path = texture.string();
      wall.texture = cv::imread(wall.texture_path, cv::IMREAD_COLOR);
      if (wall.texture.empty()) {
        throw FieldError("'" + field + ".texture': cannot read image '" + wall.texture_path + "'");
      }
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
