#include "homography_teach_repeat/ros/parameters.h"

namespace homography_teach_repeat {

namespace {
ParameterDefaultsRecorder* active_recorder = nullptr;
}  // namespace

ParameterDefaultsRecorder::ParameterDefaultsRecorder() {
  if (active_recorder != nullptr) throw std::logic_error("a ParameterDefaultsRecorder is already recording");
  active_recorder = this;
}

ParameterDefaultsRecorder::~ParameterDefaultsRecorder() { active_recorder = nullptr; }

ParameterDefaultsRecorder* ParameterDefaultsRecorder::active() { return active_recorder; }

std::runtime_error invalidParameter(const ros::NodeHandle& nh, const std::string& what) {
  return std::runtime_error("invalid parameter in " + nh.getNamespace() + ": " + what);
}

}  // namespace homography_teach_repeat
