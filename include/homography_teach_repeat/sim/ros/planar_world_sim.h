// planar_world_sim: a camera, a laser scanner and a differential base in a PlanarWorld (walls
// with photographs as textures). A thin wrapper over WorldRenderer and DifferentialDriveSim (core).
// It owns the simulated time: it steps the physics at `physics_rate`, publishes /clock (run the
// other nodes with use_sim_time), and paces itself to `real_time_factor` times real time.
//
// Subscribes: cmd_vel (geometry_msgs/Twist; older than cmd_vel_timeout [sim s]: zero)
// Publishes:  camera/image_raw + camera/camera_info (bgr8, at camera_rate), odom
//             (nav_msgs/Odometry with the odometry error model, frame odom -> base_link),
//             ground_truth (nav_msgs/Odometry, frame world -> base_link), scan
//             (sensor_msgs/LaserScan, at scan_rate, when scan_count > 0), /clock, people
//             (visualization_msgs/MarkerArray in the world frame, where `people` is on);
//             tf odom -> base_link, base_link -> camera_optical_frame (the camera mount), and the
//             ground truth world -> ground_truth/base_link
// Parameters: see config/planar_world_sim.yaml
#pragma once

#include <geometry_msgs/TransformStamped.h>
#include <geometry_msgs/Twist.h>
#include <nav_msgs/Odometry.h>
#include <image_transport/image_transport.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/Image.h>
#include <tf2_ros/static_transform_broadcaster.h>
#include <tf2_ros/transform_broadcaster.h>

#include <atomic>
#include <deque>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "homography_teach_repeat/sim/differential_drive.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/sim/world_renderer.h"

namespace homography_teach_repeat {

class PlanarWorldSim {
 public:
  // Throws std::runtime_error naming the parameter or the world file on any problem.
  PlanarWorldSim(const ros::NodeHandle& nh, const ros::NodeHandle& private_nh);
  ~PlanarWorldSim();

  // Runs the simulation loop until ros::ok() is false (call from main, callbacks need a spinner).
  void run();

 private:
  void onCommand(const geometry_msgs::TwistConstPtr& command);
  void publishState(const ros::Time& stamp);
  void publishCamera(const ros::Time& stamp, double sim_seconds);
  void publishScan(const ros::Time& stamp);
  void publishPeople(const ros::Time& stamp);
  // The world now: the walls, the clutter if on, the people where they stand.
  PlanarWorld scene() const;
  // Publishes the odometry messages whose delivery time has come (jitter), oldest first.
  void deliverOdometry(double sim_seconds);
  // Publishes the images whose delivery time has come (latency), oldest first.
  void deliverImages(double sim_seconds);

  ros::NodeHandle nh_;
  ros::NodeHandle private_nh_;
  PlanarWorld world_;
  std::optional<WorldRenderer> renderer_;
  std::optional<Crowd> crowd_;  // the world's people, when `people` is on
  std::optional<DifferentialDriveSim> robot_;
  cv::RNG rng_;
  double physics_rate_ = 100.0;
  double camera_rate_ = 10.0;
  double scan_rate_ = 10.0;
  double real_time_factor_ = 1.0;
  double cmd_vel_timeout_ = 0.5;
  double camera_mount_x_ = 0.2;
  double camera_height_ = 0.5;
  double start_time_ = 1.0;
  // A kidnapping (integrity tests): at kidnap_time_ [sim s] the robot is moved by kidnap_offset_
  // (base frame) without its odometry noticing; kidnap_time_ <= 0: never.
  double kidnap_time_ = -1.0;
  Pose2D kidnap_offset_;
  bool kidnapped_ = false;
  // The world as a real camera sees it (docs/simulator.md): overall light level (gain), images
  // delivered latency_min_..latency_max_ [s] after they were taken (stamped when taken), a fraction
  // of them never delivered.
  double light_level_ = 1.0;
  double latency_min_ = 0.0, latency_max_ = 0.0;
  double drop_probability_ = 0.0;
  struct PendingImage {
    double deliver_at;  // [simulated s]
    sensor_msgs::ImagePtr image;
    sensor_msgs::CameraInfo info;
  };
  std::deque<PendingImage> pending_images_;
  // Odometry at its own rate, each message (stamped when measured) delivered up to
  // odometry_jitter_ [s] late, in order.
  double odometry_rate_ = 50.0;
  double odometry_jitter_ = 0.0;
  struct PendingOdometry {
    double deliver_at;  // [simulated s]
    nav_msgs::Odometry message;
    geometry_msgs::TransformStamped transform;  // odom -> base_link, with it
  };
  std::deque<PendingOdometry> pending_odometry_;
  sensor_msgs::CameraInfo camera_info_;  // the calibration published with every image
  double truth_yaw_rate_ = 0.0;  // [rad/s] over the last state interval (motion blur)
  int scan_count_ = 0;
  double scan_angle_min_ = -M_PI / 2, scan_angle_max_ = M_PI / 2, scan_range_max_ = 8.0;
  std::string odom_frame_, base_frame_, camera_frame_, world_frame_, ground_truth_prefix_;

  OdometryErrorModel odometry_errors_;
  double odometry_variance_floor_ = 1e-6;  // added to every planar variance of odom [m², rad², (m/s)², (rad/s)²]
  static constexpr double kUnobservedVariance = 1e6;  // z, roll, pitch and their rates
  struct StateSample {
    Pose2D odometry, truth;
    ros::Time stamp;
  };
  std::optional<StateSample> last_state_;  // at the last state message, for the twist


  std::mutex command_mutex_;
  double command_v_ = 0.0, command_w_ = 0.0;
  double command_stamp_ = -1.0;          // [simulated s] of the last cmd_vel
  std::atomic<double> sim_seconds_{0.0};  // current simulated time

  ros::Subscriber command_subscriber_;
  image_transport::ImageTransport image_transport_;
  image_transport::CameraPublisher camera_publisher_;
  ros::Publisher odometry_publisher_;
  ros::Publisher ground_truth_publisher_;
  ros::Publisher scan_publisher_;
  ros::Publisher clock_publisher_;
  ros::Publisher people_publisher_;
  tf2_ros::TransformBroadcaster tf_broadcaster_;
  tf2_ros::StaticTransformBroadcaster static_broadcaster_;
};

}  // namespace homography_teach_repeat
