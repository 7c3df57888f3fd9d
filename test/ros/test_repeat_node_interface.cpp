// Feeds repeat_node images of the synthetic wall from poses beside the taught path.
#include <gtest/gtest.h>

#include <dynamic_reconfigure/Reconfigure.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <visualization_msgs/MarkerArray.h>

#include <cmath>
#include <vector>

#include "support/synthetic_route.h"
#include "homography_teach_repeat/HeadingCorrectionStamped.h"
#include "node_test_helpers.h"
#include "synthetic_camera.h"

using namespace homography_teach_repeat;

using test_support::syntheticCameraInfo;

namespace {

// Odometry at `stamp` and 0.1 s either side (repeat_node interpolates it at the image stamp), then
// a short spin so that it has arrived before the image.
void publishOdometryAround(const ros::Publisher& publisher, double stamp, double x, double y = 0.0) {
  for (const double t : {stamp - 0.1, stamp, stamp + 0.1}) {
    nav_msgs::Odometry odom;
    odom.header.stamp = ros::Time(t);
    odom.header.frame_id = "odom";
    odom.pose.pose.position.x = x;
    odom.pose.pose.position.y = y;
    odom.pose.pose.orientation.w = 1.0;
    publisher.publish(odom);
  }
  ros::WallDuration(0.2).sleep();
  ros::spinOnce();
}

}  // namespace

