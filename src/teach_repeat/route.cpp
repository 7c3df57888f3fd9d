#include "homography_teach_repeat/teach_repeat/route.h"

#include <sys/stat.h>
#include <yaml-cpp/yaml.h>

#include <opencv2/imgcodecs.hpp>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <utility>

#include "homography_teach_repeat/common/atomic_file.h"
#include "homography_teach_repeat/common/median.h"
#include "homography_teach_repeat/teach_repeat/route_files.h"

namespace homography_teach_repeat {
using route_files::emitPairMeasurement;
using route_files::emitPlaneUncertainty;
using route_files::keyframeStem;
using route_files::readPairMeasurement;
using route_files::readPlaneUncertainty;
using route_files::Reader;
using route_files::writeFeaturesFile;
using route_files::writeImageFile;
using route_files::writeLinesFile;

namespace {

const char* const kIndexName = "route.yaml";

bool fileExists(const std::string& path) {
  struct stat info {};
  return ::stat(path.c_str(), &info) == 0 && S_ISREG(info.st_mode);
}

Status makeDirectory(const std::string& path) {
  if (::mkdir(path.c_str(), 0755) == 0 || errno == EEXIST) {
    struct stat info {};
    if (::stat(path.c_str(), &info) == 0 && S_ISDIR(info.st_mode)) return Status::ok();
  }
  return Status(StatusCode::kInvalidInput,
                "cannot create route directory '" + path + "': " + std::strerror(errno));
}

// RouteWriter::create and checkRouteDirectoryWritable: `directory` and keyframes/ created if
// needed, then a directory that holds a route.yaml refused unless `overwrite`.
Status makeRouteDirectories(const std::string& directory) {
  Status status = makeDirectory(directory);
  if (status.isOk()) status = makeDirectory(directory + "/keyframes");
  return status;
}

Status refuseExistingRoute(const std::string& directory, bool overwrite) {
  if (!overwrite && fileExists(directory + "/" + kIndexName)) {
    return Status(StatusCode::kInvalidInput,
                  "'" + directory + "' already holds a route (route.yaml); refusing to overwrite");
  }
  return Status::ok();
}

void emitPose(YAML::Emitter& out, const Pose2D& pose) {
  out << YAML::Flow << YAML::BeginMap << YAML::Key << "x" << YAML::Value << pose.x << YAML::Key
      << "y" << YAML::Value << pose.y << YAML::Key << "yaw" << YAML::Value << pose.yaw
      << YAML::EndMap;
}

}  // namespace

Expected<RouteWriter> RouteWriter::create(const std::string& directory, const RouteInfo& info,
                                          bool overwrite) {
  try {
    PinholeCamera check(info.camera);
    (void)check;
  } catch (const std::invalid_argument& e) {
    return Status(StatusCode::kInvalidInput, std::string("route camera: ") + e.what());
  }
  Status status = makeRouteDirectories(directory);
  if (status.isOk()) status = refuseExistingRoute(directory, overwrite);
  if (!status.isOk()) return status;
  RouteWriter writer;
  writer.route_.directory = directory;
  writer.route_.info = info;
  // Fails here, at start, on a read-only directory rather than at the first keyframe.
  status = writer.writeIndex();
  if (!status.isOk()) return status;
  return writer;
}

Status checkRouteDirectoryWritable(const std::string& directory, bool overwrite) {
  auto notWritable = [&directory](const Status& cause) {
    return Status(StatusCode::kInvalidInput,
                  "route directory '" + directory + "' is not writable: " + cause.message());
  };
  Status status = makeRouteDirectories(directory);
  if (!status.isOk()) return notWritable(status);
  status = refuseExistingRoute(directory, overwrite);
  if (!status.isOk()) return status;
  const std::string probe = directory + "/keyframes/.write_probe";
  status = writeFileAtomically(probe, "teach_node write probe\n");
  if (!status.isOk()) return notWritable(status);
  std::remove(probe.c_str());
  return Status::ok();
}

Status RouteWriter::addKeyframe(const cv::Mat& image, const ImageFeatures& features,
                                const std::vector<VerticalLine>& lines, const Pose2D& pose,
                                double stamp) {
  if (image.empty()) return Status(StatusCode::kInvalidInput, "keyframe image is empty");
  if (!std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw) ||
      !std::isfinite(stamp)) {
    return Status(StatusCode::kInvalidInput, "keyframe pose or stamp is not finite");
  }
  RouteKeyframe keyframe;
  keyframe.index = static_cast<int>(route_.keyframes.size());
  keyframe.stamp = stamp;
  keyframe.pose = pose;
  const std::string stem = keyframeStem(keyframe.index);
  keyframe.image_file = stem + ".png";
  keyframe.features_file = stem + ".features.yml";
  keyframe.lines_file = stem + ".lines.yml";

