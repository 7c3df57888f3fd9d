// config/*.yaml states the nodes' built-in defaults: one set of defaults, whether a node is started
// with its YAML or without it (a launch file of the user's, a nodelet, a test). Each file is loaded
// into a namespace of its own (config_defaults.test); the nodes' parameter readers run there under
// a ParameterDefaultsRecorder, and every value the file sets is compared with the default the
// reader would have used. The simulator's files (config/sim_*.yaml) are overrides and not checked.
#include <gtest/gtest.h>

#include <ros/ros.h>

#include <cmath>
#include <cstdlib>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "homography_teach_repeat/ros/camera_subscription.h"
#include "homography_teach_repeat/ros/controller_parameters.h"
#include "homography_teach_repeat/ros/odometry_subscriber.h"
#include "homography_teach_repeat/ros/parameters.h"
#include "homography_teach_repeat/ros/repeat_parameters.h"
#include "homography_teach_repeat/ros/teach_parameters.h"

using namespace homography_teach_repeat;

namespace {

bool parseNumber(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end == text.c_str() + text.size();
}

bool sameNumber(double a, double b) { return std::abs(a - b) <= 1e-12 * std::max(1.0, std::abs(a)); }

// The parameter server's value as the recorder writes a default.
std::string shown(XmlRpc::XmlRpcValue& value) {
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return static_cast<bool>(value) ? "true" : "false";
    case XmlRpc::XmlRpcValue::TypeInt:
      return std::to_string(static_cast<int>(value));
    case XmlRpc::XmlRpcValue::TypeDouble:
      return std::to_string(static_cast<double>(value));
    case XmlRpc::XmlRpcValue::TypeString:
      return static_cast<std::string>(value);
    default:
      return value.toXml();
  }
}

bool sameValue(XmlRpc::XmlRpcValue& value, const std::string& default_text) {
  double a = 0.0;
  double b = 0.0;
  switch (value.getType()) {
    case XmlRpc::XmlRpcValue::TypeBoolean:
      return shown(value) == default_text;
    case XmlRpc::XmlRpcValue::TypeInt:
      return parseNumber(default_text, &b) && sameNumber(static_cast<int>(value), b);
    case XmlRpc::XmlRpcValue::TypeDouble:
      return parseNumber(default_text, &b) && sameNumber(static_cast<double>(value), b);
    case XmlRpc::XmlRpcValue::TypeString: {
      const std::string text = value;
      // rosparam reads 1e-3 as a string; the readers accept it as a number.
      if (parseNumber(text, &a) && parseNumber(default_text, &b)) return sameNumber(a, b);
      return text == default_text;
    }
    default:
      return false;
  }
}

struct Comparison {
  int compared = 0;
  std::vector<std::string> mismatches;
};

// Every recorded default the parameter server also holds (the YAML states it), except `ignored`.
Comparison compareWithServer(const ParameterDefaultsRecorder& recorder, const std::set<std::string>& ignored = {}) {
  Comparison result;
  for (const auto& [name, default_text] : recorder.defaults()) {
    XmlRpc::XmlRpcValue value;
    if (ignored.count(name) > 0 || !ros::param::get(name, value)) continue;
    ++result.compared;
    if (!sameValue(value, default_text)) {
      result.mismatches.push_back(name + ": the YAML says " + shown(value) + ", the node's default is " + default_text);
    }
  }
  return result;
}

std::string joined(const std::vector<std::string>& lines) {
  std::string text;
  for (const auto& line : lines) text += line + "\n";
  return text;
}

// The YAML states every recorded default it sets, and sets at least `min_compared` of them (the
// readers cover the file; a few parameters are read by the nodes themselves).
void expectDefaultsStated(const ParameterDefaultsRecorder& recorder, int min_compared,
                          const std::set<std::string>& ignored = {}) {
  const Comparison comparison = compareWithServer(recorder, ignored);
  EXPECT_TRUE(comparison.mismatches.empty()) << joined(comparison.mismatches);
  EXPECT_GE(comparison.compared, min_compared);
}

}  // namespace

TEST(ConfigDefaults, RepeatNodeYamlStatesTheBuiltInDefaults) {
  const ros::NodeHandle nh("/repeat_config");
  ParameterDefaultsRecorder recorder;
  readRepeatPipelineOptions(nh);
  readRelocalizationOptions(nh);
  readImageTransport(nh);
  readOdometryWait(nh);
  expectDefaultsStated(recorder, 75);
}

TEST(ConfigDefaults, RepeatNodeLearningYamlStatesTheBuiltInDefaults) {
  // The learning options are read only when a run learns: the same file with learn_experiences on.
  const ros::NodeHandle nh("/learning_config");
  ParameterDefaultsRecorder recorder;
  ASSERT_TRUE(readExperienceLearningOptions(nh).has_value());
  expectDefaultsStated(recorder, 5, {"/learning_config/learn_experiences"});
}

TEST(ConfigDefaults, TeachNodeYamlStatesTheBuiltInDefaults) {
  const ros::NodeHandle nh("/teach_config");
  ParameterDefaultsRecorder recorder;
  readTeachOptions(nh, false);
  readAuditOptions(nh);
  readImageTransport(nh);
  readOdometryWait(nh);
  // route_directory is set by the test, not the YAML.
  expectDefaultsStated(recorder, 12, {"/teach_config/route_directory"});
}

TEST(ConfigDefaults, ControllerNodeYamlStatesTheBuiltInDefaults) {
  const ros::NodeHandle nh("/controller_config");
  ParameterDefaultsRecorder recorder;
  readRouteFollowerOptions(nh);
  expectDefaultsStated(recorder, 30);
}

// teach_node's estimate_keyframe_tilt is auto (a string) or a bool; anything else stops the node
// at start-up naming the value.
TEST(TeachParameters, EstimateKeyframeTiltIsAutoTrueOrFalse) {
  const ros::NodeHandle nh("/keyframe_tilt");
  const auto read = [&](const auto& value) {
    nh.setParam("estimate_keyframe_tilt", value);
    return readTeachOptions(nh, true).keyframe_tilt;  // into a map: no route folder needed
  };
  nh.deleteParam("estimate_keyframe_tilt");
  EXPECT_EQ(readTeachOptions(nh, true).keyframe_tilt, KeyframeTilt::kAuto);
  EXPECT_EQ(read(std::string("auto")), KeyframeTilt::kAuto);
  EXPECT_EQ(read(true), KeyframeTilt::kEstimate);
  EXPECT_EQ(read(false), KeyframeTilt::kLevel);
  try {
    read(std::string("sometimes"));
    ADD_FAILURE() << "a bad value was accepted";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find("estimate_keyframe_tilt must be auto, true or false, got 'sometimes'"),
              std::string::npos)
        << e.what();
  }
  EXPECT_THROW(read(3), std::runtime_error);
  nh.deleteParam("estimate_keyframe_tilt");
}

TEST(ConfigDefaults, AValueOffItsDefaultIsFound) {
  const ros::NodeHandle nh("/wrong_config");
  ParameterDefaultsRecorder recorder;
  readRepeatPipelineOptions(nh);
  const Comparison comparison = compareWithServer(recorder);
  ASSERT_EQ(comparison.compared, 1);
  ASSERT_EQ(comparison.mismatches.size(), 1u);
  EXPECT_NE(comparison.mismatches.front().find("/wrong_config/min_inliers: the YAML says 16"), std::string::npos)
      << comparison.mismatches.front();
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_config_defaults");
  return RUN_ALL_TESTS();
}