TEST(RepeatNode, PosesHeadingAndMarkers) {
  ros::NodeHandle nh;
  test_support::TestCamera camera(nh, "camera/image_raw", 2);
  std::vector<geometry_msgs::PoseWithCovarianceStamped> poses;
  std::vector<HeadingCorrectionStamped> headings;
  visualization_msgs::MarkerArray markers;
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 20, [&](const auto& m) { poses.push_back(*m); });
  ros::Subscriber heading_sub = nh.subscribe<HeadingCorrectionStamped>(
      "repeat_node/heading_correction", 20, [&](const auto& m) { headings.push_back(*m); });
  sensor_msgs::Image debug;
  ros::Subscriber debug_sub = nh.subscribe<sensor_msgs::Image>(
      "repeat_node/debug_image", 2, [&](const auto& m) { debug = *m; });
  ros::Subscriber marker_sub = nh.subscribe<visualization_msgs::MarkerArray>(
      "repeat_node/route_markers", 1, [&](const auto& m) { markers = *m; });
  ASSERT_TRUE(test_support::spinUntil(
      [&] {
        return camera.getNumSubscribers() > 0 && !markers.markers.empty() &&
               heading_sub.getNumPublishers() > 0 && pose_sub.getNumPublishers() > 0;
      },
      30.0));
  int arrows = 0, planes = 0;
  for (const auto& m : markers.markers) {
    arrows += m.ns == "keyframes" ? 1 : 0;
    planes += m.ns == "planes" ? 1 : 0;
  }
  EXPECT_EQ(arrows, 6);
  EXPECT_EQ(planes, 6);

  const test_support::SyntheticWall wall;
  std::vector<Pose2D> truths;
  // 20 cm steps, then frames 1 cm apart (a camera at ~30 Hz): those are tracked by optical flow.
  const std::vector<double> path{0.05, 0.25, 0.45, 0.65, 0.85, 1.05, 1.10, 1.11, 1.12, 1.13};
  for (std::size_t step = 0; step < path.size(); ++step) {
    const double s = path[step];
    const PlanarPose camera_pose(0.08 * s + 0.06, s, 0.04 * s + 0.03);
    truths.push_back(cameraAxesToRep103(camera_pose));
    auto image = test_support::makeImage(wall.imageAt(camera_pose), "mono8");
    image->header.stamp = ros::Time(100.0 + static_cast<double>(step));
    image->header.frame_id = "camera_optical_frame";
    sensor_msgs::CameraInfo info = syntheticCameraInfo();
    info.header = image->header;
    camera.publish(*image, info);
    ASSERT_TRUE(test_support::spinUntil([&] { return headings.size() == truths.size(); }, 30.0))
        << "no heading_correction for image " << step;
  }
  ASSERT_TRUE(test_support::spinUntil([&] { return poses.size() == truths.size(); }, 10.0));
  for (std::size_t k = 0; k < truths.size(); ++k) {
    const auto& p = poses[k].pose;
    EXPECT_EQ(poses[k].header.frame_id, "map");
    EXPECT_NEAR(p.pose.position.x, truths[k].x, 0.03) << k;
    EXPECT_NEAR(p.pose.position.y, truths[k].y, 0.03) << k;
    const double yaw = 2.0 * std::atan2(p.pose.orientation.z, p.pose.orientation.w);
    EXPECT_NEAR(wrapToPi(yaw - truths[k].yaw), 0.0, 0.005) << k;
    // Row-major (x, y, z, roll, pitch, yaw): estimated x, y, yaw; z, roll, pitch unobserved.
    EXPECT_GT(p.covariance[0], 0.0);
    EXPECT_GT(p.covariance[7], 0.0);
    EXPECT_GT(p.covariance[35], 0.0);
    EXPECT_EQ(p.covariance[14], 1e6);
    EXPECT_EQ(p.covariance[21], 1e6);
    EXPECT_EQ(p.covariance[1], p.covariance[6]);
    EXPECT_TRUE(headings[k].ok) << headings[k].status;
    EXPECT_EQ(headings[k].mode, "fast_hd");
    EXPECT_GE(headings[k].reference_index, 0);
  }
  EXPECT_GE(headings.back().reference_index, 3);
  // max_tracked_frames (2): of the four close frames at least two are tracked, and never more
  // than two frames in a row without features detected afresh (in the frame itself or, with
  // background_detection, on the worker in an earlier one).
  int tracked_close = 0, background_close = 0, run = 0;
  for (std::size_t k = 0; k < headings.size(); ++k) {
    run = headings[k].tracked && !headings[k].background ? run + 1 : 0;
    EXPECT_LE(run, 2) << k;
    if (k + 4 >= headings.size() && headings[k].tracked) ++tracked_close;
    if (k + 4 >= headings.size() && headings[k].background) ++background_close;
  }
  EXPECT_GE(tracked_close, 2);
  EXPECT_GE(background_close, 1);  // background_detection is on by default
  // The debug image: reference keyframe beside the current image.
  ASSERT_TRUE(test_support::spinUntil([&] { return debug.width > 0; }, 5.0));
  EXPECT_EQ(debug.encoding, "bgr8");
  EXPECT_EQ(debug.width, 1280u);
  EXPECT_EQ(debug.height, 480u);

  // Bad input: a camera of another size, and an image of an unrelated scene: explicit failures,
  // no pose.
  const std::size_t poses_before = poses.size();
  auto small = test_support::makeImage(cv::Mat(240, 320, CV_8UC1, cv::Scalar(90)), "mono8");
  small->header.stamp = ros::Time(200.0);
  sensor_msgs::CameraInfo small_info = test_support::makeCameraInfo(320, 240, 250.0);
  small_info.header = small->header;
  camera.publish(*small, small_info);
  ASSERT_TRUE(test_support::spinUntil([&] { return headings.size() == truths.size() + 1; }, 20.0));
  EXPECT_FALSE(headings.back().ok);
  EXPECT_NE(headings.back().status.find("taught at 640x480"), std::string::npos) << headings.back().status;
  auto other = test_support::makeImage(test_support::makeTexture(640, 480, 77), "mono8");
  other->header.stamp = ros::Time(201.0);
  sensor_msgs::CameraInfo info = syntheticCameraInfo();
  info.header = other->header;
  camera.publish(*other, info);
  ASSERT_TRUE(test_support::spinUntil([&] { return headings.size() == truths.size() + 2; }, 30.0));
  EXPECT_FALSE(headings.back().ok);
  EXPECT_EQ(headings.back().reference_index, -1);
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  EXPECT_EQ(poses.size(), poses_before);
}

namespace {

// Sets repeat_node's mode through dynamic_reconfigure; returns the mode the node reports back.
std::string reconfigureMode(const std::string& mode) {
  dynamic_reconfigure::Reconfigure srv;
  dynamic_reconfigure::StrParameter parameter;
  parameter.name = "mode";
  parameter.value = mode;
  srv.request.config.strs.push_back(parameter);
  EXPECT_TRUE(ros::service::waitForService("repeat_node/set_parameters", ros::Duration(10.0)));
  EXPECT_TRUE(ros::service::call("repeat_node/set_parameters", srv));
  for (const auto& s : srv.response.config.strs) {
    if (s.name == "mode") return s.value;
  }
  return "";
}

}  // namespace

