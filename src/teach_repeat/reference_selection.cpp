#include "homography_teach_repeat/teach_repeat/reference_selection.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace homography_teach_repeat {

ReferenceSelector::ReferenceSelector(std::vector<Pose2D> keyframe_poses, double closed_route_gap)
    : poses_(std::move(keyframe_poses)), closed_(isClosedLoop(poses_, closed_route_gap)) {}

void ReferenceSelector::setTracked(int keyframe) { tracked_ = std::clamp(keyframe, 0, std::max(0, size() - 1)); }

std::vector<int> ReferenceSelector::candidates(int neighbour_search) const {
  const int n = size();
  std::vector<int> candidates{tracked_};
  for (int offset = 1; offset <= neighbour_search && offset < n; ++offset) {
    if (closed_) {
      const int ahead = (tracked_ + offset) % n;
      const int behind = ((tracked_ - offset) % n + n) % n;
      candidates.push_back(ahead);
      if (behind != ahead) candidates.push_back(behind);
    } else {
      if (tracked_ + offset < n) candidates.push_back(tracked_ + offset);
      if (tracked_ - offset >= 0) candidates.push_back(tracked_ - offset);
    }
  }
  return candidates;
}

void ReferenceSelector::advanceTo(const Pose2D& robot) {
  if (!std::isfinite(robot.x) || !std::isfinite(robot.y)) return;
  constexpr double kHeadingWeight = 0.5;  // [m/rad]
  auto distance = [&](const Pose2D& keyframe) {
    return std::hypot(keyframe.x - robot.x, keyframe.y - robot.y) +
           (std::isfinite(robot.yaw) ? kHeadingWeight * std::abs(wrapToPi(keyframe.yaw - robot.yaw)) : 0.0);
  };
  // The next keyframes are looked at, not only the next one: across a loop's seam the route's last
  // keyframe and keyframe 0 share a place and differ only in heading, so a robot leaving the start
  // heading like the last one never finds keyframe 0 closer, and stayed tracked to the last
  // keyframe for ~1 m of the first leg although keyframes 1 and 2 were far closer (the fixes with
  // the largest NEES in the simulator's room and gallery, every lap; docs/evaluation.md).
  constexpr int kLookAhead = 2;
  const int n = size();
  for (int steps = 0; steps < n;) {
    int nearest = tracked_;
    double nearest_distance = distance(poses_[static_cast<std::size_t>(tracked_)]);
    int nearest_step = 0;
    for (int ahead = 1; ahead <= kLookAhead && steps + ahead < n; ++ahead) {
      if (!closed_ && tracked_ + ahead >= n) break;
      const int keyframe = (tracked_ + ahead) % n;
      const double d = distance(poses_[static_cast<std::size_t>(keyframe)]);
      if (d < nearest_distance) {
        nearest = keyframe;
        nearest_distance = d;
        nearest_step = ahead;
      }
    }
    if (nearest_step == 0) break;
    tracked_ = nearest;
    steps += nearest_step;
  }
}

}  // namespace homography_teach_repeat
