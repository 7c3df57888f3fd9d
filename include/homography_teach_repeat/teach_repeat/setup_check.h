// Before a robot teaches: is its set-up one the teach and repeat runs can work with? check_setup
// (src/ros/nodes/check_setup.cpp) listens to the robot's topics for a few seconds and hands what it
// saw to checkSetup, which names every problem with how to fix it (docs/using.md, "Before
// teaching"). ROS-free: the node only collects.
#pragma once

#include <Eigen/Geometry>

#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/geometry/pinhole_camera.h"

namespace homography_teach_repeat {

struct SetupObservations {
  double duration = 0.0;                       // [s] listened
  std::vector<double> image_stamps;            // header stamps, in arrival order
  std::optional<CameraCalibration> camera_info;  // the last one received
  int image_width = 0, image_height = 0;       // of the last image
  std::string image_problem;                   // the image could not be converted (encoding)
  std::vector<double> odometry_stamps;
  int non_finite_odometry = 0;                 // odometry messages with NaN/Inf
  bool odometry_covariance_zero = false;       // every odometry covariance all zero
  std::optional<Eigen::Isometry3d> camera_mount;  // tf base_link -> camera optical frame
  std::string camera_mount_problem;             // why there is none (tf's message)
  std::optional<int> features;                 // in the last image (the route's feature type)
  std::optional<int> vertical_lines;           // in the last image
  // in the last image: the seasonal heading fix's features (upright AKAZE + BRIEF, ShiftHeading)
  std::optional<int> shift_features;
};

struct SetupCheckOptions {
  double min_image_rate = 5.0;      // [Hz]
  double min_odometry_rate = 10.0;  // [Hz]
  double max_stamp_offset = 0.2;    // [s] between the newest image and the newest odometry stamp
  double max_tilt = 0.035;          // [rad] (2°) of the camera from level
  int min_features = 300;
  int min_vertical_lines = 10;
  int min_shift_features = 200;  // of the seasonal heading fix (both types together)
};

struct SetupProblem {
  std::string what;        // what is wrong, with the measured figure
  std::string how_to_fix;  // what to do about it
  bool blocking = true;    // false: teaching works, but worse (a warning)
};

// Every problem found, in the order of the checks: camera_info (present, calibrated, consistent
// with the images), image and odometry rates, stamps of images and odometry overlapping, odometry
// values and covariance, the camera mount (tf present, level), features, vertical lines and the
// seasonal heading fix's features in view. Empty: the set-up is fine.
std::vector<SetupProblem> checkSetup(const SetupObservations& seen, const SetupCheckOptions& options = {});

// The rate [Hz] of stamps (their count − 1 over their span); 0 for fewer than two.
double stampRate(const std::vector<double>& stamps);

}  // namespace homography_teach_repeat
