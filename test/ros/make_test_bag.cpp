// Records a short synthetic repeat run to a bag: the camera (images of the synthetic wall of the
// core tests and camera_info), wheel odometry and the ground truth, along a path 6 cm beside the
// taught one (test/support/synthetic_route.h). The rostest repeat_node_bag plays it back through
// repeat_node with `rosbag play`. With --tf, the camera mount (base_link -> camera_optical_frame,
// the camera at the base, level) goes to /tf_static too, and --frames N records N frames
// (evaluate_sequence's end-to-end test teaches and repeats from it). --compressed jpeg|png records
// sensor_msgs/CompressedImage on camera/image_raw/compressed instead (as a camera driver publishes
// it), and --corrupt-frame K cuts frame K's JPEG/PNG short (a frame the readers must skip).
// --teach records the taught path instead (16 images 10 cm apart, as make_test_route teaches it
// without ROS, odometry = ground truth): the teach run of teach_repeat_compressed_bag.test.
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>
#include <sensor_msgs/CompressedImage.h>
#include <tf2_msgs/TFMessage.h>

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <string>
#include <vector>

#include "synthetic_camera.h"

using namespace homography_teach_repeat;

namespace {

nav_msgs::Odometry odometryMessage(const Pose2D& pose, const ros::Time& stamp, const std::string& frame) {
  nav_msgs::Odometry odometry;
  odometry.header.stamp = stamp;
  odometry.header.frame_id = frame;
  odometry.child_frame_id = "base_link";
  odometry.pose.pose.position.x = pose.x;
  odometry.pose.pose.position.y = pose.y;
  odometry.pose.pose.orientation.z = std::sin(pose.yaw / 2.0);
  odometry.pose.pose.orientation.w = std::cos(pose.yaw / 2.0);
  return odometry;
}

}  // namespace

int main(int argc, char** argv) {
  bool with_tf = false;
  bool teach = false;
  int frames = 10;
  std::string compression;  // "", "jpeg" or "png"
  int corrupt_frame = -1;
  std::string path;
  for (int i = 1; i < argc; ++i) {
    const std::string argument = argv[i];
    if (argument == "--tf") {
      with_tf = true;
    } else if (argument == "--teach") {
      teach = true;
      frames = 16;
    } else if (argument == "--frames" && i + 1 < argc) {
      frames = std::atoi(argv[++i]);
    } else if (argument == "--compressed" && i + 1 < argc) {
      compression = argv[++i];
    } else if (argument == "--corrupt-frame" && i + 1 < argc) {
      corrupt_frame = std::atoi(argv[++i]);
    } else {
      path = argument;
    }
  }
  if (path.empty() || frames < 2 || (compression != "" && compression != "jpeg" && compression != "png") ||
      (corrupt_frame >= 0 && compression.empty())) {
    std::cerr << "usage: make_test_bag FILE.bag [--tf] [--teach | --frames N >= 2] [--compressed jpeg|png [--corrupt-frame K]]\n";
    return 2;
  }
  try {
    ros::Time::init();
    const test_support::SyntheticWall wall;
    rosbag::Bag bag(path, rosbag::bagmode::Write);
    if (with_tf) {
      // The optical frame (x right, y down, z forward) at base_link: x_opt = -y, y_opt = -z, z_opt = x.
      geometry_msgs::TransformStamped mount;
      mount.header.stamp = ros::Time(1000.0);
      mount.header.frame_id = "base_link";
      mount.child_frame_id = "camera_optical_frame";
      mount.transform.rotation.x = -0.5;
      mount.transform.rotation.y = 0.5;
      mount.transform.rotation.z = -0.5;
      mount.transform.rotation.w = 0.5;
      tf2_msgs::TFMessage message;
      message.transforms.push_back(mount);
      bag.write("/tf_static", mount.header.stamp, message);
    }
    for (int i = 0; i < frames; ++i) {
      // Metres along the taught path; the repeat runs 6 cm beside it, turned 0.03 rad.
      const double s = teach ? 0.1 * i : 0.05 + 1.1 / frames * i;
      const PlanarPose camera_pose = teach ? PlanarPose(0.08 * s, s, 0.04 * s) : PlanarPose(0.08 * s + 0.06, s, 0.04 * s + 0.03);
      const Pose2D truth = cameraAxesToRep103(camera_pose);
      const ros::Time stamp(1000.0 + 0.5 * i);  // 2 Hz
      // Odometry at 20 Hz around each image (a drifting odometry would do as well: repeat_node
      // uses it only for the map -> odom tf in fast_hd mode).
      for (int k = -5; k < 5; ++k) {
        const ros::Time t = stamp + ros::Duration(0.05 * k);
        bag.write("odom", t, odometryMessage(truth, t, "odom"));
      }
      bag.write("ground_truth", stamp, odometryMessage(truth, stamp, "map"));
      auto image = test_support::makeImage(wall.imageAt(camera_pose), "mono8");
      image->header.stamp = stamp;
      image->header.frame_id = "camera_optical_frame";
      sensor_msgs::CameraInfo info = test_support::syntheticCameraInfo();
      info.header = image->header;
      if (compression.empty()) {
        bag.write("camera/image_raw", stamp, *image);
      } else {
        sensor_msgs::CompressedImage compressed;
        compressed.header = image->header;
        compressed.format = "mono8; " + compression + " compressed mono8";
        const cv::Mat pixels(static_cast<int>(image->height), static_cast<int>(image->width), CV_8UC1, image->data.data(),
                             image->step);
        const std::vector<int> quality{cv::IMWRITE_JPEG_QUALITY, 95};
        if (!cv::imencode(compression == "jpeg" ? ".jpg" : ".png", pixels, compressed.data,
                          compression == "jpeg" ? quality : std::vector<int>{})) {
          throw std::runtime_error("cannot encode frame " + std::to_string(i));
        }
        if (i == corrupt_frame) compressed.data.resize(compressed.data.size() / 2);
        bag.write("camera/image_raw/compressed", stamp, compressed);
      }
      bag.write("camera/camera_info", stamp, info);
    }
    bag.close();
    std::cout << "bag written to " << path << " (" << frames << " frames"
              << (compression.empty() ? "" : ", " + compression + " compressed") << ")\n";
  } catch (const std::exception& e) {
    std::cerr << "make_test_bag: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