  Status status = writeImageFile(route_.directory + "/" + keyframe.image_file, image);
  if (!status.isOk()) return status;

  status = writeFeaturesFile(route_.directory + "/" + keyframe.features_file, features);
  if (!status.isOk()) return status;

  status = writeLinesFile(route_.directory + "/" + keyframe.lines_file, lines);
  if (!status.isOk()) return status;

  route_.keyframes.push_back(keyframe);
  status = writeIndex();
  if (!status.isOk()) route_.keyframes.pop_back();
  return status;
}

Status RouteWriter::setPlanes(const std::vector<std::optional<ScenePlane>>& planes,
                              double first_plane_distance) {
  if (planes.size() != route_.keyframes.size()) {
    return Status(StatusCode::kInvalidInput, "one plane (or none) per keyframe is needed");
  }
  if (!(first_plane_distance >= 0.0) || !std::isfinite(first_plane_distance)) {
    return Status(StatusCode::kInvalidInput, "first_plane_distance must be finite and >= 0");
  }
  for (std::size_t k = 0; k < planes.size(); ++k) {
    route_.keyframes[k].plane = planes[k];
    route_.keyframes[k].plane_uncertainty.reset();
  }
  route_.info.first_plane_distance = first_plane_distance;
  return writeIndex();
}

Status RouteWriter::setPlaneUncertainties(const std::vector<std::optional<PlaneUncertainty>>& uncertainties) {
  if (uncertainties.size() != route_.keyframes.size()) {
    return Status(StatusCode::kInvalidInput, "one plane uncertainty (or none) per keyframe is needed");
  }
  for (std::size_t k = 0; k < uncertainties.size(); ++k) {
    if (!uncertainties[k]) continue;
    const std::string keyframe = "keyframe " + std::to_string(k) + ": plane uncertainty";
    if (!route_.keyframes[k].plane) return Status(StatusCode::kInvalidInput, keyframe + " without a plane");
    const Status valid = uncertainties[k]->validate();
    if (!valid.isOk()) return Status(StatusCode::kInvalidInput, keyframe + ": " + valid.message());
  }
  for (std::size_t k = 0; k < uncertainties.size(); ++k) route_.keyframes[k].plane_uncertainty = uncertainties[k];
  route_.info.plane_uncertainty_method = kPlaneUncertaintyMethod;
  return writeIndex();
}

Status PlaneUncertainty::validate() const {
  constexpr double kLargest = 0.5;  // what PlanarPoseEstimatorOptions accepts
  const auto invalid = [](const std::string& message) { return Status(StatusCode::kInvalidInput, message); };
  if (!(normal_sigma_rad >= 0.0 && normal_sigma_rad <= kLargest)) return invalid("normal_rad must be within [0, 0.5]");
  if (!(distance_sigma >= 0.0 && distance_sigma <= kLargest)) return invalid("distance must be within [0, 0.5]");
  if (pivot && !pivot->allFinite()) return invalid("pivot is not finite");
  if (fix_error_per_m2) {
    const Eigen::Matrix3d& e = *fix_error_per_m2;
    if (!e.allFinite()) return invalid("fix_error_per_m2 is not finite");
    if ((e - e.transpose()).cwiseAbs().maxCoeff() > 1e-9 * (1.0 + e.cwiseAbs().maxCoeff())) {
      return invalid("fix_error_per_m2 is not symmetric");
    }
    if ((e.diagonal().array() < 0.0).any()) return invalid("fix_error_per_m2 has a negative variance");
  }
  if (fix_heading_intercept_rad) {
    if (!fix_error_per_m2) return invalid("fix_heading_intercept_rad without fix_error_per_m2");
    if (!(std::abs(*fix_heading_intercept_rad) <= kLargestHeadingFloorRad)) {
      return invalid("fix_heading_intercept_rad must be within [-0.05, 0.05]");
    }
  }
  return Status::ok();
}

