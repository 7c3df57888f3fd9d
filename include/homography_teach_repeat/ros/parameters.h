// Reading ROS parameters that fails loudly (ros_best_practices' readParameters): a parameter of
// the wrong type or a missing required parameter throws std::runtime_error naming it, instead of
// silently falling back to a default.
#pragma once

#include <ros/node_handle.h>

#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>
#include <string>
#include <type_traits>

namespace homography_teach_repeat {

// Collects, while it lives, the default of every scalar parameter read through readParameter in
// this process: resolved name -> the default as text (bool "true"/"false", numbers with 17
// digits, strings as they are). What a node uses where its YAML is silent; the rostest
// `config_defaults` checks that config/*.yaml states exactly these values. One at a time.
class ParameterDefaultsRecorder {
 public:
  ParameterDefaultsRecorder();
  ~ParameterDefaultsRecorder();
  ParameterDefaultsRecorder(const ParameterDefaultsRecorder&) = delete;
  ParameterDefaultsRecorder& operator=(const ParameterDefaultsRecorder&) = delete;
  const std::map<std::string, std::string>& defaults() const { return defaults_; }

  // The recorder alive, or nullptr.
  static ParameterDefaultsRecorder* active();
  void record(const std::string& name, const std::string& text) { defaults_[name] = text; }

 private:
  std::map<std::string, std::string> defaults_;
};

template <typename T>
void recordParameterDefault(const ros::NodeHandle& nh, const std::string& name, const T& default_value) {
  ParameterDefaultsRecorder* recorder = ParameterDefaultsRecorder::active();
  if (recorder == nullptr) return;
  if constexpr (std::is_same_v<T, bool>) {
    recorder->record(nh.resolveName(name), default_value ? "true" : "false");
  } else if constexpr (std::is_arithmetic_v<T>) {
    std::ostringstream text;
    text << std::setprecision(17) << default_value;
    recorder->record(nh.resolveName(name), text.str());
  } else if constexpr (std::is_convertible_v<T, std::string>) {
    recorder->record(nh.resolveName(name), std::string(default_value));
  }
}

// The start-up error for a bad parameter: "invalid parameter in <namespace>: <what>".
std::runtime_error invalidParameter(const ros::NodeHandle& nh, const std::string& what);

template <typename T>
T readParameter(const ros::NodeHandle& nh, const std::string& name, const T& default_value) {
  recordParameterDefault(nh, name, default_value);
  if (!nh.hasParam(name)) return default_value;
  T value;
  if (!nh.getParam(name, value)) {
    throw std::runtime_error("parameter '" + nh.resolveName(name) + "' has the wrong type");
  }
  return value;
}

// PyYAML (rosparam load) reads exponent notation without a dot or sign, e.g. 1e-3 or 1.0e6, as a
// string: accept such strings for floating-point parameters instead of failing on a valid number.
template <>
inline double readParameter<double>(const ros::NodeHandle& nh, const std::string& name,
                                    const double& default_value) {
  recordParameterDefault(nh, name, default_value);
  if (!nh.hasParam(name)) return default_value;
  double value = 0.0;
  if (nh.getParam(name, value)) return value;
  std::string text;
  if (nh.getParam(name, text)) {
    std::size_t used = 0;
    try {
      value = std::stod(text, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used > 0 && used == text.size()) return value;
  }
  throw std::runtime_error("parameter '" + nh.resolveName(name) + "' must be a number");
}

// Runs `read`, which reads parameters and validates them (an options struct's validate(), or a
// check of its own): an std::invalid_argument it throws becomes the std::runtime_error that stops
// the node at start-up, naming the node's namespace and the bad field. The one place where a bad
// parameter becomes a start-up error.
template <typename Read>
void readParameters(const ros::NodeHandle& nh, Read&& read) {
  try {
    read();
  } catch (const std::invalid_argument& e) {
    throw invalidParameter(nh, e.what());
  }
}

// A parameter that must satisfy `valid`: std::invalid_argument "<name> <requirement>" otherwise
// (inside readParameters, or std::runtime_error naming the parameter outside).
template <typename T, typename Valid>
T readCheckedParameter(const ros::NodeHandle& nh, const std::string& name, const T& default_value, Valid&& valid,
                       const std::string& requirement) {
  const T value = readParameter<T>(nh, name, default_value);
  if (!valid(value)) throw invalidParameter(nh, "'" + nh.resolveName(name) + "' " + requirement);
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
