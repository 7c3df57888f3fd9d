// Records a short synthetic repeat run to a bag: the camera (images of the synthetic wall of the
// core tests and camera_info), wheel odometry and the ground truth, along a path 6 cm beside the
// taught one (test/support/synthetic_route.h). The rostest repeat_node_bag plays it back through
// repeat_node with `rosbag play`.
#include <nav_msgs/Odometry.h>
#include <rosbag/bag.h>

#include <cmath>
#include <iostream>
#include <stdexcept>
#include <string>

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
  if (argc != 2) {
    std::cerr << "usage: make_test_bag FILE.bag\n";
    return 2;
  }
  try {
    ros::Time::init();
    const test_support::SyntheticWall wall;
    rosbag::Bag bag(argv[1], rosbag::bagmode::Write);
    const int frames = 10;
    for (int i = 0; i < frames; ++i) {
      const double s = 0.05 + 0.11 * i;  // metres along the taught path
      const PlanarPose camera_pose(0.08 * s + 0.06, s, 0.04 * s + 0.03);
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
      bag.write("camera/image_raw", stamp, *image);
      bag.write("camera/camera_info", stamp, info);
    }
    bag.close();
    std::cout << "bag written to " << argv[1] << " (" << frames << " frames)\n";
  } catch (const std::exception& e) {
    std::cerr << "make_test_bag: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
