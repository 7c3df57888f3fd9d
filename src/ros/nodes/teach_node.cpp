// teach_node: see include/homography_teach_repeat/ros/teach_node.h.
#include <ros/ros.h>

#include <iostream>
#include <stdexcept>

#include "homography_teach_repeat/ros/teach_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "teach_node");
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  try {
    homography_teach_repeat::TeachNode node(nh, private_nh);
    ros::AsyncSpinner spinner(2);  // the ~finish service must not wait behind image processing
    spinner.start();
    ros::waitForShutdown();
  } catch (const std::runtime_error& e) {
    ROS_FATAL("teach_node: %s", e.what());
    std::cerr << "teach_node: " << e.what() << std::endl;  // also when rosconsole is not set up
    return 1;
  }
  return 0;
}
