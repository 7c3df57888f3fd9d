// The files of one keyframe (docs/route_format.md): its image, its features (and those of its
// learned views, addExperience) and its vertical lines, read and written, and the entries of the
// index that hold what was measured of it (route_files.h); route.cpp has the route's index.
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

void emitPairMeasurement(YAML::Emitter& out, const std::optional<MatchResidual>& residual,
                         const std::optional<PairTilt>& tilt) {
  if (residual) {
    out << YAML::Key << "match_residual" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "rms_px"
        << YAML::Value << residual->rms_px << YAML::Key << "inliers" << YAML::Value << residual->inliers
        << YAML::EndMap;
  }
  if (tilt) {
    out << YAML::Key << "tilt_to_next" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "pitch"
        << YAML::Value << tilt->pitch << YAML::Key << "roll" << YAML::Value << tilt->roll << YAML::EndMap;
  }
}

void readPairMeasurement(const Reader& reader, const YAML::Node& node, const std::string& owner, int version,
                         std::optional<MatchResidual>* residual_out, std::optional<PairTilt>* tilt_out) {
  if (const YAML::Node residual = node["match_residual"]) {
    const std::string name = owner + ": match_residual";
    if (version < 3) throw reader.error(residual, name + " needs format_version 3");
    if (!residual.IsMap()) throw reader.error(residual, name + " must be a map {rms_px, inliers}");
    MatchResidual measured;
    measured.rms_px = reader.get<double>(residual, "rms_px");
    measured.inliers = reader.get<int>(residual, "inliers");
    if (!std::isfinite(measured.rms_px) || !(measured.rms_px > 0.0)) {
      throw reader.error(residual, name + ".rms_px must be finite and > 0");
    }
    if (measured.inliers < 4) throw reader.error(residual, name + ".inliers must be >= 4");
    *residual_out = measured;
  }
  if (const YAML::Node tilt = node["tilt_to_next"]) {
    const std::string name = owner + ": tilt_to_next";
    if (version < 4) throw reader.error(tilt, name + " needs format_version 4");
    if (!tilt.IsMap()) throw reader.error(tilt, name + " must be a map {pitch, roll}");
    const PairTilt measured{reader.get<double>(tilt, "pitch"), reader.get<double>(tilt, "roll")};
    if (!measured.inRange()) throw reader.error(tilt, name + " must be finite and within 0.1 rad");
    *tilt_out = measured;
  }
}

void emitPlaneUncertainty(YAML::Emitter& out, const std::optional<PlaneUncertainty>& uncertainty) {
  if (!uncertainty) return;
  out << YAML::Key << "plane_uncertainty" << YAML::Value << YAML::Flow << YAML::BeginMap;
  out << YAML::Key << "normal_rad" << YAML::Value << uncertainty->normal_sigma_rad;
  out << YAML::Key << "distance" << YAML::Value << uncertainty->distance_sigma;
  if (uncertainty->pivot) {
    const Eigen::Vector3d& p = *uncertainty->pivot;
    out << YAML::Key << "pivot" << YAML::Value << YAML::Flow << std::vector<double>{p.x(), p.y(), p.z()};
  }
  if (uncertainty->fix_error_per_m2) {
    std::vector<double> rows;
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) rows.push_back((*uncertainty->fix_error_per_m2)(r, c));
    out << YAML::Key << "fix_error_per_m2" << YAML::Value << YAML::Flow << rows;
  }
  if (uncertainty->fix_heading_intercept_rad) {
    out << YAML::Key << "fix_heading_intercept_rad" << YAML::Value << *uncertainty->fix_heading_intercept_rad;
  }
  out << YAML::EndMap;
}

std::optional<PlaneUncertainty> readPlaneUncertainty(const Reader& reader, const YAML::Node& node, const std::string& owner,
                                                     int version, const std::optional<ScenePlane>& plane) {
  const YAML::Node entry = node["plane_uncertainty"];
  if (!entry) return std::nullopt;
  const std::string name = owner + ": plane_uncertainty";
  if (version < 5) throw reader.error(entry, name + " needs format_version 5");
  if (!plane) throw reader.error(entry, name + " without a plane");
  if (!entry.IsMap()) throw reader.error(entry, name + " must be a map {normal_rad, distance, pivot, fix_error_per_m2, fix_heading_intercept_rad}");
  PlaneUncertainty read;
  read.normal_sigma_rad = reader.get<double>(entry, "normal_rad");
  read.distance_sigma = reader.get<double>(entry, "distance");
  if (entry["pivot"]) {
    const auto pivot = reader.get<std::vector<double>>(entry, "pivot");
    if (pivot.size() != 3) throw reader.error(entry["pivot"], name + ".pivot needs 3 numbers");
    read.pivot = Eigen::Vector3d(pivot[0], pivot[1], pivot[2]);
  }
  if (entry["fix_error_per_m2"]) {
    const auto rows = reader.get<std::vector<double>>(entry, "fix_error_per_m2");
    if (rows.size() != 9) throw reader.error(entry["fix_error_per_m2"], name + ".fix_error_per_m2 needs 9 numbers (row-major)");
    Eigen::Matrix3d error;
    for (std::size_t i = 0; i < 9; ++i) error(static_cast<int>(i / 3), static_cast<int>(i % 3)) = rows[i];
    read.fix_error_per_m2 = error;
  }
  if (entry["fix_heading_intercept_rad"]) {
    read.fix_heading_intercept_rad = reader.get<double>(entry, "fix_heading_intercept_rad");
  }
  const Status valid = read.validate();
  if (!valid.isOk()) throw reader.error(entry, name + ": " + valid.message());
  // Measured with another plane (an index edited by hand): stale.
  if (!read.liesOn(*plane)) throw reader.error(entry, name + ": pivot is not on the keyframe's plane");
  return read;
}

Status writeLinesFile(const std::string& path, const std::vector<VerticalLine>& lines) {
  YAML::Emitter out;
  out << YAML::BeginMap << YAML::Key << "lines" << YAML::Value << YAML::BeginSeq;
  for (const auto& l : lines) {
    out << YAML::Flow << YAML::BeginMap;
    out << YAML::Key << "x" << YAML::Value << l.x;
    out << YAML::Key << "top" << YAML::Value << YAML::Flow << YAML::BeginSeq << l.top.x() << l.top.y()
        << YAML::EndSeq;
    out << YAML::Key << "bottom" << YAML::Value << YAML::Flow << YAML::BeginSeq << l.bottom.x()
        << l.bottom.y() << YAML::EndSeq;
    out << YAML::Key << "top_undistorted" << YAML::Value << YAML::Flow << YAML::BeginSeq
        << l.top_undistorted.x() << l.top_undistorted.y() << YAML::EndSeq;
    out << YAML::Key << "bottom_undistorted" << YAML::Value << YAML::Flow << YAML::BeginSeq
        << l.bottom_undistorted.x() << l.bottom_undistorted.y() << YAML::EndSeq;
    out << YAML::Key << "length" << YAML::Value << l.length;
    out << YAML::Key << "dark_left" << YAML::Value << (l.polarity == EdgePolarity::kDarkLeft);
    out << YAML::Key << "left_brightness" << YAML::Value << l.left_brightness;
    out << YAML::Key << "right_brightness" << YAML::Value << l.right_brightness;
    out << YAML::Key << "contrast" << YAML::Value << l.contrast;
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return writeFileAtomically(path, out.c_str());
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
