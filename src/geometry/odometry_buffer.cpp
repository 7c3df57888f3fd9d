#include "homography_teach_repeat/geometry/odometry_buffer.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {

OdometryBuffer::OdometryBuffer(double capacity_seconds, double max_gap_seconds)
    : capacity_seconds_(capacity_seconds), max_gap_seconds_(max_gap_seconds) {
  if (!(capacity_seconds > 0.0) || !(max_gap_seconds > 0.0)) {
    throw std::invalid_argument("odometry buffer: capacity and max gap must be > 0");
  }
}

Status OdometryBuffer::add(double stamp, const Pose2D& pose) {
  if (!std::isfinite(stamp) || !std::isfinite(pose.x) || !std::isfinite(pose.y) ||
      !std::isfinite(pose.yaw)) {
    return Status(StatusCode::kInvalidInput, "odometry sample is not finite: dropped");
  }
  if (!samples_.empty() && stamp < samples_.back().first) {
    return Status(StatusCode::kInvalidInput,
                  "odometry stamp " + std::to_string(stamp) + " is older than the newest (" +
                      std::to_string(samples_.back().first) + "): dropped");
  }
  samples_.emplace_back(stamp, pose);
  while (!samples_.empty() && samples_.front().first < stamp - capacity_seconds_) {
    samples_.pop_front();
  }
  return Status::ok();
}

Expected<Pose2D> OdometryBuffer::poseAt(double stamp) const {
  if (samples_.empty()) return Status(StatusCode::kTooFewPoints, "no odometry received yet");
  if (!std::isfinite(stamp)) return Status(StatusCode::kInvalidInput, "stamp is not finite");
  if (stamp > samples_.back().first) {
    return Status(StatusCode::kNoConsensus, "no odometry yet at stamp " + std::to_string(stamp) + " (the newest is " +
                                                std::to_string(samples_.back().first) + ")");
  }
  if (stamp < samples_.front().first) {
    return Status(StatusCode::kInvalidInput,
                  "stamp " + std::to_string(stamp) + " is older than the odometry kept");
  }
  const auto upper = std::lower_bound(
      samples_.begin(), samples_.end(), stamp,
      [](const std::pair<double, Pose2D>& sample, double t) { return sample.first < t; });
  if (upper->first == stamp) return upper->second;
  const auto lower = upper - 1;
  const double gap = upper->first - lower->first;
  if (gap > max_gap_seconds_) {
    return Status(StatusCode::kInvalidInput,
                  "odometry gap of " + std::to_string(gap) + " s around the stamp");
  }
  const double s = (stamp - lower->first) / gap;
  const Pose2D& a = lower->second;
  const Pose2D& b = upper->second;
  return Pose2D(a.x + s * (b.x - a.x), a.y + s * (b.y - a.y),
                wrapToPi(a.yaw + s * wrapToPi(b.yaw - a.yaw)));
}

Expected<Pose2D> OdometryBuffer::poseNear(double stamp, double max_lag) const {
  if (!samples_.empty() && std::isfinite(stamp) && stamp > samples_.back().first &&
      stamp - samples_.back().first <= max_lag) {
    return samples_.back().second;
  }
  return poseAt(stamp);
}

}  // namespace homography_teach_repeat
