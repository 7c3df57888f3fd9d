// The files of one keyframe (docs/route_format.md): its image, its features (and those of its
// learned views, addExperience) and its vertical lines, read and written; route.cpp has the
// route's index.
#include "homography_teach_repeat/teach_repeat/route.h"

#include <yaml-cpp/yaml.h>

#include <opencv2/imgcodecs.hpp>

#include <cmath>
#include <cstdio>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/atomic_file.h"
#include "homography_teach_repeat/teach_repeat/route_files.h"

namespace homography_teach_repeat {
namespace route_files {

std::string keyframeStem(int index) {
  std::ostringstream s;
  s << "keyframes/" << std::setw(6) << std::setfill('0') << index;
  return s.str();
}

Status writeImageFile(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) return Status(StatusCode::kInvalidInput, "cannot encode an image as PNG");
  return writeFileAtomically(path, std::string(png.begin(), png.end()));
}

Status writeFeaturesFile(const std::string& path, const ImageFeatures& features) {
  cv::FileStorage storage(".yml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  storage << "feature_type" << toString(features.type);
  cv::write(storage, "keypoints", features.keypoints);
  storage << "descriptors" << features.descriptors;
  return writeFileAtomically(path, storage.releaseAndGetString());
}

}  // namespace route_files

using route_files::keyframeStem;
using route_files::Reader;
using route_files::writeFeaturesFile;
using route_files::writeImageFile;

namespace {
Status checkKeyframe(const Route& route, std::size_t keyframe) {
  if (keyframe >= route.keyframes.size()) {
    return Status(StatusCode::kInvalidInput, "keyframe " + std::to_string(keyframe) +
                                                 " is not in the route (" +
                                                 std::to_string(route.keyframes.size()) + ")");
  }
  return Status::ok();
}
}  // namespace

Expected<cv::Mat> loadKeyframeImage(const Route& route, std::size_t keyframe) {
  const Status valid = checkKeyframe(route, keyframe);
  if (!valid.isOk()) return valid;
  const std::string path = routeFilePath(route.directory, route.keyframes[keyframe].image_file);
  cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (image.empty()) {
    return Status(StatusCode::kInvalidInput, "keyframe image '" + path + "' cannot be decoded");
  }
  return image;
}

namespace {
Expected<ImageFeatures> loadFeaturesFile(const Route& route, const std::string& path) {
  ImageFeatures features;
  try {
    cv::FileStorage storage(path, cv::FileStorage::READ);
    if (!storage.isOpened()) {
      return Status(StatusCode::kInvalidInput, "cannot open keyframe features '" + path + "'");
    }
    std::string type;
    storage["feature_type"] >> type;
    features.type = featureTypeFromString(type);
    cv::read(storage["keypoints"], features.keypoints);
    storage["descriptors"] >> features.descriptors;
  } catch (const std::exception& e) {
    return Status(StatusCode::kInvalidInput,
                  "keyframe features '" + path + "' are corrupt: " + e.what());
  }
  if (features.type != route.info.feature_type ||
      static_cast<int>(features.keypoints.size()) != features.descriptors.rows) {
    return Status(StatusCode::kInvalidInput,
                  "keyframe features '" + path + "' are inconsistent (type or count)");
  }
  return features;
}
}  // namespace

Expected<ImageFeatures> loadKeyframeFeatures(const Route& route, std::size_t keyframe) {
  const Status valid = checkKeyframe(route, keyframe);
  if (!valid.isOk()) return valid;
  return loadFeaturesFile(route, routeFilePath(route.directory, route.keyframes[keyframe].features_file));
}

Status writeKeyframeFeatures(const Route& route, std::size_t keyframe, const ImageFeatures& features) {
  Status valid = checkKeyframe(route, keyframe);
  if (!valid.isOk()) return valid;
  return writeFeaturesFile(routeFilePath(route.directory, route.keyframes[keyframe].features_file), features);
}

Expected<ImageFeatures> loadExperienceFeatures(const Route& route, std::size_t keyframe, std::size_t experience) {
  const Status valid = checkKeyframe(route, keyframe);
  if (!valid.isOk()) return valid;
  const auto& experiences = route.keyframes[keyframe].experiences;
  if (experience >= experiences.size()) {
    return Status(StatusCode::kInvalidInput, "keyframe " + std::to_string(keyframe) + " has no experience " +
                                                 std::to_string(experience));
  }
  return loadFeaturesFile(route, routeFilePath(route.directory, experiences[experience].features_file));
}

Expected<std::vector<VerticalLine>> loadKeyframeLines(const Route& route, std::size_t keyframe) {
  const Status valid = checkKeyframe(route, keyframe);
  if (!valid.isOk()) return valid;
  const std::string path = routeFilePath(route.directory, route.keyframes[keyframe].lines_file);
  const Reader reader(path);
  std::vector<VerticalLine> lines;
  try {
    const YAML::Node root = YAML::LoadFile(path);
    if (!root.IsMap() || !root["lines"] || !root["lines"].IsSequence()) {
      throw reader.error(root, "missing list 'lines' (empty or truncated file?)");
    }
    auto point = [&](const YAML::Node& node, const std::string& key) {
      const auto v = reader.get<std::vector<double>>(node, key);
      if (v.size() != 2 || !std::isfinite(v[0]) || !std::isfinite(v[1])) {
        throw reader.error(node, "'" + key + "' needs 2 finite numbers");
      }
      return Eigen::Vector2d(v[0], v[1]);
    };
    for (const auto& node : root["lines"]) {
      VerticalLine l;
      l.x = reader.finite(node, "x");
      l.top = point(node, "top");
      l.bottom = point(node, "bottom");
      l.top_undistorted = point(node, "top_undistorted");
      l.bottom_undistorted = point(node, "bottom_undistorted");
      l.length = reader.finite(node, "length");
      l.polarity = reader.get<bool>(node, "dark_left") ? EdgePolarity::kDarkLeft
                                                       : EdgePolarity::kDarkRight;
      l.left_brightness = reader.finite(node, "left_brightness");
      l.right_brightness = reader.finite(node, "right_brightness");
      l.contrast = reader.finite(node, "contrast");
      lines.push_back(l);
    }
  } catch (const YAML::Exception& e) {
    return Status(StatusCode::kInvalidInput, path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  } catch (const std::runtime_error& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  return lines;
}

Status addExperience(Route& route, std::size_t keyframe, const cv::Mat& image, const ImageFeatures& features,
                     const Pose2D& pose, const Eigen::Matrix3d& pose_covariance, double stamp, int max_experiences) {
  if (keyframe >= route.keyframes.size()) {
    return Status(StatusCode::kInvalidInput, "experience for keyframe " + std::to_string(keyframe) +
                                                 ", the route has " + std::to_string(route.keyframes.size()));
  }
  if (image.empty()) return Status(StatusCode::kInvalidInput, "experience image is empty");
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw) || !std::isfinite(stamp) ||
      !pose_covariance.allFinite()) {
    return Status(StatusCode::kInvalidInput, "experience pose, covariance or stamp is not finite");
  }
  if (max_experiences < 1) return Status(StatusCode::kInvalidInput, "max_experiences must be >= 1");
  if (features.type != route.info.feature_type) {
    return Status(StatusCode::kInvalidInput, "experience features are " + toString(features.type) + ", the route's " +
                                                 toString(route.info.feature_type));
  }
  RouteKeyframe& k = route.keyframes[keyframe];
  RouteExperience experience;
  for (const RouteExperience& e : k.experiences) experience.id = std::max(experience.id, e.id + 1);
  experience.stamp = stamp;
  experience.pose = pose;
  experience.pose_covariance = pose_covariance;
  const std::string stem = keyframeStem(k.index) + ".e" + std::to_string(experience.id);
  experience.image_file = stem + ".png";
  experience.features_file = stem + ".features.yml";
  Status status = writeImageFile(route.directory + "/" + experience.image_file, image);
  if (status.isOk()) status = writeFeaturesFile(route.directory + "/" + experience.features_file, features);
  if (!status.isOk()) return status;
  const std::vector<RouteExperience> before = k.experiences;
  k.experiences.push_back(experience);
  std::vector<RouteExperience> dropped;
  while (static_cast<int>(k.experiences.size()) > max_experiences) {
    dropped.push_back(k.experiences.front());
    k.experiences.erase(k.experiences.begin());
  }
  status = writeRouteIndex(route);
  if (!status.isOk()) {
    k.experiences = before;
    return status;
  }
  // The index no longer lists them: a crash before this leaves only unlisted files behind.
  for (const RouteExperience& e : dropped) {
    std::remove((route.directory + "/" + e.image_file).c_str());
    std::remove((route.directory + "/" + e.features_file).c_str());
  }
  return Status::ok();
}

}  // namespace homography_teach_repeat
