#include "homography_teach_repeat/eval/synthetic_line_scene.h"

namespace homography_teach_repeat {

std::optional<double> projectVerticalLine(const LineCamera& camera, const PlanarPose& pose,
                                          const Eigen::Vector2d& point, double width) {
  const Eigen::Vector3d in_camera =
      pose.rotation21() * (Eigen::Vector3d(point.x(), 0.0, point.y()) - pose.centre());
  if (!(in_camera.z() > 0.01)) return std::nullopt;
  const double x = camera.f * in_camera.x() / in_camera.z() + camera.x0;
  if (!(x >= 0.0 && x < width)) return std::nullopt;
  return x;
}

}  // namespace homography_teach_repeat
