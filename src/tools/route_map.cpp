// route_map: lists and edits a map of routes and plans a way through it (docs/map_format.md).
//   rosrun homography_teach_repeat route_map --help
#include <iostream>
#include <string>
#include <vector>

#include "homography_teach_repeat/network/route_map_command.h"

int main(int argc, char** argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  return homography_teach_repeat::runRouteMapCommand(args, std::cout, std::cerr);
}
