// Exact synthetic correspondences of a plane seen by two cameras (reference and current), for
// the unit tests and the evaluation programs: points of the plane visible in both images,
// projected with the pinhole model of docs/math.md §1.1 (camera 2: X2 = R21 (X1 − C)).
#pragma once

#include <Eigen/Core>

#include <cstdint>
#include <random>

#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

// Projects a point of the reference frame into the camera at `pose` (undistorted pixels).
// Returns false when the point is not in front of that camera.
bool projectToCamera(const PinholeCamera& camera, const PlanarPose& pose,
                     const Eigen::Vector3d& point_reference, Eigen::Vector2d* pixel);

// Draws reference pixels uniformly over the image, intersects their rays with the plane
// (n·X = d) and keeps those in front of both cameras and inside both images, until `count`
// matches or `max_draws` draws. Exact (no noise).
PointMatches sampleVisiblePlaneMatches(const PinholeCamera& camera, const ScenePlane& plane,
                                       const PlanarPose& pose, int count, std::mt19937_64* rng,
                                       int max_draws = 100000);

// Same, for a given set of plane points (reference frame): the points seen by both cameras.
PointMatches projectPlanePoints(const PinholeCamera& camera, const PlanarPose& pose,
                                const std::vector<Eigen::Vector3d>& points_reference);

}  // namespace homography_teach_repeat
