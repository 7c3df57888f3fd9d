// rostest: homography_node registers graf3 against graf1 and publishes the ground-truth H.
#include <gtest/gtest.h>
#include <image_transport/image_transport.h>
#include <opencv2/imgcodecs.hpp>
#include <ros/ros.h>

#include "homography_teach_repeat/HomographyStamped.h"
#include "homography_teach_repeat/homography/homography.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

TEST(HomographyNodeInterface, PublishesTheGroundTruthHomography) {
  ros::NodeHandle nh, private_nh("~");
  const std::string data = private_nh.param<std::string>("data", "");
  const cv::Mat graf3 = cv::imread(data + "/graf3.png", cv::IMREAD_COLOR);
  ASSERT_FALSE(graf3.empty()) << "cannot read " << data << "/graf3.png";
  const auto truth_file = readHomographyFile(data + "/H1to3p.xml");
  ASSERT_TRUE(truth_file.isOk()) << truth_file.status().toString();
  const Eigen::Matrix3d& truth = *truth_file;

  image_transport::ImageTransport transport(nh);
  test_support::TestCamera camera(nh, "camera/image_raw", 1);
  HomographyStamped::ConstPtr received;
  sensor_msgs::ImageConstPtr debug_image;
  const image_transport::Subscriber debug_subscriber = transport.subscribe(
      "homography_node/debug_image", 1,
      [&](const sensor_msgs::ImageConstPtr& msg) { debug_image = msg; });
  const ros::Subscriber subscriber = nh.subscribe<HomographyStamped>(
      "homography_node/homography", 1, [&](const HomographyStamped::ConstPtr& msg) { received = msg; });
  ASSERT_TRUE(test_support::spinUntil(
      [&] {
        return camera.getNumSubscribers() > 0 && subscriber.getNumPublishers() > 0 &&
               debug_subscriber.getNumPublishers() > 0;
      },
      60.0))
      << "homography_node did not connect";

  const ros::Time stamp(1234.5);
  auto publish = [&] {
    sensor_msgs::ImagePtr image = test_support::makeImage(graf3, "bgr8");
    image->header.stamp = stamp;
    image->header.frame_id = "camera_optical_frame";
    sensor_msgs::CameraInfo info = test_support::makeCameraInfo(graf3.cols, graf3.rows, 700.0);
    info.header = image->header;
    camera.publish(*image, info);
  };
  ASSERT_TRUE(test_support::spinUntil(
      [&] { return received != nullptr && debug_image != nullptr; }, 180.0, publish, 1.0))
      << "no homography and debug image received";
  EXPECT_EQ(debug_image->encoding, "bgr8");
  EXPECT_EQ(debug_image->width, 800u);
  EXPECT_EQ(debug_image->header.stamp, stamp);

  EXPECT_EQ(received->header.frame_id, "camera_optical_frame");
  EXPECT_EQ(received->header.stamp, stamp);
  EXPECT_NE(received->reference.find("graf1.png"), std::string::npos);
  EXPECT_GE(received->inliers, 50u);
  EXPECT_GE(received->matches, received->inliers);
  EXPECT_LT(received->rms_transfer_error_px, 3.0);
  Eigen::Matrix3d H;
  for (int k = 0; k < 9; ++k) H(k / 3, k % 3) = received->h[static_cast<std::size_t>(k)];
  EXPECT_NEAR(H.norm(), 1.0, 1e-9);
  const auto error = meanGridTransferDifference(H, truth, 800, 640, 800, 640, 10);
  ASSERT_TRUE(error.isOk());
  EXPECT_LT(*error, 1.0) << "mean grid transfer error vs H1to3p [px]";
}

int main(int argc, char** argv) {
  ::testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_homography_node_interface");
  return RUN_ALL_TESTS();
}
