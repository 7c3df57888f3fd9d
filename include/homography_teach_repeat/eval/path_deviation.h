// How far a robot is from a taught path: the distance to the polyline through the keyframe
// positions, and the heading error against the keyframe nearest to that closest point. Used to
// score repeat runs against ground truth (scripts/demo, evaluate_demo_run).
#pragma once

#include <vector>

#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

struct PathDeviation {
  double distance = 0.0;       // [m] to the closest point of the path
  double heading_error = 0.0;  // [rad] robot yaw minus the nearest keyframe's yaw, wrapped
  int nearest_keyframe = -1;
};

// `path`: keyframe poses in order (at least one). Non-finite input gives NaN fields.
PathDeviation deviationFromPath(const std::vector<Pose2D>& path, const Pose2D& pose);

}  // namespace homography_teach_repeat
