// Bad input to repeat_node: explicit failures on ~heading_correction, no crash, no pose.
#include <gtest/gtest.h>

#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <ros/ros.h>

#include <filesystem>
#include <fstream>

#include "support/synthetic_route.h"
#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "homography_teach_repeat/ros/controller_node.h"
#include "homography_teach_repeat/ros/repeat_node.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

TEST(RepeatNode, BadInputIsReportedAndSurvived) {
  ros::NodeHandle nh;
  test_support::TestCamera camera(nh, "camera/image_raw", 2);
  std::vector<HeadingCorrectionStamped> headings;
  int poses = 0;
  ros::Subscriber heading_sub = nh.subscribe<HeadingCorrectionStamped>(
      "repeat_node/heading_correction", 20, [&](const auto& m) { headings.push_back(*m); });
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 20, [&](const auto&) { ++poses; });
  // Every connection up before the first image (the node publishes its answers at once).
  ASSERT_TRUE(test_support::spinUntil(
      [&] {
        return camera.getNumSubscribers() > 0 && heading_sub.getNumPublishers() > 0 &&
               pose_sub.getNumPublishers() > 0;
      },
      30.0));

  const CameraCalibration c = test_support::syntheticCalibration();
  auto info = [&](const std_msgs::Header& header, double focal) {
    sensor_msgs::CameraInfo i = test_support::makeCameraInfo(c.width, c.height, focal);
    i.K[2] = c.cx;
    i.K[5] = c.cy;
    i.header = header;
    return i;
  };
  auto expectFailure = [&](const sensor_msgs::ImagePtr& image, double focal, const std::string& reason) {
    const std::size_t before = headings.size();
    camera.publish(*image, info(image->header, focal));
    ASSERT_TRUE(test_support::spinUntil([&] { return headings.size() > before; }, 20.0)) << reason;
    EXPECT_FALSE(headings.back().ok) << reason;
    EXPECT_NE(headings.back().status.find(reason), std::string::npos) << headings.back().status;
  };
  // A float image: an encoding the node does not take.
  auto float_image = test_support::makeImage(cv::Mat(480, 640, CV_32FC1, cv::Scalar(0.5)), "32FC1");
  expectFailure(float_image, c.fx, "32FC1");
  // An empty image.
  auto empty = boost::make_shared<sensor_msgs::Image>();
  empty->encoding = "mono8";
  empty->width = 640;
  empty->height = 480;
  expectFailure(empty, c.fx, "INVALID_INPUT");
  // Zero focal length.
  const test_support::SyntheticWall wall;
  auto good = test_support::makeImage(wall.imageAt(PlanarPose(0.02, 0.1, 0.0)), "mono8");
  expectFailure(good, 0.0, "INVALID_INPUT");
  EXPECT_EQ(poses, 0);
  // Still alive: a good image is localized.
  const std::size_t before = headings.size();
  camera.publish(*good, info(good->header, c.fx));
  ASSERT_TRUE(test_support::spinUntil([&] { return headings.size() > before && poses > 0; }, 20.0));
  EXPECT_TRUE(headings.back().ok) << headings.back().status;
}

namespace {

// Constructs the node class in namespace `ns` and expects it to refuse to start with a message
// containing `fragment` (the executables print it and exit with status 1).
template <class Node>
void expectStartFails(const std::string& ns, const std::string& fragment) {
  try {
    Node node{ros::NodeHandle(ns), ros::NodeHandle(ns)};
    FAIL() << "started in " << ns << " although it should fail with '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

}  // namespace

// A missing, corrupt or unknown-version route, or a bad parameter: repeat_node and controller_node
// refuse to start, naming the file or the parameter.
TEST(RepeatNode, RouteProblemsStopTheStartNamingTheFile) {
  ros::NodeHandle nh("~");
  expectStartFails<RepeatNode>("~no_route", "route_directory' is not set");
  nh.setParam("missing/route_directory", "/nonexistent/route");
  expectStartFails<RepeatNode>("~missing", "/nonexistent/route");
  expectStartFails<ControllerNode>("~missing", "/nonexistent/route");

  const std::filesystem::path corrupt = std::filesystem::temp_directory_path() / "htr_corrupt_route";
  std::filesystem::create_directories(corrupt);
  std::ofstream((corrupt / "route.yaml").string()) << "format_version: 1\nkeyframes: [ {index: 0, pose: {x: 1";
  nh.setParam("corrupt/route_directory", corrupt.string());
  expectStartFails<RepeatNode>("~corrupt", "route.yaml");
  std::ofstream((corrupt / "route.yaml").string()) << "format_version: 99\n";
  expectStartFails<RepeatNode>("~corrupt", "format_version");
  std::filesystem::remove_all(corrupt);

  // A valid route with a keyframe file the mode loads at start truncated (a disk that filled up, a
  // copy cut short): the start fails naming the file. (Keyframe images are read only for
  // ~debug_image.)
  const std::filesystem::path fixture = std::filesystem::temp_directory_path() / "htr_repeat_node_test_route";
  const std::filesystem::path truncated = std::filesystem::temp_directory_path() / "htr_truncated_route";
  for (const auto& [file, mode] : {std::pair<std::string, std::string>{"keyframes/000002.features.yml", "fast_hd"},
                                   {"keyframes/000003.lines.yml", "mu"}}) {
    SCOPED_TRACE(file);
    std::filesystem::remove_all(truncated);
    std::filesystem::copy(fixture, truncated, std::filesystem::copy_options::recursive);
    const auto size = std::filesystem::file_size(truncated / file);
    std::filesystem::resize_file(truncated / file, size / 2);
    nh.setParam("truncated/route_directory", truncated.string());
    nh.setParam("truncated/mode", mode);
    expectStartFails<RepeatNode>("~truncated", file);
  }
  std::filesystem::remove_all(truncated);

  nh.setParam("bad_mode/route_directory", (std::filesystem::temp_directory_path() / "htr_repeat_node_test_route").string());
  nh.setParam("bad_mode/mode", "teleport");
  expectStartFails<RepeatNode>("~bad_mode", "fast_hd");
  nh.setParam("bad_start/route_directory", (std::filesystem::temp_directory_path() / "htr_repeat_node_test_route").string());
  nh.setParam("bad_start/start_keyframe", 99);
  expectStartFails<RepeatNode>("~bad_start", "start_keyframe");
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_repeat_node_bad_input");
  return RUN_ALL_TESTS();
}
