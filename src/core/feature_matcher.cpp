#include "homography_teach_repeat/feature_matcher.h"

#include <opencv2/features2d.hpp>

#include <cmath>
#include <stdexcept>

namespace homography_teach_repeat {

void MatchOptions::validate() const {
  if (!(ratio > 0.0 && ratio <= 1.0)) throw std::invalid_argument("ratio must be in (0, 1]");
}

Expected<std::vector<cv::DMatch>> matchFeatures(const ImageFeatures& reference,
                                                const ImageFeatures& current,
                                                const MatchOptions& options) {
  options.validate();
  if (reference.type != current.type) {
    return Status(StatusCode::kInvalidInput, "cannot match " + toString(reference.type) +
                                                 " features against " + toString(current.type));
  }
  std::vector<cv::DMatch> result;
  if (reference.keypoints.size() < 2 || current.keypoints.size() < 2) return result;
  if (reference.descriptors.type() != current.descriptors.type() ||
      reference.descriptors.cols != current.descriptors.cols) {
    return Status(StatusCode::kInvalidInput, "descriptor layouts differ");
  }
  const int norm = hasBinaryDescriptor(reference.type) ? cv::NORM_HAMMING : cv::NORM_L2;
  cv::BFMatcher matcher(norm, false);
  std::vector<std::vector<cv::DMatch>> forward;
  matcher.knnMatch(reference.descriptors, current.descriptors, forward, 2);
  std::vector<cv::DMatch> backward;
  if (options.mutual) matcher.match(current.descriptors, reference.descriptors, backward);

  for (const auto& candidates : forward) {
    if (candidates.size() < 2) continue;
    const cv::DMatch& best = candidates[0];
    if (!(best.distance < options.ratio * candidates[1].distance)) continue;
    if (options.mutual && backward[static_cast<std::size_t>(best.trainIdx)].trainIdx != best.queryIdx) {
      continue;
    }
    result.push_back(best);
  }
  return result;
}

PointMatches toPointMatches(const ImageFeatures& reference, const ImageFeatures& current,
                            const std::vector<cv::DMatch>& matches) {
  PointMatches out;
  out.reserve(matches.size());
  for (const auto& m : matches) {
    const cv::Point2f& a = reference.keypoints[static_cast<std::size_t>(m.queryIdx)].pt;
    const cv::Point2f& b = current.keypoints[static_cast<std::size_t>(m.trainIdx)].pt;
    out.push_back({Eigen::Vector2d(a.x, a.y), Eigen::Vector2d(b.x, b.y)});
  }
  return out;
}

}  // namespace homography_teach_repeat
