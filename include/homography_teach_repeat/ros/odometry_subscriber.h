// Odometry on its own callback queue and thread. ROS does not order callbacks across topics: with
// one spinner, an image whose socket was read first was processed before the odometry of its own
// instant, which was published before it (measured in the simulator: about 3 % of the frames found
// the newest odometry 0.1-0.3 s older than the image, so they got no pose or, turning, a wrong
// prediction). Here the odometry is handed over as it arrives, also while an image is processed,
// and a node can wait for the odometry of an image's stamp before it uses the image.
#pragma once

#include <nav_msgs/Odometry.h>
#include <ros/callback_queue.h>
#include <ros/ros.h>

#include <condition_variable>
#include <functional>
#include <limits>
#include <memory>
#include <mutex>
#include <string>

namespace homography_teach_repeat {

// The node's ~odometry_wait [s, 0-5]: how long an image waits for the odometry of its stamp
// (std::runtime_error naming the parameter outside that range).
double readOdometryWait(const ros::NodeHandle& private_nh, double default_wait = 0.2);

class OdometrySubscriber {
 public:
  using Callback = std::function<void(const nav_msgs::OdometryConstPtr&)>;

  // Subscribes `topic` (relative to `nh`, tcpNoDelay) and starts the thread that calls `callback`
  // (which must lock what it shares with the node's other callbacks).
  OdometrySubscriber(const ros::NodeHandle& nh, const std::string& topic, Callback callback);
  ~OdometrySubscriber();
  OdometrySubscriber(const OdometrySubscriber&) = delete;
  OdometrySubscriber& operator=(const OdometrySubscriber&) = delete;

  // Waits (wall time) until odometry stamped at or after `stamp` [s] has been handed to the
  // callback, at most `max_wait` [s]; whether it came.
  bool waitFor(double stamp, double max_wait) const;
  std::string topic() const { return subscriber_.getTopic(); }

 private:
  ros::CallbackQueue queue_;
  Callback callback_;
  ros::Subscriber subscriber_;
  std::unique_ptr<ros::AsyncSpinner> spinner_;
  mutable std::mutex mutex_;
  mutable std::condition_variable arrived_;
  double newest_ = -std::numeric_limits<double>::infinity();
};

}  // namespace homography_teach_repeat
