// Synthetic places for the place index (its gtest and evaluate_place_index): landmarks along a
// path, each with its own descriptor; keyframe p sees the landmarks of a window starting at
// p * `step`, and a revisit sees a random part of that window with noisy descriptors.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "homography_teach_repeat/teach_repeat/route.h"

namespace homography_teach_repeat {
namespace synthetic_places {

struct World {
  cv::Mat landmarks;  // one descriptor per landmark (CV_32F or CV_8U)
  int window = 0;
  int step = 0;
};

// `binary`: 32-byte descriptors; otherwise 128 floats in [0, 1).
inline World makeWorld(int places, int window, int step, bool binary, unsigned seed = 7) {
  cv::RNG rng(seed);
  World w;
  w.window = window;
  w.step = step;
  const int count = (places - 1) * step + window;
  w.landmarks = binary ? cv::Mat(count, 32, CV_8U) : cv::Mat(count, 128, CV_32F);
  if (binary) {
    rng.fill(w.landmarks, cv::RNG::UNIFORM, 0, 256);
  } else {
    rng.fill(w.landmarks, cv::RNG::UNIFORM, 0.0, 1.0);
  }
  return w;
}

// What a visit to place `p` sees: `fraction` of its window's landmarks (a random subset), each
// descriptor with noise (`noise`: standard deviation for floats, flipped bits per descriptor for binary).
inline cv::Mat visit(const World& w, int p, double fraction, double noise, cv::RNG& rng) {
  cv::Mat seen;
  for (int i = 0; i < w.window; ++i) {
    if (rng.uniform(0.0, 1.0) >= fraction) continue;
    cv::Mat d = w.landmarks.row(p * w.step + i).clone();
    if (d.type() == CV_32F) {
      cv::Mat n(d.size(), CV_32F);
      rng.fill(n, cv::RNG::NORMAL, 0.0, noise);
      d += n;
    } else {
      for (int f = 0; f < static_cast<int>(noise); ++f) {
        const int bit = rng.uniform(0, 256);
        d.at<std::uint8_t>(0, bit / 8) ^= static_cast<std::uint8_t>(1 << (bit % 8));
      }
    }
    seen.push_back(d);
  }
  return seen;
}

// The route information of a map whose keyframe files only stand in (a 64x48 camera without
// distortion): the map store's tests and evaluate_place_index's synthetic maps.
inline RouteInfo tinyRouteInfo(FeatureType type) {
  RouteInfo info;
  info.feature_type = type;
  info.camera.width = 64;
  info.camera.height = 48;
  info.camera.fx = info.camera.fy = 50.0;
  info.camera.cx = 32.0;
  info.camera.cy = 24.0;
  info.camera.distortion_model = "plumb_bob";
  info.camera.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};
  return info;
}

}  // namespace synthetic_places
}  // namespace homography_teach_repeat
