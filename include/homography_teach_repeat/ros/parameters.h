// Reading ROS parameters that fails loudly (ros_best_practices' readParameters): a parameter of
// the wrong type or a missing required parameter throws std::runtime_error naming it, instead of
// silently falling back to a default.
#pragma once

#include <ros/node_handle.h>

#include <stdexcept>
#include <string>

namespace homography_teach_repeat {

template <typename T>
T readParameter(const ros::NodeHandle& nh, const std::string& name, const T& default_value) {
  if (!nh.hasParam(name)) return default_value;
  T value;
  if (!nh.getParam(name, value)) {
    throw std::runtime_error("parameter '" + nh.resolveName(name) + "' has the wrong type");
  }
  return value;
}

template <typename T>
T readRequiredParameter(const ros::NodeHandle& nh, const std::string& name) {
  if (!nh.hasParam(name)) {
    throw std::runtime_error("required parameter '" + nh.resolveName(name) + "' is not set");
  }
  return readParameter<T>(nh, name, T());
}

}  // namespace homography_teach_repeat
