#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

namespace homography_teach_repeat {

bool projectToCamera(const PinholeCamera& camera, const PlanarPose& pose,
                     const Eigen::Vector3d& point_reference, Eigen::Vector2d* pixel) {
  const Eigen::Vector3d in_camera = pose.rotation21() * (point_reference - pose.centre());
  if (!(in_camera.z() > 1e-6)) return false;
  *pixel = (camera.K() * in_camera).hnormalized();
  return pixel->allFinite();
}

namespace {
bool inside(const PinholeCamera& camera, const Eigen::Vector2d& p) {
  return p.x() >= 0.0 && p.y() >= 0.0 && p.x() <= camera.width() - 1.0 &&
         p.y() <= camera.height() - 1.0;
}
}  // namespace

PointMatches sampleVisiblePlaneMatches(const PinholeCamera& camera, const ScenePlane& plane,
                                       const PlanarPose& pose, int count, std::mt19937_64* rng,
                                       int max_draws) {
  std::uniform_real_distribution<double> u(0.0, camera.width() - 1.0);
  std::uniform_real_distribution<double> v(0.0, camera.height() - 1.0);
  const Eigen::Matrix3d K_inverse = camera.Kinverse();
  PointMatches matches;
  for (int draw = 0; draw < max_draws && static_cast<int>(matches.size()) < count; ++draw) {
    const Eigen::Vector2d reference(u(*rng), v(*rng));
    const Eigen::Vector3d ray = K_inverse * reference.homogeneous();
    const double along = plane.normal.dot(ray);
    if (!(along > 1e-9)) continue;  // ray parallel to or away from the plane
    const Eigen::Vector3d point = ray * (plane.distance / along);
    Eigen::Vector2d current;
    if (!projectToCamera(camera, pose, point, &current) || !inside(camera, current)) continue;
    matches.push_back({reference, current});
  }
  return matches;
}

PointMatches projectPlanePoints(const PinholeCamera& camera, const PlanarPose& pose,
                                const std::vector<Eigen::Vector3d>& points_reference) {
  PointMatches matches;
  const PlanarPose identity;
  for (const auto& point : points_reference) {
    Eigen::Vector2d reference, current;
    if (!projectToCamera(camera, identity, point, &reference) || !inside(camera, reference) ||
        !projectToCamera(camera, pose, point, &current) || !inside(camera, current)) {
      continue;
    }
    matches.push_back({reference, current});
  }
  return matches;
}

}  // namespace homography_teach_repeat
