#include "homography_teach_repeat/geometry/point_match.h"

namespace homography_teach_repeat {

PointMatches undistortMatches(const PinholeCamera& camera, const PointMatches& measured, std::vector<int>* kept) {
  PointMatches undistorted;
  undistorted.reserve(measured.size());
  if (kept != nullptr) {
    kept->clear();
    kept->reserve(measured.size());
  }
  const bool distorted = !camera.isIdealPinhole();
  for (std::size_t i = 0; i < measured.size(); ++i) {
    PointMatch m = measured[i];
    if (distorted) {
      const cv::Point2d a = camera.undistortPixel({m.reference.x(), m.reference.y()});
      const cv::Point2d b = camera.undistortPixel({m.current.x(), m.current.y()});
      m.reference = Eigen::Vector2d(a.x, a.y);
      m.current = Eigen::Vector2d(b.x, b.y);
    }
    if (!m.reference.allFinite() || !m.current.allFinite()) continue;
    undistorted.push_back(m);
    if (kept != nullptr) kept->push_back(static_cast<int>(i));
  }
  return undistorted;
}

}  // namespace homography_teach_repeat
