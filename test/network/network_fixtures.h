// Maps of routes for the network tests: in memory (poses only, for the graph and the composed
// route) and on disk (tiny routes written by RouteWriter, for the map store).
#pragma once

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "homography_teach_repeat/eval/synthetic_places.h"
#include "homography_teach_repeat/network/route_map.h"
#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {
namespace network_test {

// A temporary directory under $TMPDIR (the build tree's test_tmp), removed at exit.
inline std::string temporaryDirectory() {
  static struct Cleanup {
    std::vector<std::string> directories;
    ~Cleanup() {
      for (const auto& d : directories) {
        std::error_code ignored;
        std::filesystem::remove_all(d, ignored);
      }
    }
  } cleanup;
  const char* tmp = std::getenv("TMPDIR");
  std::string pattern = std::string(tmp != nullptr && *tmp != '\0' ? tmp : "/tmp") + "/htr_map_test_XXXXXX";
  const char* made = ::mkdtemp(pattern.data());
  if (made == nullptr) return std::string();
  cleanup.directories.emplace_back(made);
  return made;
}

using synthetic_places::tinyRouteInfo;

// A route of keyframes at `poses`, written to `directory` (tiny images and features).
inline Route writeTinyRoute(const std::string& directory, const std::vector<Pose2D>& poses,
                            FeatureType type = FeatureType::kOrb) {
  std::error_code ignored;
  std::filesystem::create_directories(std::filesystem::path(directory).parent_path(), ignored);
  auto writer = RouteWriter::create(directory, tinyRouteInfo(type));
  EXPECT_TRUE(writer.isOk()) << writer.status().toString();
  if (!writer.isOk()) return Route{};
  for (std::size_t k = 0; k < poses.size(); ++k) {
    ImageFeatures features;
    features.type = type;
    features.keypoints.emplace_back(cv::Point2f(3.0f, 4.0f), 7.0f);
    features.descriptors = cv::Mat(1, 32, CV_8U, cv::Scalar(static_cast<int>(k)));
    const Status added = writer->addKeyframe(cv::Mat(48, 64, CV_8UC1, cv::Scalar(static_cast<int>(10 * k))),
                                             features, {}, poses[k], 10.0 + static_cast<double>(k));
    EXPECT_TRUE(added.isOk()) << added.toString();
  }
  return writer->route();
}

// Keyframes every `step` metres from `start` along its heading.
inline std::vector<Pose2D> straight(const Pose2D& start, int count, double step = 0.5) {
  std::vector<Pose2D> poses;
  for (int k = 0; k < count; ++k) poses.push_back(start.compose(Pose2D(step * k, 0.0, 0.0)));
  return poses;
}

// An in-memory route (no files) for the graph and the composed route.
inline MapRoute memoryRoute(const std::string& name, const std::vector<Pose2D>& poses) {
  MapRoute r;
  r.name = name;
  r.directory = "routes/" + name;
  r.route.directory = "/maps/test/routes/" + name;
  r.route.info = tinyRouteInfo(FeatureType::kOrb);
  for (std::size_t k = 0; k < poses.size(); ++k) {
    RouteKeyframe keyframe;
    keyframe.index = static_cast<int>(k);
    keyframe.pose = poses[k];
    const std::string stem = "keyframes/" + std::to_string(k);
    keyframe.image_file = stem + ".png";
    keyframe.features_file = stem + ".features.yml";
    keyframe.lines_file = stem + ".lines.yml";
    r.route.keyframes.push_back(keyframe);
  }
  return r;
}

// The junction between two keyframes from their poses in a common frame (the world's truth).
inline Junction junctionFromPoses(const KeyframeRef& from, const Pose2D& from_pose, const KeyframeRef& to,
                                  const Pose2D& to_pose) {
  Junction j;
  j.from = from;
  j.to = to;
  j.to_in_from = from_pose.inverse().compose(to_pose);
  j.covariance = Eigen::Vector3d(1e-4, 1e-4, 1e-5).asDiagonal();
  j.inliers = 100;
  return j;
}

}  // namespace network_test
}  // namespace homography_teach_repeat
