// rostest: homography_node rejects bad input with an error diagnostic and keeps working; its
// constructor fails loudly on bad parameters.
#include <diagnostic_msgs/DiagnosticArray.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>
#include <ros/ros.h>

#include <limits>

#include "homography_teach_repeat/HomographyStamped.h"
#include "homography_teach_repeat/ros/homography_node.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

namespace {

const std::string kGraf3 = "/usr/share/doc/opencv-doc/examples/data/graf3.png";

class BadInput : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = std::make_unique<test_support::TestCamera>(nh_, "camera/image_raw", 1);
    homography_subscriber_ = nh_.subscribe<HomographyStamped>(
        "homography_node/homography", 10,
        [this](const HomographyStamped::ConstPtr&) { ++homographies_; });
    diagnostics_subscriber_ = nh_.subscribe<diagnostic_msgs::DiagnosticArray>(
        "/diagnostics", 50, [this](const diagnostic_msgs::DiagnosticArray::ConstPtr& msg) {
          for (const auto& status : msg->status) {
            if (status.name.find("registration") != std::string::npos) last_ = status;
          }
        });
    ASSERT_TRUE(test_support::spinUntil(
        [&] {
          return camera_->getNumSubscribers() > 0 && homography_subscriber_.getNumPublishers() > 0;
        },
        60.0));
  }

  // Publishes (image, info) until a diagnostic ERROR containing `fragment` arrives.
  void expectErrorDiagnostic(const sensor_msgs::Image& image, const sensor_msgs::CameraInfo& info,
                             const std::string& fragment) {
    last_ = diagnostic_msgs::DiagnosticStatus();
    const bool seen = test_support::spinUntil(
        [&] {
          return last_.level == diagnostic_msgs::DiagnosticStatus::ERROR &&
                 last_.message.find(fragment) != std::string::npos;
        },
        60.0, [&] { camera_->publish(image, info); });
    EXPECT_TRUE(seen) << "no ERROR diagnostic containing '" << fragment
                      << "'; last: " << last_.message;
  }

  ros::NodeHandle nh_;
  std::unique_ptr<test_support::TestCamera> camera_;
  ros::Subscriber homography_subscriber_, diagnostics_subscriber_;
  diagnostic_msgs::DiagnosticStatus last_;
  int homographies_ = 0;
};

}  // namespace

TEST_F(BadInput, EachBadInputIsReportedAndTheNodeKeepsWorking) {
  const cv::Mat graf3 = cv::imread(kGraf3, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(graf3.empty());
  const sensor_msgs::CameraInfo good_info = test_support::makeCameraInfo(graf3.cols, graf3.rows, 700.0);
  const sensor_msgs::ImagePtr good_image = test_support::makeImage(graf3, "mono8");

  cv::Mat float_image;
  graf3.convertTo(float_image, CV_32F);
  expectErrorDiagnostic(*test_support::makeImage(float_image, "32FC1"), good_info,
                        "unsupported image encoding '32FC1'");

  sensor_msgs::Image empty;
  empty.encoding = "mono8";
  expectErrorDiagnostic(empty, good_info, "empty image");

  sensor_msgs::Image truncated = *good_image;
  truncated.data.resize(1000);
  expectErrorDiagnostic(truncated, good_info, "truncated image");

  sensor_msgs::CameraInfo zero_focal = good_info;
  zero_focal.K = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  expectErrorDiagnostic(*good_image, zero_focal, "fx must be finite and > 0");

  sensor_msgs::CameraInfo nan_distortion = good_info;
  nan_distortion.D[0] = std::numeric_limits<double>::quiet_NaN();
  expectErrorDiagnostic(*good_image, nan_distortion, "D[0] is not finite");

  sensor_msgs::CameraInfo wrong_size = test_support::makeCameraInfo(640, 480, 500.0);
  expectErrorDiagnostic(*good_image, wrong_size, "differs from camera_info");

  EXPECT_EQ(homographies_, 0) << "a homography was published for a bad frame";

  // Still alive and working.
  EXPECT_TRUE(test_support::spinUntil([&] { return homographies_ > 0; }, 120.0,
                                 [&] { camera_->publish(*good_image, good_info); }, 1.0))
      << "no homography after the bad inputs: did the node die?";
}

namespace {
void expectConstructionFails(const std::string& ns, const std::string& fragment) {
  try {
    HomographyNode node{ros::NodeHandle(ns), ros::NodeHandle(ns)};
    FAIL() << "node in " << ns << " started although it should fail with '" << fragment << "'";
  } catch (const std::runtime_error& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}
}  // namespace

TEST(HomographyNodeParameters, FailLoudly) {
  ros::NodeHandle nh("~");
  expectConstructionFails("~missing", "missing/reference_image' is not set");

  nh.setParam("unreadable/reference_image", "/nonexistent/reference.png");
  expectConstructionFails("~unreadable", "cannot read the reference image '/nonexistent/reference.png'");

  nh.setParam("surf/reference_image", kGraf3);
  nh.setParam("surf/feature_type", "surf");
  expectConstructionFails("~surf", "available: sift, orb, akaze");

  nh.setParam("wrong_type/reference_image", kGraf3);
  nh.setParam("wrong_type/max_features", "many");
  expectConstructionFails("~wrong_type", "max_features' has the wrong type");

  nh.setParam("bad_ratio/reference_image", kGraf3);
  nh.setParam("bad_ratio/match_ratio", 1.7);
  expectConstructionFails("~bad_ratio", "ratio must be in (0, 1]");

  nh.setParam("bad_timeout/reference_image", kGraf3);
  nh.setParam("bad_timeout/image_timeout", -1.0);
  expectConstructionFails("~bad_timeout", "image_timeout' must be > 0");
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_homography_node_bad_input");
  return RUN_ALL_TESTS();
}
