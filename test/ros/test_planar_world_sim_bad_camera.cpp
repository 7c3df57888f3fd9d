// planar_world_sim refuses a camera it cannot render at start-up: a NaN lens coefficient, a zero
// focal length or two ways to band-limit its pixels at once stops it with a message naming the node
// and the field, exit code 1 (issue 22, "Bad input"). The test sets the parameters and runs the node itself under the test's master.
#include <gtest/gtest.h>

#include <ros/ros.h>
#include <sys/wait.h>

#include <cstdio>
#include <limits>
#include <string>
#include <vector>

namespace {

struct Outcome {
  int exit_code = -1;
  std::string output;
};

// Runs planar_world_sim as node `name` (its private parameters already set) until it exits.
Outcome runSimulator(const std::string& name) {
  const std::string command = std::string("timeout 60 ") + HTR_PLANAR_WORLD_SIM + " __name:=" + name + " 2>&1";
  Outcome outcome;
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return outcome;
  char buffer[256];
  while (std::fgets(buffer, sizeof(buffer), pipe) != nullptr) outcome.output += buffer;
  const int status = ::pclose(pipe);
  outcome.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  std::printf("planar_world_sim as %s: exit code %d, said:\n%s\n", name.c_str(), outcome.exit_code, outcome.output.c_str());
  return outcome;
}

// A valid world and lens for node `name` (the world: the test's own ~world_file, from the launch file).
void setValidCamera(ros::NodeHandle& nh, const std::string& name) {
  std::string world_file;
  ros::NodeHandle("~").getParam("world_file", world_file);
  nh.setParam("/" + name + "/world_file", world_file);
  nh.setParam("/" + name + "/distortion_model", std::string("plumb_bob"));
  nh.setParam("/" + name + "/distortion", std::vector<double>{-0.15, 0.03, 0.0, 0.0, 0.0});
}

}  // namespace

TEST(PlanarWorldSimBadCamera, ANaNLensCoefficientStopsItNamingTheCoefficient) {
  ros::NodeHandle nh;
  setValidCamera(nh, "nan_lens_sim");
  nh.setParam("/nan_lens_sim/distortion",
              std::vector<double>{-0.15, std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0, 0.0});
  const Outcome outcome = runSimulator("nan_lens_sim");
  EXPECT_EQ(outcome.exit_code, 1) << outcome.output;
  EXPECT_NE(outcome.output.find("nan_lens_sim"), std::string::npos) << outcome.output;
  EXPECT_NE(outcome.output.find("D[1] is not finite"), std::string::npos) << outcome.output;
}

TEST(PlanarWorldSimBadCamera, AZeroFocalLengthStopsItNamingTheField) {
  ros::NodeHandle nh;
  setValidCamera(nh, "zero_focal_sim");
  nh.setParam("/zero_focal_sim/fx", 0.0);
  const Outcome outcome = runSimulator("zero_focal_sim");
  EXPECT_EQ(outcome.exit_code, 1) << outcome.output;
  EXPECT_NE(outcome.output.find("zero_focal_sim"), std::string::npos) << outcome.output;
  EXPECT_NE(outcome.output.find("fx must be finite and > 0"), std::string::npos) << outcome.output;
}

TEST(PlanarWorldSimBadCamera, SupersamplingWithTextureFilteringStopsItNamingBoth) {
  ros::NodeHandle nh;
  setValidCamera(nh, "two_filters_sim");
  nh.setParam("/two_filters_sim/image_supersampling", 4);
  nh.setParam("/two_filters_sim/image_texture_filtering", true);
  const Outcome outcome = runSimulator("two_filters_sim");
  EXPECT_EQ(outcome.exit_code, 1) << outcome.output;
  EXPECT_NE(outcome.output.find("/two_filters_sim/image_supersampling"), std::string::npos) << outcome.output;
  EXPECT_NE(outcome.output.find("/two_filters_sim/image_texture_filtering"), std::string::npos) << outcome.output;
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_planar_world_sim_bad_camera");
  return RUN_ALL_TESTS();
}