bool PlaneUncertainty::liesOn(const ScenePlane& plane) const {
  return !pivot || std::abs(plane.normal.dot(*pivot) - plane.distance) <= 1e-9 * (1.0 + plane.distance);
}

bool planeUncertaintyMissing(const Route& route) {
  const bool current = route.info.plane_uncertainty_method == kPlaneUncertaintyMethod;
  for (const RouteKeyframe& k : route.keyframes) {
    if (k.plane && !(current && k.plane_uncertainty && k.plane_uncertainty->liesOn(*k.plane))) return true;
  }
  return false;
}

bool planeUncertaintyStored(const Route& route) {
  bool any = false;
  for (const RouteKeyframe& k : route.keyframes) any = any || k.plane.has_value();
  return any && !planeUncertaintyMissing(route);
}

Status RouteWriter::setMeasuredNoise(const std::vector<std::optional<MatchResidual>>& residuals,
                                     const std::vector<std::optional<PairTilt>>& tilts) {
  if (residuals.size() != route_.keyframes.size() || tilts.size() != route_.keyframes.size()) {
    return Status(StatusCode::kInvalidInput, "one match residual and one tilt (or none) per keyframe are needed");
  }
  for (std::size_t k = 0; k < residuals.size(); ++k) {
    if (residuals[k] && !(std::isfinite(residuals[k]->rms_px) && residuals[k]->rms_px > 0.0 && residuals[k]->inliers >= 4)) {
      return Status(StatusCode::kInvalidInput, "keyframe " + std::to_string(k) +
                                                   ": match residual must be finite and > 0 with >= 4 inliers");
    }
    if (tilts[k] && !tilts[k]->inRange()) {
      return Status(StatusCode::kInvalidInput, "keyframe " + std::to_string(k) +
                                                   ": tilt to the next keyframe must be finite and within 0.1 rad");
    }
  }
  for (std::size_t k = 0; k < residuals.size(); ++k) {
    route_.keyframes[k].match_residual = residuals[k];
    route_.keyframes[k].tilt_to_next = tilts[k];
  }
  route_.info.match_noise_measured = true;
  route_.info.tilt_measured = true;
  return Status::ok();
}

Status RouteWriter::writeIndex() const { return writeRouteIndex(route_); }

namespace {
// Calls visit(match_residual, tilt_to_next) for every keyframe and every experience of the route.
template <typename Visit>
void forEachPairMeasurement(const Route& route, Visit&& visit) {
  for (const RouteKeyframe& k : route.keyframes) {
    visit(k.match_residual, k.tilt_to_next);
    for (const RouteExperience& e : k.experiences) visit(e.match_residual, e.tilt_to_next);
  }
}
}  // namespace

std::optional<double> routeMatchResidual(const Route& route) {
  if (!route.info.match_noise_measured) return std::nullopt;
  std::vector<double> values;
  forEachPairMeasurement(route, [&](const std::optional<MatchResidual>& residual, const std::optional<PairTilt>&) {
    if (residual) values.push_back(residual->rms_px);
  });
  return upperMedian(std::move(values));
}

std::optional<double> routeTiltSigma(const Route& route) {
  if (!route.info.tilt_measured) return std::nullopt;
  std::vector<double> magnitudes;
  forEachPairMeasurement(route, [&](const std::optional<MatchResidual>&, const std::optional<PairTilt>& tilt) {
    if (!tilt) return;
    magnitudes.push_back(std::abs(tilt->pitch));
    magnitudes.push_back(std::abs(tilt->roll));
  });
  const std::optional<double> median = upperMedian(std::move(magnitudes));
  if (!median) return std::nullopt;
  return 1.4826 * *median;  // the median of |x| is 0.6745 σ for a zero-mean normal x
}

