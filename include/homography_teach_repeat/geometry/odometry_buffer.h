// Odometry by timestamp: images and odometry arrive on different topics at different rates, so
// the pose of an image is interpolated at the image's stamp rather than taken from the latest
// message (arrival order lies under load and with rosbag). Linear interpolation of x, y and of
// yaw along the shorter arc.
#pragma once

#include <deque>
#include <utility>

#include "homography_teach_repeat/geometry/planar_pose.h"
#include "homography_teach_repeat/common/status.h"

namespace homography_teach_repeat {

class OdometryBuffer {
 public:
  // `capacity_seconds`: how much history is kept; `max_gap_seconds`: the largest gap between two
  // samples across which interpolation is allowed.
  explicit OdometryBuffer(double capacity_seconds = 5.0, double max_gap_seconds = 0.5);

  // kInvalidInput for a non-finite stamp or pose (the sample is dropped: NaN odometry must not
  // reach the route or the controller); kInvalidInput for a stamp older than the newest sample
  // (out-of-order); samples older than the capacity are discarded.
  Status add(double stamp, const Pose2D& pose);

  // Status kTooFewPoints when empty; kNoConsensus ("not yet") when `stamp` is newer than the
  // newest sample; kInvalidInput when older than the oldest kept sample or across a gap larger
  // than max_gap_seconds.
  Expected<Pose2D> poseAt(double stamp) const;
  // poseAt, except that a stamp at most `max_lag` [s] newer than the newest sample gets the newest
  // sample (an image processed before the odometry of the same instant has arrived; the robot
  // moves millimetres in that time). Errors as poseAt.
  Expected<Pose2D> poseNear(double stamp, double max_lag) const;

  bool empty() const { return samples_.empty(); }
  double newestStamp() const { return samples_.empty() ? 0.0 : samples_.back().first; }
  void clear() { samples_.clear(); }

 private:
  double capacity_seconds_;
  double max_gap_seconds_;
  std::deque<std::pair<double, Pose2D>> samples_;
};

}  // namespace homography_teach_repeat
