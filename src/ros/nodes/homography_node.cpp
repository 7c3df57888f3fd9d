// Registers camera frames against a reference image (see ros/homography_node.h).
#include <ros/ros.h>

#include <stdexcept>

#include "homography_teach_repeat/ros/homography_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "homography_node");
  try {
    homography_teach_repeat::HomographyNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("homography_node: %s", e.what());
    return 1;
  }
  return 0;
}
