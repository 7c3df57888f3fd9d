#include "homography_teach_repeat/heading_aided_odometry.h"

#include <cmath>
#include <stdexcept>
#include <string>

namespace homography_teach_repeat {
namespace {

bool finite(const Pose2D& p) { return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.yaw); }

void requireNonNegative(double value, const char* name) {
  if (!std::isfinite(value) || value < 0.0) {
    throw std::invalid_argument(std::string("heading-aided odometry: ") + name + " must be finite and >= 0");
  }
}

}  // namespace

void HeadingAidedOdometryOptions::validate() const {
  requireNonNegative(position_variance_per_metre, "position_variance_per_metre");
  requireNonNegative(heading_fix_variance, "heading_fix_variance");
  requireNonNegative(heading_variance_per_metre, "heading_variance_per_metre");
  if (!(correction_gain > 0.0 && correction_gain <= 1.0)) {
    throw std::invalid_argument("heading-aided odometry: correction_gain must be in (0, 1]");
  }
}

HeadingAidedOdometry::HeadingAidedOdometry(const HeadingAidedOdometryOptions& options) : options_(options) {
  options_.validate();
}

Status HeadingAidedOdometry::align(const Pose2D& route_pose, const Pose2D& odom_pose) {
  if (!finite(route_pose) || !finite(odom_pose)) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite alignment pose");
  }
  alignment_ = route_pose.compose(odom_pose.inverse());
  aligned_ = true;
  last_odom_ = odom_pose;
  distance_since_start_ = distance_since_fix_ = 0.0;
  has_fix_ = false;
  return Status::ok();
}

void HeadingAidedOdometry::accumulateDistance(const Pose2D& odom_pose) {
  if (last_odom_) {
    const double step = std::hypot(odom_pose.x - last_odom_->x, odom_pose.y - last_odom_->y);
    distance_since_start_ += step;
    distance_since_fix_ += step;
  }
  last_odom_ = odom_pose;
}

Status HeadingAidedOdometry::correctHeading(double route_yaw, const Pose2D& odom_pose) {
  if (!std::isfinite(route_yaw) || !finite(odom_pose)) {
    return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite heading fix");
  }
  if (!aligned_) return Status(StatusCode::kNoConsensus, "heading-aided odometry: not aligned yet");
  const Pose2D at_fix = alignment_.compose(odom_pose);
  const double yaw = at_fix.yaw + options_.correction_gain * wrapToPi(route_yaw - at_fix.yaw);
  // Rotation about the robot's position at the fix: the same position, the measured heading.
  alignment_ = Pose2D(at_fix.x, at_fix.y, wrapToPi(yaw)).compose(odom_pose.inverse());
  distance_since_fix_ = 0.0;
  has_fix_ = true;
  return Status::ok();
}

Expected<Pose2D> HeadingAidedOdometry::routePose(const Pose2D& odom_pose) {
  if (!finite(odom_pose)) return Status(StatusCode::kInvalidInput, "heading-aided odometry: non-finite odometry");
  if (!aligned_) return Status(StatusCode::kNoConsensus, "heading-aided odometry: not aligned yet");
  accumulateDistance(odom_pose);
  Pose2D pose = alignment_.compose(odom_pose);
  pose.yaw = wrapToPi(pose.yaw);
  return pose;
}

Eigen::Matrix3d HeadingAidedOdometry::covariance() const {
  Eigen::Matrix3d c = Eigen::Matrix3d::Zero();
  c(0, 0) = c(1, 1) = options_.position_variance_per_metre * distance_since_start_;
  // Before the first fix the heading is the alignment's: as uncertain as after a fix plus drift.
  c(2, 2) = options_.heading_fix_variance + options_.heading_variance_per_metre *
                                                (has_fix_ ? distance_since_fix_ : distance_since_start_);
  return c;
}

}  // namespace homography_teach_repeat
