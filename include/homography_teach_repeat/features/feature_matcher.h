// Descriptor matching between a reference image and a current image: brute-force nearest
// neighbours with Lowe's ratio test and a mutual (cross) consistency check.
#pragma once

#include <opencv2/core.hpp>

#include <vector>

#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

struct MatchOptions {
  double ratio = 0.8;   // best / second-best distance must be below this (Lowe's test)
  bool mutual = true;   // keep a match only if each feature is the other's nearest neighbour

  void validate() const;  // throws std::invalid_argument
};

// queryIdx indexes `reference`, trainIdx indexes `current`.
// Status kInvalidInput when the descriptor types differ. Fewer than two features on either side
// gives an OK empty result.
Expected<std::vector<cv::DMatch>> matchFeatures(const ImageFeatures& reference,
                                                const ImageFeatures& current,
                                                const MatchOptions& options);

// Pixel coordinates of matched keypoints.
PointMatches toPointMatches(const ImageFeatures& reference, const ImageFeatures& current,
                            const std::vector<cv::DMatch>& matches);

}  // namespace homography_teach_repeat
