#include "homography_teach_repeat/eval/path_deviation.h"

#include <Eigen/Core>

#include <algorithm>

#include <cmath>
#include <limits>

namespace homography_teach_repeat {

PathDeviation deviationFromPath(const std::vector<Pose2D>& path, const Pose2D& pose) {
  PathDeviation out;
  const double nan = std::numeric_limits<double>::quiet_NaN();
  if (path.empty() || !std::isfinite(pose.x) || !std::isfinite(pose.y) || !std::isfinite(pose.yaw)) {
    out.distance = out.heading_error = nan;
    return out;
  }
  const Eigen::Vector2d p(pose.x, pose.y);
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < path.size(); ++k) {
    const Eigen::Vector2d a(path[k].x, path[k].y);
    const Eigen::Vector2d b = k + 1 < path.size() ? Eigen::Vector2d(path[k + 1].x, path[k + 1].y) : a;
    const Eigen::Vector2d ab = b - a;
    const double t = ab.squaredNorm() > 0.0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
    const double d = (a + t * ab - p).norm();
    if (d < best) {
      best = d;
      out.nearest_keyframe = static_cast<int>(t <= 0.5 || k + 1 >= path.size() ? k : k + 1);
    }
  }
  out.distance = best;
  out.heading_error = wrapToPi(pose.yaw - path[static_cast<std::size_t>(out.nearest_keyframe)].yaw);
  return out;
}

}  // namespace homography_teach_repeat
