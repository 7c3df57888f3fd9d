// libFuzzer target: the world-file loader (planar_world_sim's YAML) on arbitrary contents; a
// world that loads is also ray cast (the LaserScan path). Statuses only: no crash, hang or
// out-of-bounds read.
#include "fuzz_support.h"
#include "homography_teach_repeat/sim/planar_world.h"

namespace htr = homography_teach_repeat;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const std::string path = htr_fuzz::scratchDirectory() + "/world.yaml";
  htr_fuzz::writeFile(path, data, size);
  const auto world = htr::loadPlanarWorld(path);
  if (world) {
    for (int k = 0; k < 8; ++k) {
      const double angle = k * M_PI / 4.0;
      (void)htr::castRay(*world, Eigen::Vector2d(1.0, 1.0), Eigen::Vector2d(std::cos(angle), std::sin(angle)));
    }
  }
  return 0;
}
