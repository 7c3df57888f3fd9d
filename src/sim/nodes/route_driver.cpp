// route_driver: see include/homography_teach_repeat/sim/ros/route_driver.h.
#include <ros/ros.h>

#include <iostream>
#include <stdexcept>

#include "homography_teach_repeat/sim/ros/route_driver.h"

int main(int argc, char** argv) {
  ros::init(argc, argv, "route_driver");
  try {
    homography_teach_repeat::RouteDriver driver(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::AsyncSpinner spinner(2);  // the finish service call must not block odometry
    spinner.start();
    ros::waitForShutdown();
  } catch (const std::exception& e) {
    ROS_FATAL("route_driver: %s", e.what());
    std::cerr << "route_driver: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
