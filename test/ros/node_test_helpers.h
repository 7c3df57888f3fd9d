// Helpers for the rostests: synthetic camera messages and waiting with a deadline.
#pragma once

#include <cv_bridge/cv_bridge.h>
#include <geometry_msgs/TransformStamped.h>
#include <image_transport/camera_common.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <optional>
#include <string>
#include <vector>

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

// The tf base_link -> camera_optical_frame of a level camera `x_ahead` metres ahead of base_link
// looking along base x: optical (x, y, z) = base (−y, −z, x).
inline geometry_msgs::TransformStamped levelCameraMount(double x_ahead) {
  geometry_msgs::TransformStamped mount;
  mount.header.stamp = ros::Time::now();
  mount.header.frame_id = "base_link";
  mount.child_frame_id = "camera_optical_frame";
  mount.transform.translation.x = x_ahead;
  mount.transform.rotation.x = -0.5;
  mount.transform.rotation.y = 0.5;
  mount.transform.rotation.z = -0.5;
  mount.transform.rotation.w = 0.5;
  return mount;
}

// A camera driver for the tests: an image topic (image_transport) and its camera_info topic, each
// advertised on its own so that the test can wait until a node's synchronised camera subscriber
// has connected to both (image_transport::CameraPublisher counts the better-connected one of the
// two: an image published before the camera_info connection is up is never answered).
class TestCamera {
 public:
  TestCamera(ros::NodeHandle nh, const std::string& image_topic, uint32_t queue_size)
      : image_(image_transport::ImageTransport(nh).advertise(image_topic, queue_size)),
        info_(nh.advertise<sensor_msgs::CameraInfo>(
            image_transport::getCameraInfoTopic(nh.resolveName(image_topic)), queue_size)) {}

  // The subscribers connected to both topics (the smaller of the two counts).
  uint32_t getNumSubscribers() const { return std::min(image_.getNumSubscribers(), info_.getNumSubscribers()); }

  void publish(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info) const {
    image_.publish(image);
    info_.publish(info);
  }

 private:
  image_transport::Publisher image_;
  ros::Publisher info_;
};

// Odometry of base_link in odom at (x, y, yaw).
inline nav_msgs::Odometry makeOdometry(const ros::Time& stamp, double x, double y, double yaw) {
  nav_msgs::Odometry odom;
  odom.header.stamp = stamp;
  odom.header.frame_id = "odom";
  odom.child_frame_id = "base_link";
  odom.pose.pose.position.x = x;
  odom.pose.pose.position.y = y;
  odom.pose.pose.orientation.z = std::sin(yaw / 2);
  odom.pose.pose.orientation.w = std::cos(yaw / 2);
  return odom;
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

// A node started by the test itself (fork/exec), so the test has its pid to kill or to wait for.
// With `capture_stderr` its standard error goes to a pipe the test reads after it exits.
class ChildProcess {
 public:
  explicit ChildProcess(const std::vector<std::string>& argv, bool capture_stderr = false) {
    int pipe_fds[2] = {-1, -1};
    if (capture_stderr && ::pipe2(pipe_fds, O_CLOEXEC) != 0) return;
    pid_ = ::fork();
    if (pid_ == 0) {
      if (capture_stderr) ::dup2(pipe_fds[1], STDERR_FILENO);
      std::vector<char*> args;
      for (const auto& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      ::execv(args[0], args.data());
      ::_exit(127);
    }
    if (capture_stderr) {
      ::close(pipe_fds[1]);
      stderr_fd_ = pipe_fds[0];
    }
  }
  ~ChildProcess() {
    if (pid_ > 0 && !exit_status_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
    if (stderr_fd_ >= 0) ::close(stderr_fd_);
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  pid_t pid() const { return pid_; }
  bool started() const { return pid_ > 0; }

  void kill(int signal) const { ::kill(pid_, signal); }

  // The exit code (or 128 + signal) once it has ended; std::nullopt when it still runs after
  // `timeout_s` (wall clock).
  std::optional<int> waitForExit(double timeout_s) {
    const ros::WallTime deadline = ros::WallTime::now() + ros::WallDuration(timeout_s);
    while (!exit_status_) {
      int status = 0;
      const pid_t done = ::waitpid(pid_, &status, WNOHANG);
      if (done == pid_) {
        exit_status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
      } else if (ros::WallTime::now() > deadline) {
        return std::nullopt;
      } else {
        ros::WallDuration(0.02).sleep();
      }
    }
    return exit_status_;
  }

  // What it wrote to standard error (after it exited; capture_stderr only).
  std::string standardError() const {
    std::string text;
    char buffer[4096];
    ssize_t n = 0;
    while (stderr_fd_ >= 0 && (n = ::read(stderr_fd_, buffer, sizeof buffer)) > 0) {
      text.append(buffer, static_cast<std::size_t>(n));
    }
    return text;
  }

 private:
  pid_t pid_ = -1;
  int stderr_fd_ = -1;
  std::optional<int> exit_status_;
};

}  // namespace test_support
}  // namespace homography_teach_repeat
