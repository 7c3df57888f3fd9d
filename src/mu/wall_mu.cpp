#include "homography_teach_repeat/mu/wall_mu.h"

#include "homography_teach_repeat/mu/heading_1d.h"

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

}  // namespace homography_teach_repeat
