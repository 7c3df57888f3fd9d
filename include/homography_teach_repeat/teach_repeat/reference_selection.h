// Which keyframe the repeat run is at, and which keyframes to try for the current image: the
// tracked one, then its neighbours (k+1, k−1, k+2, ...). On a closed route (a loop: its last
// keyframe near its first) tracking and the search wrap around, so lap 2 goes on from the last
// keyframe to the first ones.
#pragma once

#include <vector>

#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {

class ReferenceSelector {
 public:
  // `closed_route_gap` [m]: the route is a loop when it has at least 3 keyframes and its last is
  // within this distance of its first (0: never).
  ReferenceSelector(std::vector<Pose2D> keyframe_poses, double closed_route_gap);

  int tracked() const { return tracked_; }
  bool closedRoute() const { return closed_; }
  int size() const { return static_cast<int>(poses_.size()); }
  void setTracked(int keyframe);  // clamped to the route

  // The tracked keyframe and up to `neighbour_search` keyframes on each side, nearest first.
  std::vector<int> candidates(int neighbour_search) const;

  // Moves on while `robot` (route frame) is closer to one of the next two keyframes than to the
  // tracked one, to the nearest of them (at most one lap per call). "Closer" weighs the heading
  // too (0.5 m per radian): where the teach run turned in place the keyframes share a position,
  // and tracking must follow the turn (in the simulator, μ against a corner keyframe 60-90° away
  // from the robot's heading gave fixes 90° off). Non-finite positions are ignored.
  void advanceTo(const Pose2D& robot);

 private:
  std::vector<Pose2D> poses_;
  bool closed_ = false;
  int tracked_ = 0;
};

}  // namespace homography_teach_repeat
