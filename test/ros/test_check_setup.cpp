// check_setup end to end (test/launch/check_setup_*.test): its latched ~report on the simulator's
// robot says it is ready to teach; on a set-up without camera_info, odometry and camera tf (this
// test publishes bare images) it names each problem with its fix and says NOT READY. With
// ~image_delay the test's images start late: check_setup, which waits for the camera, still sees them.
#include <gtest/gtest.h>

#include <ros/ros.h>
#include <std_msgs/String.h>

#include <string>

#include "node_test_helpers.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

TEST(CheckSetup, ReportNamesEveryProblem) {
  ros::NodeHandle nh, private_nh("~");
  const std::string expect = private_nh.param<std::string>("expect", "ready");
  const double image_delay = private_nh.param("image_delay", 0.0);
  const ros::WallTime start = ros::WallTime::now();
  std::string report;
  ros::Subscriber report_sub =
      nh.subscribe<std_msgs::String>("check_setup/report", 1, [&](const auto& m) { report = m->data; });
  ros::Publisher image_pub = nh.advertise<sensor_msgs::Image>("camera/image_raw", 2);
  const cv::Mat texture = test_support::makeTexture(640, 480, 7);
  const auto publish_image = [&] {
    if (expect == "ready") return;  // the simulator's camera
    if ((ros::WallTime::now() - start).toSec() < image_delay) return;
    auto image = test_support::makeImage(texture, "mono8");
    image->header.stamp = ros::Time::now();
    image->header.frame_id = "camera_optical_frame";
    image_pub.publish(image);
  };
  ASSERT_TRUE(test_support::spinUntil([&] { return !report.empty(); }, 60.0, publish_image, 0.1))
      << "no report from check_setup";
  std::cout << report;
  if (expect == "ready") {
    EXPECT_NE(report.find("ready to teach"), std::string::npos) << report;
    EXPECT_EQ(report.find("NOT READY"), std::string::npos) << report;
    EXPECT_EQ(report.find("PROBLEM"), std::string::npos) << report;
  } else {
    EXPECT_NE(report.find("NOT READY"), std::string::npos) << report;
    EXPECT_EQ(report.find("no image"), std::string::npos) << report;
    EXPECT_NE(report.find("no camera_info beside the images"), std::string::npos) << report;
    EXPECT_NE(report.find("camera_calibration"), std::string::npos) << report;
    EXPECT_NE(report.find("no odometry in 3.0 s"), std::string::npos) << report;
    EXPECT_NE(report.find("no tf from base_link"), std::string::npos) << report;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_check_setup");
  return RUN_ALL_TESTS();
}
