#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {

std::runtime_error invalidParameter(const ros::NodeHandle& nh, const std::string& what) {
  return std::runtime_error("invalid parameter in " + nh.getNamespace() + ": " + what);
}

}  // namespace homography_teach_repeat
