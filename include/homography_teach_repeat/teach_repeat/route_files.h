// Internal to teach_repeat's route sources (route.cpp, route_keyframe_files.cpp): reading the
// route's YAML with file:line in every error, the index's entries of what was measured of a
// keyframe, and naming and writing a keyframe's image and features files atomically. The formats:
// docs/route_format.md.
#pragma once

#include <yaml-cpp/yaml.h>

#include <opencv2/core.hpp>

#include <cmath>
#include <optional>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/teach_repeat/route.h"

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

// A keyframe's or an experience's measured pair (match_residual, tilt_to_next), where it has one,
// written into the index's map being emitted; and read and validated (the version that introduced
// each: 3, 4), errors naming `owner` ("keyframe 3", "keyframe 3, experience 1").
void emitPairMeasurement(YAML::Emitter& out, const std::optional<MatchResidual>& residual,
                         const std::optional<PairTilt>& tilt);
void readPairMeasurement(const Reader& reader, const YAML::Node& node, const std::string& owner, int version,
                         std::optional<MatchResidual>* residual_out, std::optional<PairTilt>* tilt_out);
// A keyframe's plane_uncertainty, the same way (format 5; refused on a keyframe without a plane,
// where PlaneUncertainty::validate refuses it, or with its pivot off `plane`).
void emitPlaneUncertainty(YAML::Emitter& out, const std::optional<PlaneUncertainty>& uncertainty);
std::optional<PlaneUncertainty> readPlaneUncertainty(const Reader& reader, const YAML::Node& node, const std::string& owner,
                                                     int version, const std::optional<ScenePlane>& plane);

// "keyframes/NNNNNN" for keyframe `index`: the stem of its files' names (and its experiences').
std::string keyframeStem(int index);
// A PNG of `image` at `path`, written atomically.
Status writeImageFile(const std::string& path, const cv::Mat& image);
// A keyframe's features (type, keypoints, descriptors) as OpenCV YAML at `path`, written atomically.
Status writeFeaturesFile(const std::string& path, const ImageFeatures& features);
// A keyframe's vertical lines as YAML at `path`, written atomically.
Status writeLinesFile(const std::string& path, const std::vector<VerticalLine>& lines);

}  // namespace route_files
}  // namespace homography_teach_repeat