// dynamic_reconfigure switches to the mu mode at run time: heading corrections from vertical
// lines and, with odometry, the heading-aided pose; an unknown mode is refused.
TEST(RepeatNode, ReconfiguredToMuModeWithOdometry) {
  ros::NodeHandle nh;
  test_support::TestCamera camera(nh, "camera/image_raw", 2);
  ros::Publisher odom_pub = nh.advertise<nav_msgs::Odometry>("odom", 10);
  std::vector<geometry_msgs::PoseWithCovarianceStamped> poses;
  std::vector<HeadingCorrectionStamped> headings;
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 20, [&](const auto& m) { poses.push_back(*m); });
  ros::Subscriber heading_sub = nh.subscribe<HeadingCorrectionStamped>(
      "repeat_node/heading_correction", 20, [&](const auto& m) { headings.push_back(*m); });
  ASSERT_TRUE(test_support::spinUntil(
      [&] {
        return camera.getNumSubscribers() > 0 && odom_pub.getNumSubscribers() > 0 &&
               heading_sub.getNumPublishers() > 0 && pose_sub.getNumPublishers() > 0;
      },
      30.0));
  EXPECT_EQ(reconfigureMode("no_such_mode"), "fast_hd");
  ASSERT_EQ(reconfigureMode("mu"), "mu");

  const test_support::SyntheticWall wall;
  const double s = 1.0;
  const PlanarPose camera_pose(0.08 * s, s, 0.04 * s + 0.02);
  const Pose2D truth = cameraAxesToRep103(camera_pose);
  publishOdometryAround(odom_pub, 300.0, 5.0);  // the odometry frame differs from the route's
  auto image = test_support::makeImage(wall.imageAt(camera_pose), "mono8");
  image->header.stamp = ros::Time(300.0);
  sensor_msgs::CameraInfo info = syntheticCameraInfo();
  info.header = image->header;
  camera.publish(*image, info);
  ASSERT_TRUE(test_support::spinUntil([&] { return !headings.empty(); }, 30.0));
  EXPECT_TRUE(headings.back().ok) << headings.back().status;
  EXPECT_EQ(headings.back().mode, "mu");
  ASSERT_TRUE(test_support::spinUntil([&] { return !poses.empty(); }, 5.0)) << "no mu-mode pose";
  const auto& p = poses.back().pose;
  const double yaw = 2.0 * std::atan2(p.pose.orientation.z, p.pose.orientation.w);
  // The visual heading (within the translation coupling of μ for this 10 cm offset).
  EXPECT_NEAR(wrapToPi(yaw - truth.yaw), 0.0, 2.0 * M_PI / 180.0);
  // The position: the keyframe the robot was assumed at (alignment), in the route frame.
  EXPECT_LT(std::hypot(p.pose.position.x - truth.x, p.pose.position.y - truth.y), 0.3);
  EXPECT_GT(p.covariance[35], 0.0);
  EXPECT_EQ(p.covariance[14], 1e6);

  // A frame without a heading fix (an unrelated scene): the heading-aided odometry alone is still
  // published, with a larger covariance, up to max_unaided_distance (3 m) since the last fix.
  const double fixed_variance = p.covariance[0];
  auto unrelatedFrame = [&](double stamp, double odom_x) {
    publishOdometryAround(odom_pub, stamp, odom_x);
    auto other = test_support::makeImage(test_support::makeTexture(640, 480, 77), "mono8");
    other->header.stamp = ros::Time(stamp);
    sensor_msgs::CameraInfo other_info = syntheticCameraInfo();
    other_info.header = other->header;
    const std::size_t before = headings.size();
    camera.publish(*other, other_info);
    EXPECT_TRUE(test_support::spinUntil([&] { return headings.size() > before; }, 30.0));
    EXPECT_FALSE(headings.back().ok);
    ros::WallDuration(0.3).sleep();
    ros::spinOnce();
  };
  const std::size_t poses_at_fix = poses.size();
  unrelatedFrame(302.0, 5.5);
  ASSERT_EQ(poses.size(), poses_at_fix + 1) << "no unaided mu-mode pose 0.5 m after the fix";
  EXPECT_GT(poses.back().pose.covariance[0], fixed_variance);
  unrelatedFrame(304.0, 9.0);  // 4 m since the fix
  EXPECT_EQ(poses.size(), poses_at_fix + 1);

  // A heading fix 0.15 rad away from the heading the odometry carries (the odometry did not turn)
  // is refused by the localization filter: a single frame's μ is never taken unconfirmed (here it
  // waits for the next frame's confirmation; against the previous fix's keyframe its μ would have
  // changed by ~75 px where the odometry predicts no change).
  publishOdometryAround(odom_pub, 306.0, 5.0);
  auto turned = test_support::makeImage(
      wall.imageAt(PlanarPose(camera_pose.x, camera_pose.z, camera_pose.theta + 0.15)), "mono8");
  turned->header.stamp = ros::Time(306.0);
  sensor_msgs::CameraInfo turned_info = syntheticCameraInfo();
  turned_info.header = turned->header;
  const std::size_t headings_before = headings.size();
  camera.publish(*turned, turned_info);
  ASSERT_TRUE(test_support::spinUntil([&] { return headings.size() > headings_before; }, 30.0));
  EXPECT_FALSE(headings.back().ok);
  EXPECT_NE(headings.back().status.find("localization filter: mu"), std::string::npos) << headings.back().status;
  EXPECT_EQ(reconfigureMode("fast_hd"), "fast_hd");
}