Status writeRouteIndex(const Route& route) {
  const RouteInfo& info = route.info;
  YAML::Emitter out;
  out << YAML::BeginMap;
  out << YAML::Key << "format_version" << YAML::Value << kRouteFormatVersion;
  out << YAML::Key << "feature_type" << YAML::Value << toString(info.feature_type);
  out << YAML::Key << "camera" << YAML::Value << YAML::BeginMap;
  out << YAML::Key << "width" << YAML::Value << info.camera.width;
  out << YAML::Key << "height" << YAML::Value << info.camera.height;
  out << YAML::Key << "fx" << YAML::Value << info.camera.fx;
  out << YAML::Key << "fy" << YAML::Value << info.camera.fy;
  out << YAML::Key << "cx" << YAML::Value << info.camera.cx;
  out << YAML::Key << "cy" << YAML::Value << info.camera.cy;
  out << YAML::Key << "distortion_model" << YAML::Value << info.camera.distortion_model;
  out << YAML::Key << "distortion" << YAML::Value << YAML::Flow << info.camera.distortion;
  if (!info.camera.camera_to_level.isIdentity(1e-12)) {
    // Row-major, the levelling of a tilted mount (pinhole_camera.h); absent for a level camera.
    std::vector<double> rows;
    for (int r = 0; r < 3; ++r) for (int k = 0; k < 3; ++k) rows.push_back(info.camera.camera_to_level(r, k));
    out << YAML::Key << "camera_to_level" << YAML::Value << YAML::Flow << rows;
  }
  out << YAML::EndMap;
  out << YAML::Key << "camera_mount" << YAML::Value;
  emitPose(out, info.camera_mount);
  out << YAML::Key << "first_plane_distance" << YAML::Value << info.first_plane_distance;
  if (info.match_noise_measured) {
    // For the reader; loading takes the keyframes' values (routeMatchResidual), 0: none measured.
    out << YAML::Key << "measured_noise" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key
        << "match_residual_px" << YAML::Value << routeMatchResidual(route).value_or(0.0);
    if (info.tilt_measured) out << YAML::Key << "tilt_rad" << YAML::Value << routeTiltSigma(route).value_or(0.0);
    out << YAML::EndMap;
  }
  const bool any_uncertainty = std::any_of(route.keyframes.begin(), route.keyframes.end(),
                                           [](const RouteKeyframe& k) { return k.plane_uncertainty.has_value(); });
  if (any_uncertainty) out << YAML::Key << "plane_uncertainty_method" << YAML::Value << info.plane_uncertainty_method;
  out << YAML::Key << "keyframes" << YAML::Value << YAML::BeginSeq;
  for (const auto& k : route.keyframes) {
    out << YAML::BeginMap;
    out << YAML::Key << "index" << YAML::Value << k.index;
    out << YAML::Key << "stamp" << YAML::Value << k.stamp;
    out << YAML::Key << "pose" << YAML::Value;
    emitPose(out, k.pose);
    out << YAML::Key << "image" << YAML::Value << k.image_file;
    out << YAML::Key << "features" << YAML::Value << k.features_file;
    out << YAML::Key << "lines" << YAML::Value << k.lines_file;
    if (k.plane) {
      out << YAML::Key << "plane" << YAML::Value << YAML::Flow << YAML::BeginMap;
      out << YAML::Key << "normal" << YAML::Value << YAML::Flow << YAML::BeginSeq
          << k.plane->normal.x() << k.plane->normal.y() << k.plane->normal.z() << YAML::EndSeq;
      out << YAML::Key << "distance" << YAML::Value << k.plane->distance << YAML::EndMap;
    }
    emitPairMeasurement(out, k.match_residual, k.tilt_to_next);
    emitPlaneUncertainty(out, k.plane_uncertainty);
    if (!k.experiences.empty()) {
      out << YAML::Key << "experiences" << YAML::Value << YAML::BeginSeq;
      for (const RouteExperience& e : k.experiences) {
        out << YAML::Flow << YAML::BeginMap;
        out << YAML::Key << "id" << YAML::Value << e.id;
        out << YAML::Key << "stamp" << YAML::Value << e.stamp;
        out << YAML::Key << "pose" << YAML::Value;
        emitPose(out, e.pose);
        std::vector<double> covariance;
        for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) covariance.push_back(e.pose_covariance(r, c));
        out << YAML::Key << "pose_covariance" << YAML::Value << YAML::Flow << covariance;
        out << YAML::Key << "image" << YAML::Value << e.image_file;
        out << YAML::Key << "features" << YAML::Value << e.features_file;
        emitPairMeasurement(out, e.match_residual, e.tilt_to_next);
        out << YAML::EndMap;
      }
      out << YAML::EndSeq;
    }
    out << YAML::EndMap;
  }
  out << YAML::EndSeq << YAML::EndMap;
  return writeFileAtomically(route.directory + "/" + kIndexName, std::string(out.c_str()) + "\n");
}

