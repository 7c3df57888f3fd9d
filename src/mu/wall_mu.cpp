#include "homography_teach_repeat/mu/wall_mu.h"

#include "homography_teach_repeat/mu/heading_1d.h"

#include <cmath>

namespace homography_teach_repeat {

std::optional<MuObservation> muWallOf(const Pose2D& reference_pose, const std::optional<ScenePlane>& plane,
                                      const Pose2D& camera_mount, double focal_px, int reference_id) {
  if (!plane) return std::nullopt;
  const Eigen::Vector2d normal(plane->normal.x(), plane->normal.z());
  if (!(normal.norm() > 0.5) || !(plane->distance > 0.0)) return std::nullopt;
  MuObservation wall;
  wall.reference_pose = reference_pose;
  // The wall's line in the (x, z) plane: n·X = d with the unit horizontal part of n.
  wall.wall_normal = normal.normalized();
  wall.wall_distance = plane->distance / normal.norm();
  wall.camera_mount = camera_mount;
  wall.focal_px = focal_px;
  wall.reference_id = reference_id;
  return wall;
}

Expected<Eigen::Matrix2d> wallHomography1dAt(const MuObservation& wall, const Pose2D& base) {
  const CameraMount mount(wall.camera_mount.x, wall.camera_mount.y, wall.camera_mount.yaw);
  const PlanarPose camera = mount.baseToCamera(wall.reference_pose.inverse().compose(base));
  return planeHomography1d(camera, wall.wall_normal, wall.wall_distance, wall.focal_px);
}

Expected<double> wallModelVariance(const MuObservation& wall, const Pose2D& base) {
  if (!std::isfinite(wall.wall_normal_sigma_rad) || !std::isfinite(wall.wall_distance_sigma) ||
      wall.wall_normal_sigma_rad < 0.0 || wall.wall_distance_sigma < 0.0) {
    return Status(StatusCode::kInvalidInput, "wall sigma must be finite and >= 0");
  }
  if (wall.wall_normal_sigma_rad == 0.0 && wall.wall_distance_sigma == 0.0) return 0.0;
  auto muOf = [&](double normal_turn, double distance_scale) -> Expected<double> {
    MuObservation moved = wall;
    const double c = std::cos(normal_turn), s = std::sin(normal_turn);
    moved.wall_normal = Eigen::Vector2d(c * wall.wall_normal.x() - s * wall.wall_normal.y(),
                                        s * wall.wall_normal.x() + c * wall.wall_normal.y());
    // The normal turns about the wall's pivot (its features' centroid; else its point nearest the
    // camera), then the distance scales (docs/math.md §3.6, §4.11).
    Eigen::Vector2d pivot = wall.wall_pivot.value_or(wall.wall_distance * wall.wall_normal);
    pivot += (wall.wall_distance - wall.wall_normal.dot(pivot)) * wall.wall_normal;  // onto the wall
    moved.wall_distance = moved.wall_normal.dot(pivot) * distance_scale;
    const auto H = wallHomography1dAt(moved, base);
    if (!H) return H.status();
    return (*H)(0, 1) / (*H)(1, 1);
  };
  constexpr double kStep = 1e-4;  // [rad] and [fraction]
  double variance = 0.0;
  if (wall.wall_normal_sigma_rad > 0.0) {
    const auto plus = muOf(kStep, 1.0);
    const auto minus = muOf(-kStep, 1.0);
    if (!plus || !minus) return Status(StatusCode::kDegenerate, "the wall turned is not in front of both cameras");
    const double slope = (*plus - *minus) / (2.0 * kStep);  // [px/rad]
    variance += slope * slope * wall.wall_normal_sigma_rad * wall.wall_normal_sigma_rad;
  }
  if (wall.wall_distance_sigma > 0.0) {
    const auto plus = muOf(0.0, 1.0 + kStep);
    const auto minus = muOf(0.0, 1.0 - kStep);
    if (!plus || !minus) return Status(StatusCode::kDegenerate, "the wall moved is not in front of both cameras");
    const double slope = (*plus - *minus) / (2.0 * kStep);  // [px per fraction of d]
    variance += slope * slope * wall.wall_distance_sigma * wall.wall_distance_sigma;
  }
  return variance;
}

}  // namespace homography_teach_repeat
