// Internal to teach_repeat's route sources (route.cpp, route_keyframe_files.cpp): reading the
// route's YAML with file:line in every error, and naming and writing a keyframe's image and
// features files atomically. The formats: docs/route_format.md.
#pragma once

#include <yaml-cpp/yaml.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <stdexcept>
#include <string>
#include <utility>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {
namespace route_files {

// Field access that reports the file, the key and the line of the node on failure.
class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}

  template <typename T>
  T get(const YAML::Node& node, const std::string& key) const {
    const YAML::Node child = node[key];
    if (!child) throw error(node, "missing field '" + key + "'");
    try {
      return child.as<T>();
    } catch (const YAML::Exception&) {
      throw error(child, "field '" + key + "' has the wrong type");
    }
  }
  double finite(const YAML::Node& node, const std::string& key) const {
    const double value = get<double>(node, key);
    if (!std::isfinite(value)) throw error(node[key], "field '" + key + "' is not finite");
    return value;
  }
  Pose2D pose(const YAML::Node& node, const std::string& key) const {
    const YAML::Node child = node[key];
    if (!child || !child.IsMap()) throw error(node, "missing map '" + key + "'");
    return Pose2D(finite(child, "x"), finite(child, "y"), finite(child, "yaw"));
  }
  std::runtime_error error(const YAML::Node& node, const std::string& message) const {
    const int line = node.Mark().line >= 0 ? node.Mark().line + 1 : 0;
    return std::runtime_error(file_ + (line > 0 ? ":" + std::to_string(line) : "") + ": " +
                              message);
  }

 private:
  std::string file_;
};

// "keyframes/NNNNNN" for keyframe `index`: the stem of its files' names (and its experiences').
std::string keyframeStem(int index);
// A PNG of `image` at `path`, written atomically.
Status writeImageFile(const std::string& path, const cv::Mat& image);
// A keyframe's features (type, keypoints, descriptors) as OpenCV YAML at `path`, written atomically.
Status writeFeaturesFile(const std::string& path, const ImageFeatures& features);

}  // namespace route_files
}  // namespace homography_teach_repeat
