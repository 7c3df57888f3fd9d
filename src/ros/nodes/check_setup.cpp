// check_setup: before a robot teaches, is its set-up one teach and repeat can work with? Listens
// for `duration` seconds to the camera (image_transport camera: camera/image_raw +
// camera/camera_info), the odometry (odom) and the tf base_frame -> the camera's frame, extracts
// the features (feature_type), vertical lines and seasonal-fix features of the last image, and hands what it saw to the
// ROS-free checkSetup (teach_repeat/setup_check.h). Prints every problem with how to fix it,
// publishes the report on ~report (std_msgs/String, latched) and /diagnostics, and exits 0 when
// nothing blocks teaching, 1 otherwise (2: bad parameters).
//   rosrun homography_teach_repeat check_setup camera:=/camera [_duration:=5] [_base_frame:=base_link]
// The window starts at the first image (a check_setup started beside the drivers waits for the
// camera, commonly the last to come up), at the latest after startup_wait seconds.
// Parameters (private): duration [s] 5, startup_wait [s] 10, base_frame base_link, camera_frame (default: camera_info's
// frame_id), feature_type sift, min_image_rate 5, min_odometry_rate 10, max_stamp_offset 0.2,
// max_tilt 0.035 rad, min_features 300, min_vertical_lines 10, min_shift_features 200, line_min_length_px 0 (5.2 % of the image height),
// image_transport raw (or compressed: camera/image_raw/compressed, JPEG or PNG).
#include <diagnostic_msgs/DiagnosticArray.h>
#include <image_transport/image_transport.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_msgs/String.h>
#include <tf2_ros/transform_listener.h>

#include <atomic>
#include <cmath>
#include <iostream>
#include <mutex>
#include <sstream>
#include <stdexcept>

#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/vertical_lines.h"
#include "homography_teach_repeat/mu/shift_heading.h"
#include "homography_teach_repeat/ros/camera_subscription.h"
#include "homography_teach_repeat/ros/compressed_image.h"
#include "homography_teach_repeat/ros/conversions.h"
#include "homography_teach_repeat/ros/parameters.h"
#include "homography_teach_repeat/teach_repeat/setup_check.h"

namespace htr = homography_teach_repeat;

namespace {

struct Settings {
  double duration = 5.0;
  double startup_wait = 10.0;
  std::string base_frame = "base_link", camera_frame;
  htr::FeatureType feature_type = htr::FeatureType::kSift;
  htr::SetupCheckOptions check;
  htr::VerticalLineOptions lines;
  std::string image_transport = "raw";
};

const char* const kUsage =
    "usage: rosrun homography_teach_repeat check_setup [camera:=/camera] [_duration:=5] [_base_frame:=base_link]\n"
    "         [_image_transport:=raw|compressed] [_feature_type:=sift] [_camera_frame:=FRAME]\n"
    "         [_startup_wait:=10]\n"
    "Listens for `duration` seconds to CAMERA/image_raw (or CAMERA/image_raw/compressed), CAMERA/camera_info, odom\n"
    "and the tf base_frame -> camera, and says whether teach and repeat can work with what it saw:\n"
    "each problem with how to fix it. The listening starts at the first image (or undecodable compressed image),\n"
    "at the latest after `startup_wait` seconds (drivers started beside check_setup get the time to come up).\n"
    "Exit 0: ready to teach; 1: a problem blocks teaching; 2: bad parameters.\n"
    "Other parameters: min_image_rate 5, min_odometry_rate 10, max_stamp_offset 0.2 s, max_tilt 0.035 rad,\n"
    "min_features 300, min_vertical_lines 10, min_shift_features 200, line_min_length_px 0: 5.2 % of the image height (docs/using.md).\n";

Settings readSettings(const ros::NodeHandle& p) {
  Settings s;
  htr::readParameters(p, [&] {
    s.duration = htr::readParameter(p, "duration", s.duration);
    if (!(s.duration > 0.5) || !std::isfinite(s.duration)) throw std::invalid_argument("duration must be > 0.5 s");
    s.startup_wait = htr::readParameter(p, "startup_wait", s.startup_wait);
    if (!(s.startup_wait >= 0.0) || !std::isfinite(s.startup_wait)) {
      throw std::invalid_argument("startup_wait must be >= 0 s");
    }
    s.base_frame = htr::readParameter<std::string>(p, "base_frame", s.base_frame);
    s.camera_frame = htr::readParameter<std::string>(p, "camera_frame", "");
    s.feature_type = htr::featureTypeFromString(htr::readParameter<std::string>(p, "feature_type", "sift"));
    htr::SetupCheckOptions& c = s.check;
    c.min_image_rate = htr::readParameter(p, "min_image_rate", c.min_image_rate);
    c.min_odometry_rate = htr::readParameter(p, "min_odometry_rate", c.min_odometry_rate);
    c.max_stamp_offset = htr::readParameter(p, "max_stamp_offset", c.max_stamp_offset);
    c.max_tilt = htr::readParameter(p, "max_tilt", c.max_tilt);
    c.min_features = htr::readParameter(p, "min_features", c.min_features);
    c.min_vertical_lines = htr::readParameter(p, "min_vertical_lines", c.min_vertical_lines);
    c.min_shift_features = htr::readParameter(p, "min_shift_features", c.min_shift_features);
    s.lines.min_length_px = htr::readParameter(p, "line_min_length_px", s.lines.min_length_px);
    s.image_transport = htr::readImageTransport(p);
    s.lines.validate();
  });
  return s;
}

}  // namespace

