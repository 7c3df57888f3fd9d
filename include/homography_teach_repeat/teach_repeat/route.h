// A taught route on disk: a directory with an index `route.yaml` and per-keyframe files
//   keyframes/NNNNNN.png            the reference image (as recorded: distorted, 8-bit)
//   keyframes/NNNNNN.features.yml   keypoints + descriptors (cv::FileStorage)
//   keyframes/NNNNNN.lines.yml      vertical lines
// Every file is written atomically (atomic_file.h) and the index last, so a crash while teaching
// loses at most the keyframe being written: the index only ever lists complete keyframes.
//
// route.yaml (format_version 1):
//   format_version: 1
//   feature_type: sift | orb | akaze | surf
//   camera: {width, height, fx, fy, cx, cy, distortion_model, distortion: [..]}
//   camera_mount: {x, y, yaw}            # camera optical centre in base_link [m, rad]
//   first_plane_distance: 3.2            # user-given scale [m]; 0 = unknown
//   keyframes:
//     - {index: 0, stamp: 12.5, pose: {x, y, yaw},        # odometry pose of base_link [m, rad]
//        image: keyframes/000000.png, features: ..., lines: ...,
//        plane: {normal: [nx, ny, nz], distance: d}}      # optional, in the keyframe camera frame
// Loading validates everything and names the file and the problem on any error.
#pragma once

#include <opencv2/core.hpp>

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/features/vertical_lines.h"

namespace homography_teach_repeat {

constexpr int kRouteFormatVersion = 1;

struct RouteKeyframe {
  int index = 0;
  double stamp = 0.0;  // [s]
  Pose2D pose;         // odometry pose of base_link when the image was taken
  std::string image_file;     // relative to the route directory
  std::string features_file;
  std::string lines_file;
  std::optional<ScenePlane> plane;  // dominant plane in this keyframe's camera frame
};

struct RouteInfo {
  FeatureType feature_type = FeatureType::kSift;
  CameraCalibration camera;
  Pose2D camera_mount;  // camera optical centre and yaw in base_link (planar part of the tf)
  double first_plane_distance = 0.0;
};

struct Route {
  std::string directory;
  RouteInfo info;
  std::vector<RouteKeyframe> keyframes;
};

// Appends keyframes to a new route directory.
class RouteWriter {
 public:
  // Creates `directory` (and keyframes/) if needed. Status kInvalidInput when it cannot be created
  // or written (e.g. read-only), or already holds a route.yaml and `overwrite` is false.
  static Expected<RouteWriter> create(const std::string& directory, const RouteInfo& info,
                                      bool overwrite = false);

  // Writes the keyframe's files, then the index. Status kInvalidInput on an empty image, a
  // non-finite pose, or a write failure (the index then still lists only complete keyframes).
  Status addKeyframe(const cv::Mat& image, const ImageFeatures& features,
                     const std::vector<VerticalLine>& lines, const Pose2D& pose, double stamp);

  // Sets the plane of each keyframe (size must match) and the scale; rewrites the index.
  Status setPlanes(const std::vector<std::optional<ScenePlane>>& planes,
                   double first_plane_distance);

  const Route& route() const { return route_; }

 private:
  RouteWriter() = default;
  Status writeIndex() const;
  Route route_;
};

// Checks, before any image arrives, that a route can be written to `directory`: creates it and
// keyframes/ if needed and writes (then removes) a probe file through writeFileAtomically.
// Status kInvalidInput naming the directory when it cannot be created or written (read-only file
// system, permissions, a path through a regular file), or when it already holds a route.yaml and
// `overwrite` is false. teach_node calls it at start so a bad directory stops it at once.
Status checkRouteDirectoryWritable(const std::string& directory, bool overwrite);

// Reads and validates route.yaml (not the per-keyframe files). Status kInvalidInput naming the
// file for: a missing directory or index, YAML syntax errors (with line), an unknown
// format_version, missing or ill-typed fields, non-finite numbers, a bad camera, duplicate or
// unordered keyframe indices, a keyframe file that does not exist.
Expected<Route> loadRoute(const std::string& directory);

// Per-keyframe data; kInvalidInput naming the file when it is missing or corrupt.
Expected<cv::Mat> loadKeyframeImage(const Route& route, std::size_t keyframe);
Expected<ImageFeatures> loadKeyframeFeatures(const Route& route, std::size_t keyframe);
Expected<std::vector<VerticalLine>> loadKeyframeLines(const Route& route, std::size_t keyframe);

}  // namespace homography_teach_repeat
