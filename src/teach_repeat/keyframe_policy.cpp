#include "homography_teach_repeat/teach_repeat/keyframe_policy.h"

#include <cmath>
#include <stdexcept>

namespace homography_teach_repeat {

void KeyframePolicy::validate() const {
  if (!std::isfinite(distance) || !(distance > 0.0)) {
    throw std::invalid_argument("keyframe_distance must be finite and > 0");
  }
  if (!std::isfinite(angle) || !(angle > 0.0)) {
    throw std::invalid_argument("keyframe_angle must be finite and > 0");
  }
}

bool KeyframePolicy::shouldStore(const std::optional<Pose2D>& last_keyframe,
                                 const Pose2D& current) const {
  if (!last_keyframe) return true;
  return std::hypot(current.x - last_keyframe->x, current.y - last_keyframe->y) >= distance ||
         std::abs(wrapToPi(current.yaw - last_keyframe->yaw)) >= angle;
}

}  // namespace homography_teach_repeat