int main(int argc, char** argv) {
  for (int i = 1; i < argc; ++i) {
    const std::string argument = argv[i];
    if (argument == "--help" || argument == "-h") {
      std::cout << kUsage;
      return 0;
    }
  }
  ros::init(argc, argv, "check_setup");
  ros::NodeHandle nh, private_nh("~");
  Settings settings;
  try {
    settings = readSettings(private_nh);
  } catch (const std::exception& e) {
    std::cerr << "check_setup: " << e.what() << std::endl;
    return 2;
  }
  std::mutex mutex;
  std::atomic<bool> image_heard{false};
  htr::SetupObservations seen;
  sensor_msgs::ImageConstPtr last_image;
  std::string camera_frame = settings.camera_frame;
  // Images and camera_info apart (a missing camera_info must be seen as such, not as no images).
  const auto on_image = [&](const sensor_msgs::ImageConstPtr& image) {
    image_heard = true;
    std::lock_guard<std::mutex> lock(mutex);
    seen.image_stamps.push_back(image->header.stamp.toSec());
    seen.image_width = static_cast<int>(image->width);
    seen.image_height = static_cast<int>(image->height);
    last_image = image;
    if (camera_frame.empty()) camera_frame = image->header.frame_id;
  };
  image_transport::ImageTransport transport(nh);
  image_transport::Subscriber raw_sub;
  ros::Subscriber compressed_sub;
  std::size_t undecodable = 0;
  std::string decode_error;
  if (settings.image_transport == "raw") {
    raw_sub = transport.subscribe("camera/image_raw", 5, on_image, ros::VoidPtr(), image_transport::TransportHints("raw"));
  } else {
    compressed_sub = nh.subscribe<sensor_msgs::CompressedImage>(
        nh.resolveName("camera/image_raw") + "/compressed", 5, [&](const sensor_msgs::CompressedImageConstPtr& compressed) {
          auto image = htr::ros_conversions::decompress(*compressed);
          if (image) {
            on_image(*image);
            return;
          }
          ROS_WARN_THROTTLE(2.0, "check_setup: %s", image.status().message().c_str());
          image_heard = true;
          std::lock_guard<std::mutex> lock(mutex);
          ++undecodable;
          decode_error = image.status().message();
        });
  }
  const std::string image_topic = raw_sub ? raw_sub.getTopic() : compressed_sub.getTopic();
  ros::Subscriber info_sub = nh.subscribe<sensor_msgs::CameraInfo>("camera/camera_info", 5, [&](const auto& info) {
    std::lock_guard<std::mutex> lock(mutex);
    seen.camera_info = htr::ros_conversions::toCalibration(*info);
    if (!info->header.frame_id.empty()) camera_frame = info->header.frame_id;
  });
  bool covariance_seen = false;
  ros::Subscriber odometry_sub = nh.subscribe<nav_msgs::Odometry>("odom", 100, [&](const auto& odom) {
    std::lock_guard<std::mutex> lock(mutex);
    if (!htr::ros_conversions::toPose2D(odom->pose.pose)) {
      ++seen.non_finite_odometry;
      return;
    }
    seen.odometry_stamps.push_back(odom->header.stamp.toSec());
    for (const double v : odom->pose.covariance) covariance_seen = covariance_seen || v != 0.0;
  });
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener(tf_buffer);
  ros::Publisher report_pub = private_nh.advertise<std_msgs::String>("report", 1, /*latch=*/true);
  ros::Publisher diagnostics_pub = nh.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", 1, true);

  ROS_INFO("check_setup: listening for %.1f s to %s, %s, %s and the tf %s -> camera", settings.duration,
           image_topic.c_str(), info_sub.getTopic().c_str(), odometry_sub.getTopic().c_str(),
           settings.base_frame.c_str());
  ros::AsyncSpinner spinner(1);
  spinner.start();
  // Wall time: a simulated clock may not have started.
  const ros::WallTime wait_start = ros::WallTime::now();
  while (ros::ok() && !image_heard && (ros::WallTime::now() - wait_start).toSec() < settings.startup_wait) {
    ros::WallDuration(0.05).sleep();
  }
  const ros::WallTime wall_start = ros::WallTime::now();
  while (ros::ok() && (ros::WallTime::now() - wall_start).toSec() < settings.duration) ros::WallDuration(0.05).sleep();
  spinner.stop();
  if (!ros::ok()) return 1;

  std::lock_guard<std::mutex> lock(mutex);
  seen.duration = settings.duration;
  seen.odometry_covariance_zero = !seen.odometry_stamps.empty() && !covariance_seen;
  if (camera_frame.empty()) {
    seen.camera_mount_problem = "no camera frame known (no camera_info or image with a frame_id)";
  } else {
    try {
      const auto mount = tf_buffer.lookupTransform(settings.base_frame, camera_frame, ros::Time(0), ros::Duration(0.5));
      seen.camera_mount = htr::ros_conversions::toIsometry(mount.transform);
    } catch (const tf2::TransformException& e) {
      seen.camera_mount_problem = std::string(settings.base_frame + " -> " + camera_frame + ": ") + e.what();
    }
  }
  if (last_image) {
    const auto image = htr::ros_conversions::toCvImage(last_image);
    if (!image) {
      seen.image_problem = image.status().message();
    } else {
      try {
        htr::FeatureExtractor extractor(htr::FeatureOptions{settings.feature_type, 5000});
        const auto features = extractor.extract(*image);
        if (features) seen.features = static_cast<int>(features->keypoints.size());
        htr::VerticalLineExtractor line_extractor(settings.lines);
        const auto lines = line_extractor.extract(*image);
        if (lines) seen.vertical_lines = static_cast<int>(lines->size());
        htr::ShiftHeading shift_heading;
        const auto shift_features = shift_heading.describe(*image);
        if (shift_features) {
          int count = 0;
          for (const auto& set : shift_features->sets) count += static_cast<int>(set.keypoints.size());
          seen.shift_features = count;
        }
      } catch (const std::invalid_argument& e) {
        seen.image_problem = e.what();
      }
    }
  }
  if (undecodable > 0 && seen.image_problem.empty()) {
    seen.image_problem = std::to_string(undecodable) + " compressed image(s) on " + image_topic +
                         " could not be decoded (the last: " + decode_error + ")";
  }
  const auto problems = htr::checkSetup(seen, settings.check);
  bool blocking = false;
  std::ostringstream report;
  report << "check_setup: " << seen.image_stamps.size() << " images (" << htr::stampRate(seen.image_stamps) << " Hz), "
         << seen.odometry_stamps.size() << " odometry messages (" << htr::stampRate(seen.odometry_stamps) << " Hz)";
  if (seen.features) report << ", " << *seen.features << " features";
  if (seen.vertical_lines) report << ", " << *seen.vertical_lines << " vertical lines";
  if (seen.shift_features) report << ", " << *seen.shift_features << " seasonal-fix features";
  report << " in " << settings.duration << " s\n";
  for (const auto& p : problems) {
    blocking = blocking || p.blocking;
    report << (p.blocking ? "PROBLEM: " : "warning: ") << p.what << "\n    fix: " << p.how_to_fix << "\n";
  }
  report << (problems.empty() ? "OK: ready to teach" : blocking ? "NOT READY: fix the problems above" : "ready to teach, with the warnings above")
         << "\n";
  std::cout << report.str() << std::flush;
  std_msgs::String message;
  message.data = report.str();
  report_pub.publish(message);
  diagnostic_msgs::DiagnosticArray diagnostics;
  diagnostics.header.stamp = ros::Time::now();
  diagnostic_msgs::DiagnosticStatus status;
  status.name = "check_setup";
  status.hardware_id = "check_setup";
  status.level = blocking ? diagnostic_msgs::DiagnosticStatus::ERROR
                          : problems.empty() ? diagnostic_msgs::DiagnosticStatus::OK : diagnostic_msgs::DiagnosticStatus::WARN;
  status.message = problems.empty() ? "ready to teach" : problems.front().what;
  for (const auto& p : problems) {
    diagnostic_msgs::KeyValue value;
    value.key = p.what;
    value.value = p.how_to_fix;
    status.values.push_back(value);
  }
  diagnostics.status.push_back(status);
  diagnostics_pub.publish(diagnostics);
  ros::WallDuration(0.5).sleep();  // let latched subscribers connect
  return blocking ? 1 : 0;
}
