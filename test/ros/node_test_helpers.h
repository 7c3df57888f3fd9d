// Helpers for the rostests: synthetic camera messages and waiting with a deadline.
#pragma once

#include <cv_bridge/cv_bridge.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <functional>

namespace homography_teach_repeat {
namespace test_support {

inline sensor_msgs::CameraInfo makeCameraInfo(int width, int height, double focal) {
  sensor_msgs::CameraInfo info;
  info.width = static_cast<uint32_t>(width);
  info.height = static_cast<uint32_t>(height);
  info.distortion_model = "plumb_bob";
  info.D = {0.0, 0.0, 0.0, 0.0, 0.0};
  info.K = {focal, 0.0, width / 2.0, 0.0, focal, height / 2.0, 0.0, 0.0, 1.0};
  info.R = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  info.P = {focal, 0.0, width / 2.0, 0.0, 0.0, focal, height / 2.0, 0.0, 0.0, 0.0, 1.0, 0.0};
  return info;
}

inline sensor_msgs::ImagePtr makeImage(const cv::Mat& image, const std::string& encoding) {
  return cv_bridge::CvImage(std_msgs::Header(), encoding, image).toImageMsg();
}

// Spins until `done()` or the wall-clock timeout; calls `tick()` every `period` seconds.
inline bool spinUntil(const std::function<bool()>& done, double timeout_s,
                      const std::function<void()>& tick = [] {}, double period = 0.5) {
  const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
  ros::WallTime next_tick = ros::WallTime::now();
  while (ros::ok() && ros::WallTime::now() < deadline) {
    if (ros::WallTime::now() >= next_tick) {
      tick();
      next_tick = ros::WallTime::now() + ros::WallDuration(period);
    }
    ros::spinOnce();
    if (done()) return true;
    ros::WallDuration(0.01).sleep();
  }
  return done();
}

}  // namespace test_support
}  // namespace homography_teach_repeat
