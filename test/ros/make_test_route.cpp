// Writes the synthetic taught route of the core tests (test/support/synthetic_route.h) to the
// directory given as argument: the fixture of the repeat_node rostest.
#include <iostream>
#include <stdexcept>

#include "support/synthetic_route.h"

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: make_test_route DIRECTORY\n";
    return 2;
  }
  try {
    const homography_teach_repeat::test_support::SyntheticWall wall;
    const std::string dir = homography_teach_repeat::test_support::teachSyntheticRoute(
        wall, homography_teach_repeat::FeatureType::kAkaze, 16, argv[1]);
    std::cout << "route written to " << dir << "\n";
  } catch (const std::exception& e) {
    std::cerr << "make_test_route: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
