// planar_world_sim: see include/homography_teach_repeat/sim/ros/planar_world_sim.h.
#include <ros/ros.h>

#include <iostream>
#include <stdexcept>
#include <string>

#include "homography_teach_repeat/sim/ros/planar_world_sim.h"

int main(int argc, char** argv) {
  // planar_world_sim --check WORLD.yaml: validate a world file without ROS (exit code 0 / 1).
  if (argc == 3 && std::string(argv[1]) == "--check") {
    const auto world = homography_teach_repeat::loadPlanarWorld(argv[2]);
    if (!world) {
      std::cerr << "planar_world_sim: " << world.status().message() << std::endl;
      return 1;
    }
    std::cout << "world '" << argv[2] << "': " << world->walls.size() << " walls, " << world->clutter.size()
              << " clutter boxes, " << world->people.size() << " people, valid" << std::endl;
    return 0;
  }
  ros::init(argc, argv, "planar_world_sim");
  try {
    homography_teach_repeat::PlanarWorldSim sim(ros::NodeHandle(), ros::NodeHandle("~"));
    ros::AsyncSpinner spinner(1);  // cmd_vel while run() owns this thread
    spinner.start();
    sim.run();
  } catch (const std::exception& e) {
    ROS_FATAL("planar_world_sim: %s", e.what());
    std::cerr << "planar_world_sim: " << e.what() << std::endl;
    return 1;
  }
  return 0;
}