// A visual pose whose motion since the last accepted pose disagrees with the odometry's (here the
// odometry moved 1.5 m sideways, the images 0.2 m back) is refused: heading_correction ok = false
// naming the odometry disagreement, and no pose.
TEST(RepeatNode, OdometryGateRefusesAPoseOdometryContradicts) {
  ros::NodeHandle nh;
  test_support::TestCamera camera(nh, "camera/image_raw", 2);
  ros::Publisher odom_pub = nh.advertise<nav_msgs::Odometry>("odom", 10);
  std::vector<geometry_msgs::PoseWithCovarianceStamped> poses;
  std::vector<HeadingCorrectionStamped> headings;
  ros::Subscriber pose_sub = nh.subscribe<geometry_msgs::PoseWithCovarianceStamped>(
      "repeat_node/pose", 20, [&](const auto& m) { poses.push_back(*m); });
  ros::Subscriber heading_sub = nh.subscribe<HeadingCorrectionStamped>(
      "repeat_node/heading_correction", 20, [&](const auto& m) { headings.push_back(*m); });
  ASSERT_TRUE(test_support::spinUntil(
      [&] {
        return camera.getNumSubscribers() > 0 && odom_pub.getNumSubscribers() > 0 &&
               heading_sub.getNumPublishers() > 0 && pose_sub.getNumPublishers() > 0;
      },
      30.0));
  ASSERT_EQ(reconfigureMode("fast_hd"), "fast_hd");
  const test_support::SyntheticWall wall;
  auto publishFrame = [&](double s, double stamp, double odom_x, double odom_y) {
    publishOdometryAround(odom_pub, stamp, odom_x, odom_y);
    auto image = test_support::makeImage(wall.imageAt(PlanarPose(0.08 * s, s, 0.04 * s + 0.02)), "mono8");
    image->header.stamp = ros::Time(stamp);
    sensor_msgs::CameraInfo info = syntheticCameraInfo();
    info.header = image->header;
    const std::size_t before = headings.size();
    camera.publish(*image, info);
    return test_support::spinUntil([&] { return headings.size() > before; }, 30.0);
  };
  ASSERT_TRUE(publishFrame(1.0, 400.0, 5.0, 0.0));
  EXPECT_TRUE(headings.back().ok) << headings.back().status;
  ASSERT_TRUE(test_support::spinUntil([&] { return poses.size() == 1; }, 5.0));
  ASSERT_TRUE(publishFrame(0.8, 401.0, 5.0, 1.5));
  EXPECT_FALSE(headings.back().ok);
  EXPECT_NE(headings.back().status.find("odometry"), std::string::npos) << headings.back().status;
  ros::WallDuration(0.5).sleep();
  ros::spinOnce();
  EXPECT_EQ(poses.size(), 1u);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_repeat_node_interface");
  return RUN_ALL_TESTS();
}
