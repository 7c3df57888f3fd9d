#include "homography_teach_repeat/geometry/scene_plane.h"

#include <cmath>

namespace homography_teach_repeat {
namespace {
// nx² + nz² below this is a horizontal plane (floor/ceiling).
constexpr double kHorizontalPlaneTolerance = 1e-6;
}  // namespace

Status ScenePlane::validate() const {
  if (!normal.allFinite() || !std::isfinite(distance)) {
    return Status(StatusCode::kInvalidInput, "plane normal or distance is not finite");
  }
  if (std::abs(normal.norm() - 1.0) > 1e-6) {
    return Status(StatusCode::kInvalidInput, "plane normal is not a unit vector");
  }
  if (!(distance > 0.0)) {
    return Status(StatusCode::kInvalidInput, "plane distance must be > 0");
  }
  if (normal.x() * normal.x() + normal.z() * normal.z() < kHorizontalPlaneTolerance) {
    return Status(StatusCode::kDegenerate,
                  "horizontal plane (floor/ceiling, nx = nz = 0): Fast-HD's Π is singular");
  }
  return Status::ok();
}

Eigen::Matrix3d planeInducedHomography(const PinholeCamera& camera, const PlanarPose& pose,
                                       const ScenePlane& plane, double height_offset) {
  const Eigen::Matrix3d R21 = pose.rotation21();
  const Eigen::Vector3d t21 = R21 * Eigen::Vector3d(pose.x, height_offset, pose.z);
  const Eigen::Matrix3d H =
      camera.K() * (R21 - t21 * plane.normal.transpose() / plane.distance) * camera.Kinverse();
  return H / H.norm();
}

std::optional<Eigen::Vector3d> centroidOnPlane(const ScenePlane& plane, const std::vector<Eigen::Vector3d>& rays) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int count = 0;
  for (const Eigen::Vector3d& ray : rays) {
    const double along = plane.normal.dot(ray);
    if (!(along > 1e-12)) continue;  // behind the camera, parallel, or NaN
    sum += ray * (plane.distance / along);
    ++count;
  }
  if (count == 0) return std::nullopt;
  return Eigen::Vector3d(sum / count);
}

std::optional<Eigen::Vector3d> centroidOnPlane(const ScenePlane& plane, const PinholeCamera& camera,
                                               const PointMatches& matches) {
  std::vector<Eigen::Vector3d> rays;
  rays.reserve(matches.size());
  const Eigen::Matrix3d K_inverse = camera.Kinverse();
  for (const PointMatch& match : matches) rays.push_back(K_inverse * match.reference.homogeneous());
  return centroidOnPlane(plane, rays);
}

ScenePlane turnedAbout(const ScenePlane& plane, const Eigen::Vector3d& normal, const Eigen::Vector3d& pivot) {
  ScenePlane turned = plane;
  turned.normal = normal.normalized();
  turned.distance = turned.normal.dot(pivot);
  return turned;
}

}  // namespace homography_teach_repeat
