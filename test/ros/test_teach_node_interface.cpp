// Drives a synthetic robot past a textured wall and checks what teach_node writes.
#include <gtest/gtest.h>

#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <opencv2/imgproc.hpp>

#include <cmath>

#include "homography_teach_repeat/TeachStatus.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

namespace {

constexpr double kFocal = 500.0;

cv::Mat wallTexture() {
  cv::RNG rng(7);
  cv::Mat texture(480, 640, CV_8UC1, cv::Scalar(128));
  for (int i = 0; i < 800; ++i) {
    const cv::Point centre(rng.uniform(0, 640), rng.uniform(0, 480));
    const int size = rng.uniform(3, 25);
    if (i % 2 == 0) {
      cv::rectangle(texture, centre, centre + cv::Point(size, size * 2 / 3),
                    cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
    } else {
      cv::circle(texture, centre, size / 2, cv::Scalar(rng.uniform(0, 256)), cv::FILLED);
    }
  }
  cv::GaussianBlur(texture, texture, cv::Size(3, 3), 0.8);
  return texture;
}

}  // namespace

TEST(TeachNode, RecordsKeyframesAndPlanes) {
  ros::NodeHandle nh;
  ros::NodeHandle private_nh("~");
  std::string route_dir;
  ASSERT_TRUE(private_nh.getParam("route", route_dir));

  // The camera 0.2 m ahead of base_link, level, looking forward (optical z = base x).
  tf2_ros::StaticTransformBroadcaster static_tf;
  static_tf.sendTransform(test_support::levelCameraMount(0.2));

  test_support::TestCamera camera_publisher(nh, "camera/image_raw", 5);
  ros::Publisher odom_publisher = nh.advertise<nav_msgs::Odometry>("odom", 50);
  TeachStatus last_status;
  bool have_status = false;
  ros::Subscriber status_subscriber = nh.subscribe<TeachStatus>(
      "teach_node/status", 5, [&](const TeachStatus::ConstPtr& s) {
        last_status = *s;
        have_status = true;
      });
  ASSERT_TRUE(test_support::spinUntil(
      [&] { return camera_publisher.getNumSubscribers() > 0 && odom_publisher.getNumSubscribers() > 0 && have_status; },
      30.0));

  CameraCalibration calibration;
  calibration.width = 640;
  calibration.height = 480;
  calibration.fx = calibration.fy = kFocal;
  calibration.cx = 320.0;
  calibration.cy = 240.0;
  const PinholeCamera camera(calibration);
  const CameraMount camera_mount(0.2, 0.0, 0.0);
  const ScenePlane wall{Eigen::Vector3d(std::sin(0.3), 0.0, std::cos(0.3)), 4.0};
  const cv::Mat texture = wallTexture();
  auto basePose = [](double s) { return Pose2D(s, 0.05 * s, 0.06 * s); };

  auto publishOdometry = [&](const ros::Time& stamp, const Pose2D& pose) {
    odom_publisher.publish(test_support::makeOdometry(stamp, pose.x, pose.y, pose.yaw));
  };
  // 16 images 10 cm apart; odometry 50 ms before and after each image stamp.
  const Pose2D base0 = basePose(0.0);
  for (int step = 0; step < 16; ++step) {
    const double s = 0.1 * step;
    const ros::Time stamp = ros::Time::now();
    publishOdometry(stamp - ros::Duration(0.05), basePose(s - 0.005));
    publishOdometry(stamp + ros::Duration(0.05), basePose(s + 0.005));
    ros::spinOnce();
    ros::WallDuration(0.05).sleep();
    const PlanarPose camera_pose = camera_mount.baseToCamera(base0.inverse().compose(basePose(s)));
    cv::Mat image;
    const Eigen::Matrix3d H = planeInducedHomography(camera, camera_pose, wall);
    cv::Mat h(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r) for (int c = 0; c < 3; ++c) h.at<double>(r, c) = H(r, c);
    cv::warpPerspective(texture, image, h, texture.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT,
                        cv::Scalar(128));
    auto message = test_support::makeImage(image, "mono8");
    message->header.stamp = stamp;
    message->header.frame_id = "camera_optical_frame";
    sensor_msgs::CameraInfo info = test_support::makeCameraInfo(640, 480, kFocal);
    info.header = message->header;
    camera_publisher.publish(*message, info);
    // Wait until the node has seen it (the status counts keyframes; images are processed in
    // order, so a short pause per image is enough and keeps the queue from dropping).
    ros::WallDuration(0.25).sleep();
    ros::spinOnce();
  }
  ASSERT_TRUE(test_support::spinUntil([&] { return last_status.keyframes >= 5; }, 30.0))
      << "keyframes: " << last_status.keyframes << " state " << last_status.state << ": "
      << last_status.message;

  std_srvs::Trigger finish;
  ASSERT_TRUE(ros::service::waitForService("teach_node/finish", ros::Duration(10.0)));
  ASSERT_TRUE(ros::service::call("teach_node/finish", finish));
  EXPECT_TRUE(finish.response.success) << finish.response.message;
  ASSERT_TRUE(test_support::spinUntil([&] { return last_status.state == "finished"; }, 10.0));

  const auto route = loadRoute(route_dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  EXPECT_EQ(route->keyframes.size(), last_status.keyframes);
  EXPECT_NEAR(route->info.camera_mount.x, 0.2, 1e-9);
  EXPECT_EQ(route->info.feature_type, FeatureType::kAkaze);
  int planes = 0;
  for (const auto& k : route->keyframes) planes += k.plane ? 1 : 0;
  EXPECT_EQ(planes, static_cast<int>(route->keyframes.size())) << finish.response.message;
  // The first keyframe's plane is the wall as seen from the first camera.
  ASSERT_TRUE(route->keyframes.front().plane.has_value());
  EXPECT_LT((route->keyframes.front().plane->normal - wall.normal).norm(), 0.03);
  EXPECT_NEAR(route->keyframes.front().plane->distance, 4.0, 1e-9);
  // ~finish measured the route's match noise (docs/route_format.md, "Measured noise"): the
  // synthetic wall's exact warps match to a fraction of a pixel.
  EXPECT_TRUE(route->info.match_noise_measured);
  const auto residual = routeMatchResidual(*route);
  ASSERT_TRUE(residual.has_value());
  EXPECT_GT(*residual, 0.0);
  EXPECT_LT(*residual, 1.0);
  // ... and the camera's tilt between keyframes: the level camera's is what the estimate leaves.
  EXPECT_TRUE(route->info.tilt_measured);
  EXPECT_LT(routeTiltSigma(*route).value_or(0.0), 0.01);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_teach_node_interface");
  return RUN_ALL_TESTS();
}
