// controller_node: see include/homography_teach_repeat/ros/controller_node.h.
#include <ros/ros.h>

#include <iostream>
#include <stdexcept>

#include "homography_teach_repeat/ros/controller_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "controller_node");
  try {
    homography_teach_repeat::ControllerNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("controller_node: %s", e.what());
    std::cerr << "controller_node: " << e.what() << std::endl;  // also when rosconsole is not set up
    return 1;
  }
  return 0;
}
