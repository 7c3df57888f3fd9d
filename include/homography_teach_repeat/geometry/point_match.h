// Point correspondences between a reference image and a current image, and their undistortion:
// the one place where measured (distorted) pixels become the pinhole pixels every estimator
// works with (docs/math.md §1.1).
#pragma once

#include <Eigen/Core>

#include <vector>

#include "homography_teach_repeat/geometry/pinhole_camera.h"

namespace homography_teach_repeat {

// One point correspondence, pixels: `reference` in image 1, `current` in image 2.
struct PointMatch {
  Eigen::Vector2d reference;
  Eigen::Vector2d current;
};
using PointMatches = std::vector<PointMatch>;

// The matches with both pixels undistorted by `camera` (a camera without distortion returns
// them as they are). A pixel that does not undistort to a finite point (far outside the image of
// a strong lens) drops its match: estimators never see NaN; `kept`, when given, receives the
// index into `measured` of every match returned, so callers can map inliers back to the
// measured pixels.
PointMatches undistortMatches(const PinholeCamera& camera, const PointMatches& measured,
                              std::vector<int>* kept = nullptr);

}  // namespace homography_teach_repeat
