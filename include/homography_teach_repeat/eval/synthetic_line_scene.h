// Exact synthetic vertical-line observations for tests and evaluation programs: top-view points
// (x, z) of vertical lines, expressed in a reference frame, seen by a 1D camera at a planar pose
// (docs/math.md §4.1: X2 = R X1 + t with R = the x-z block of PlanarPose::rotation21()).
#pragma once

#include <Eigen/Core>

#include <optional>

#include "homography_teach_repeat/mu/heading_1d.h"
#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

// Image x of the vertical line through `point` (reference frame, metres) for a camera at `pose`
// (in the reference frame); nullopt when the line is behind the camera (z <= 1 cm) or its x is
// outside [0, width).
std::optional<double> projectVerticalLine(const LineCamera& camera, const PlanarPose& pose,
                                          const Eigen::Vector2d& point, double width);

}  // namespace homography_teach_repeat
