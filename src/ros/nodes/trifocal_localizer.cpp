// trifocal_localizer: see include/homography_teach_repeat/ros/trifocal_localizer_node.h.
#include <ros/ros.h>

#include <iostream>
#include <stdexcept>

#include "homography_teach_repeat/ros/trifocal_localizer_node.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "trifocal_localizer");
  try {
    homography_teach_repeat::TrifocalLocalizerNode node(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::spin();
  } catch (const std::exception& e) {
    ROS_FATAL("trifocal_localizer: %s", e.what());
    std::cerr << "trifocal_localizer: " << e.what() << std::endl;  // also when rosconsole is not set up
    return 1;
  }
  return 0;
}
