#include "homography_teach_repeat/ros/odometry_subscriber.h"

#include <cmath>

#include "homography_teach_repeat/ros/parameters.h"

#include <algorithm>
#include <chrono>
#include <limits>
#include <utility>

namespace homography_teach_repeat {

double readOdometryWait(const ros::NodeHandle& private_nh, double default_wait) {
  return readCheckedParameter(private_nh, "odometry_wait", default_wait,
                              [](double v) { return std::isfinite(v) && v >= 0.0 && v <= 5.0; }, "must be in [0, 5] s");
}

OdometrySubscriber::OdometrySubscriber(const ros::NodeHandle& nh, const std::string& topic, Callback callback)
    : callback_(std::move(callback)) {
  ros::NodeHandle own(nh);
  own.setCallbackQueue(&queue_);
  // tcpNoDelay: small messages at 50 Hz should not wait for the previous one's acknowledgement.
  subscriber_ = own.subscribe<nav_msgs::Odometry>(
      topic, 100,
      [this](const nav_msgs::OdometryConstPtr& odometry) {
        callback_(odometry);
        {
          std::lock_guard<std::mutex> lock(mutex_);
          newest_ = std::max(newest_, odometry->header.stamp.toSec());
        }
        arrived_.notify_all();
      },
      ros::VoidConstPtr(), ros::TransportHints().tcpNoDelay());
  spinner_ = std::make_unique<ros::AsyncSpinner>(1, &queue_);
  spinner_->start();
}

OdometrySubscriber::~OdometrySubscriber() {
  spinner_->stop();
  subscriber_.shutdown();
}

bool OdometrySubscriber::waitFor(double stamp, double max_wait) const {
  std::unique_lock<std::mutex> lock(mutex_);
  if (newest_ == -std::numeric_limits<double>::infinity()) return false;  // none yet: no reason to wait
  return arrived_.wait_for(lock, std::chrono::duration<double>(std::max(0.0, max_wait)),
                           [&] { return newest_ >= stamp; });
}

}  // namespace homography_teach_repeat
