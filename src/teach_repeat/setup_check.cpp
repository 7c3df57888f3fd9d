#include "homography_teach_repeat/teach_repeat/setup_check.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {
namespace {

std::string format(const char* pattern, double a, double b = 0.0) {
  char text[256];
  std::snprintf(text, sizeof(text), pattern, a, b);
  return text;
}

void checkCamera(const SetupObservations& seen, std::vector<SetupProblem>* problems) {
  if (seen.image_stamps.empty()) {
    problems->push_back({format("no image in %.1f s", seen.duration),
                         "start the camera driver, and remap camera:= to its namespace (it must publish image_raw and "
                         "camera_info side by side: rostopic list | grep camera_info)"});
    return;
  }
  if (!seen.image_problem.empty()) {
    problems->push_back({"the images cannot be read: " + seen.image_problem,
                         "publish mono8, bgr8, rgb8 or 16-bit images (image_proc or the driver's format setting)"});
  }
  if (!seen.camera_info) {
    problems->push_back({"no camera_info beside the images",
                         "calibrate the camera (rosrun camera_calibration cameracalibrator.py) and let the driver "
                         "publish the calibration on camera_info"});
    return;
  }
  const CameraCalibration& c = *seen.camera_info;
  try {
    const PinholeCamera camera(c);
    (void)camera;
  } catch (const std::invalid_argument& e) {
    problems->push_back({std::string("camera_info is not a calibration: ") + e.what(),
                         "an all-zero K means the camera was never calibrated: run camera_calibration and store the "
                         "result where the driver loads it (camera_info_url)"});
    return;
  }
  if (seen.image_width > 0 && (seen.image_width != c.width || seen.image_height != c.height)) {
    problems->push_back({format("camera_info is %.0fx", c.width) + std::to_string(c.height) + " but the images are " +
                             std::to_string(seen.image_width) + "x" + std::to_string(seen.image_height),
                         "use the calibration of this resolution (or the driver's binning/ROI settings it was made with)"});
  }
  if (std::abs(c.fx - c.fy) > 0.1 * std::max(c.fx, c.fy)) {
    problems->push_back({format("fx %.1f and fy %.1f differ by more than 10 %%", c.fx, c.fy),
                         "square pixels are expected: recalibrate (a wrong board size gives this)", false});
  }
  if (c.cx < 0.0 || c.cx >= c.width || c.cy < 0.0 || c.cy >= c.height) {
    problems->push_back({format("the principal point (%.1f, %.1f) is outside the image", c.cx, c.cy),
                         "recalibrate: the principal point lies near the image centre"});
  }
  const double horizontal_fov = 2.0 * std::atan(c.width / (2.0 * c.fx)) * 180.0 / M_PI;
  if (horizontal_fov < 20.0 || horizontal_fov > 150.0) {
    problems->push_back({format("the horizontal field of view is %.0f deg", horizontal_fov),
                         "a focal length in pixels of the image's size is expected (20-150 deg): is fx in mm or "
                         "for another resolution?",
                         false});
  }
}

void checkRates(const SetupObservations& seen, const SetupCheckOptions& o, std::vector<SetupProblem>* problems) {
  const double image_rate = stampRate(seen.image_stamps);
  if (seen.image_stamps.size() >= 2 && image_rate < o.min_image_rate) {
    problems->push_back({format("images at %.1f Hz (at least %.1f Hz wanted)", image_rate, o.min_image_rate),
                         "raise the camera's frame rate, or look for a slow transport (compressed images over wifi: "
                         "run the nodes on the robot)"});
  }
  if (seen.odometry_stamps.empty()) {
    problems->push_back({format("no odometry in %.1f s", seen.duration),
                         "start the base driver and remap odom:= to its nav_msgs/Odometry topic"});
    return;
  }
  const double odometry_rate = stampRate(seen.odometry_stamps);
  if (seen.odometry_stamps.size() >= 2 && odometry_rate < o.min_odometry_rate) {
    problems->push_back({format("odometry at %.1f Hz (at least %.1f Hz wanted)", odometry_rate, o.min_odometry_rate),
                         "raise the base driver's odometry rate (the pose of each image is interpolated in it)"});
  }
  if (seen.non_finite_odometry > 0) {
    problems->push_back({format("%.0f odometry messages with NaN or Inf", seen.non_finite_odometry),
                         "fix the base driver: such messages are dropped"});
  }
  if (seen.odometry_covariance_zero) {
    problems->push_back({"the odometry covariance is all zero",
                         "let the base driver publish its pose and twist covariance (robot_localization reads zero "
                         "as certainty)",
                         false});
  }
  if (seen.image_stamps.empty()) return;
  const auto [odometry_first, odometry_last] = std::minmax_element(seen.odometry_stamps.begin(), seen.odometry_stamps.end());
  const auto [image_first, image_last] = std::minmax_element(seen.image_stamps.begin(), seen.image_stamps.end());
  if (*image_last < *odometry_first || *image_first > *odometry_last) {
    problems->push_back({format("the image stamps (%.3f s ...) and the odometry stamps (%.3f s ...) do not overlap",
                                *image_first, *odometry_first),
                         "the two come from different clocks: synchronize the computers (chrony), and in simulation "
                         "or with rosbag set use_sim_time"});
    return;
  }
  const double offset = *image_last - *odometry_last;
  if (std::abs(offset) > o.max_stamp_offset) {
    problems->push_back({format("the newest image is %.3f s", std::abs(offset)) +
                             (offset > 0.0 ? " ahead of" : " behind") + " the newest odometry",
                         "check the clocks of the camera and the base computers, and the drivers' stamps (the "
                         "driver should stamp at capture, not at publication)",
                         std::abs(offset) > 1.0});
  }
}

void checkMount(const SetupObservations& seen, const SetupCheckOptions& o, std::vector<SetupProblem>* problems) {
  if (!seen.camera_mount) {
    problems->push_back({"no tf from base_link to the camera's optical frame" +
                             (seen.camera_mount_problem.empty() ? std::string() : ": " + seen.camera_mount_problem),
                         "publish it (robot_state_publisher with the URDF, or static_transform_publisher base_link "
                         "<camera>_optical_frame with the optical frame's axes: z forward, x right, y down)"});
    return;
  }
  const double tilt = CameraMount::tiltOf(*seen.camera_mount);
  if (!std::isfinite(tilt)) {
    problems->push_back({"the tf base_link -> camera is not a rotation (NaN or not orthonormal)", "fix the URDF or the static transform"});
    return;
  }
  if (tilt > o.max_tilt) {
    const double elevation = CameraMount::elevationOf(*seen.camera_mount);
    problems->push_back({format("the camera is %.1f deg from level (its axis %.1f deg ", tilt * 180.0 / M_PI,
                                std::abs(elevation) * 180.0 / M_PI) +
                             (elevation < 0.0 ? "down)" : "up)"),
                         "level the camera (the planar pose assumes it), or if that is how it sits, teach with "
                         "estimate_keyframe_tilt (auto, the default, estimates it where the teach run measures the "
                         "body's tilt) and repeat with the tilt nuisance (docs/evaluation.md, KITTI 07)",
                         tilt > 0.3});
  }
}

void checkView(const SetupObservations& seen, const SetupCheckOptions& o, std::vector<SetupProblem>* problems) {
  if (seen.features && *seen.features < o.min_features) {
    problems->push_back({format("%.0f features in the current view (at least %.0f wanted)", *seen.features, o.min_features),
                         "point the camera at textured walls, add light, or check the focus; a blank wall gives no pose",
                         false});
  }
  if (seen.vertical_lines && *seen.vertical_lines < o.min_vertical_lines) {
    problems->push_back({format("%.0f vertical lines in the current view (at least %.0f wanted for mu)",
                                *seen.vertical_lines, o.min_vertical_lines),
                         "mu and hybrid mode need door frames, shelves, pillars in view; fast_hd does not", false});
  }
  if (seen.shift_features && *seen.shift_features < o.min_shift_features) {
    problems->push_back({format("%.0f features for the seasonal heading fix in the current view (at least %.0f wanted)",
                                *seen.shift_features, o.min_shift_features),
                         "hybrid mode's heading fix across seasons matches upright AKAZE and BRIEF corners: point the "
                         "camera at textured scenery (facades, trees, fences) rather than sky or road",
                         false});
  }
}

}  // namespace

double stampRate(const std::vector<double>& stamps) {
  if (stamps.size() < 2) return 0.0;
  const auto [first, last] = std::minmax_element(stamps.begin(), stamps.end());
  const double span = *last - *first;
  return span > 0.0 ? static_cast<double>(stamps.size() - 1) / span : 0.0;
}

std::vector<SetupProblem> checkSetup(const SetupObservations& seen, const SetupCheckOptions& options) {
  std::vector<SetupProblem> problems;
  checkCamera(seen, &problems);
  checkRates(seen, options, &problems);
  checkMount(seen, options, &problems);
  checkView(seen, options, &problems);
  return problems;
}

}  // namespace homography_teach_repeat