std::string routeFilePath(const std::string& directory, const std::string& file) {
  if (!file.empty() && file.front() == '/') return file;
  return directory + "/" + file;
}

bool isClosedRoute(const Route& route, double max_gap) {
  std::vector<Pose2D> poses;
  for (const auto& k : route.keyframes) poses.push_back(k.pose);
  return isClosedLoop(poses, max_gap);
}

Expected<Route> loadRoute(const std::string& directory) {
  const std::string index_path = directory + "/" + kIndexName;
  if (!fileExists(index_path)) {
    return Status(StatusCode::kInvalidInput,
                  "no route at '" + directory + "': " + kIndexName + " not found");
  }
  Route route;
  route.directory = directory;
  const Reader reader(index_path);
  try {
    const YAML::Node root = YAML::LoadFile(index_path);
    if (!root.IsMap()) throw reader.error(root, "not a YAML map (empty or truncated file?)");
    const int version = reader.get<int>(root, "format_version");
    if (version < 1 || version > kRouteFormatVersion) {
      throw reader.error(root["format_version"],
                         "unknown format_version " + std::to_string(version) + " (this build reads 1 to " +
                             std::to_string(kRouteFormatVersion) + ")");
    }
    route.loaded_format_version = version;
    try {
      route.info.feature_type = featureTypeFromString(reader.get<std::string>(root, "feature_type"));
    } catch (const std::invalid_argument& e) {
      throw reader.error(root["feature_type"], e.what());
    }
    const YAML::Node camera = root["camera"];
    if (!camera || !camera.IsMap()) throw reader.error(root, "missing map 'camera'");
    CameraCalibration& c = route.info.camera;
    c.width = reader.get<int>(camera, "width");
    c.height = reader.get<int>(camera, "height");
    c.fx = reader.finite(camera, "fx");
    c.fy = reader.finite(camera, "fy");
    c.cx = reader.finite(camera, "cx");
    c.cy = reader.finite(camera, "cy");
    c.distortion_model = reader.get<std::string>(camera, "distortion_model");
    c.distortion = reader.get<std::vector<double>>(camera, "distortion");
    if (camera["camera_to_level"]) {
      const auto rows = reader.get<std::vector<double>>(camera, "camera_to_level");
      if (rows.size() != 9) throw reader.error(camera["camera_to_level"], "field 'camera_to_level' needs 9 numbers (row-major)");
      for (std::size_t i = 0; i < 9; ++i) c.camera_to_level(static_cast<int>(i / 3), static_cast<int>(i % 3)) = rows[i];
    }
    try {
      PinholeCamera check(c);
      (void)check;
    } catch (const std::invalid_argument& e) {
      throw reader.error(camera, std::string("bad camera: ") + e.what());
    }
    route.info.camera_mount = reader.pose(root, "camera_mount");
    route.info.first_plane_distance = reader.finite(root, "first_plane_distance");
    if (const YAML::Node measured = root["measured_noise"]) {
      if (version < 3) throw reader.error(measured, "'measured_noise' needs format_version 3");
      if (!measured.IsMap()) throw reader.error(measured, "'measured_noise' must be a map");
      const double residual = reader.finite(measured, "match_residual_px");
      if (residual < 0.0) throw reader.error(measured, "match_residual_px must be >= 0");
      route.info.match_noise_measured = true;
      if (measured["tilt_rad"]) {
        if (version < 4) throw reader.error(measured, "'measured_noise: tilt_rad' needs format_version 4");
        if (reader.finite(measured, "tilt_rad") < 0.0) throw reader.error(measured, "tilt_rad must be >= 0");
        route.info.tilt_measured = true;
      }
    }
    if (root["plane_uncertainty_method"]) {
      if (version < 5) throw reader.error(root, "'plane_uncertainty_method' needs format_version 5");
      route.info.plane_uncertainty_method = reader.get<int>(root, "plane_uncertainty_method");
      if (route.info.plane_uncertainty_method < 1) throw reader.error(root, "plane_uncertainty_method must be >= 1");
    }
    const YAML::Node keyframes = root["keyframes"];
    if (!keyframes || !keyframes.IsSequence()) throw reader.error(root, "missing list 'keyframes'");
    for (const auto& node : keyframes) {
      RouteKeyframe k;
      k.index = reader.get<int>(node, "index");
      if (k.index != static_cast<int>(route.keyframes.size())) {
        throw reader.error(node, "keyframe index " + std::to_string(k.index) + " out of order");
      }
      k.stamp = reader.finite(node, "stamp");
      k.pose = reader.pose(node, "pose");
      k.image_file = reader.get<std::string>(node, "image");
      k.features_file = reader.get<std::string>(node, "features");
      k.lines_file = reader.get<std::string>(node, "lines");
      for (const std::string* file : {&k.image_file, &k.features_file, &k.lines_file}) {
        if (!fileExists(routeFilePath(directory, *file))) {
          throw reader.error(node, "keyframe file '" + routeFilePath(directory, *file) + "' is missing");
        }
      }
      if (node["plane"]) {
        const YAML::Node plane = node["plane"];
        const auto normal = reader.get<std::vector<double>>(plane, "normal");
        if (normal.size() != 3) throw reader.error(plane, "plane normal needs 3 numbers");
        ScenePlane p;
        p.normal = Eigen::Vector3d(normal[0], normal[1], normal[2]);
        p.distance = reader.finite(plane, "distance");
        const Status valid = p.validate();
        if (valid.code() == StatusCode::kInvalidInput) throw reader.error(plane, valid.message());
        k.plane = p;
      }
      readPairMeasurement(reader, node, "keyframe " + std::to_string(k.index), version, &k.match_residual,
                          &k.tilt_to_next);
      k.plane_uncertainty = readPlaneUncertainty(reader, node, "keyframe " + std::to_string(k.index), version, k.plane);
      if (k.plane_uncertainty && route.info.plane_uncertainty_method == 0) {
        throw reader.error(node, "keyframe " + std::to_string(k.index) + ": plane_uncertainty without the route's plane_uncertainty_method");
      }
      if (const YAML::Node experiences = node["experiences"]) {
        if (version < 2) throw reader.error(experiences, "'experiences' needs format_version 2");
        if (!experiences.IsSequence()) throw reader.error(experiences, "'experiences' must be a list");
        for (const auto& e : experiences) {
          RouteExperience experience;
          experience.id = reader.get<int>(e, "id");
          experience.stamp = reader.finite(e, "stamp");
          experience.pose = reader.pose(e, "pose");
          const auto covariance = reader.get<std::vector<double>>(e, "pose_covariance");
          if (covariance.size() != 9) throw reader.error(e, "field 'pose_covariance' needs 9 numbers (row-major)");
          for (std::size_t i = 0; i < 9; ++i) {
            if (!std::isfinite(covariance[i])) throw reader.error(e, "field 'pose_covariance' is not finite");
            experience.pose_covariance(static_cast<int>(i / 3), static_cast<int>(i % 3)) = covariance[i];
          }
          experience.image_file = reader.get<std::string>(e, "image");
          experience.features_file = reader.get<std::string>(e, "features");
          readPairMeasurement(reader, e, "keyframe " + std::to_string(k.index) + ", experience " +
                              std::to_string(experience.id), version, &experience.match_residual,
                              &experience.tilt_to_next);
          for (const std::string* file : {&experience.image_file, &experience.features_file}) {
            if (!fileExists(routeFilePath(directory, *file))) {
              throw reader.error(e, "experience file '" + routeFilePath(directory, *file) + "' is missing");
            }
          }
          k.experiences.push_back(std::move(experience));
        }
      }
      route.keyframes.push_back(k);
    }
  } catch (const YAML::Exception& e) {
    return Status(StatusCode::kInvalidInput,
                  index_path + ":" + std::to_string(e.mark.line + 1) + ": " + e.msg);
  } catch (const std::runtime_error& e) {
    return Status(StatusCode::kInvalidInput, e.what());
  }
  return route;
}

}  // namespace homography_teach_repeat
