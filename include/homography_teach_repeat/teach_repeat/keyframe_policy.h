// When the teach node stores a keyframe: after the robot has moved `distance` metres or turned
// `angle` radians since the last keyframe (by odometry), and always for the first image.
// (Defined in teach_session.cpp, its one user.)
#pragma once

#include <optional>

#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

struct KeyframePolicy {
  double distance = 0.5;  // [m] (config/teach_node.yaml says how to choose it)
  double angle = 0.35;    // [rad]

  void validate() const;  // throws std::invalid_argument naming the bad field

  // True for the first keyframe (no previous) or when either threshold is reached.
  bool shouldStore(const std::optional<Pose2D>& last_keyframe, const Pose2D& current) const;
};

}  // namespace homography_teach_repeat
