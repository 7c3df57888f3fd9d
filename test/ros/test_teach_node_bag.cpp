// teach_node on a recorded teach run played back with `rosbag play` (teach_repeat_compressed_bag.test:
// JPEG images on camera/image_raw/compressed, one frame cut short): after the bag, ~finish writes a
// route whose keyframes and planes are those of the synthetic wall, and teach_node's diagnostics
// count the frame it could not decode. The route is the fixture of repeat_node_compressed_bag.test.
#include <gtest/gtest.h>

#include <diagnostic_msgs/DiagnosticArray.h>
#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sensor_msgs/CameraInfo.h>
#include <std_srvs/Trigger.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <string>

#include "homography_teach_repeat/TeachStatus.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;

TEST(TeachNode, TeachesFromACompressedRecording) {
  ros::NodeHandle nh, private_nh("~");
  std::string route_directory;
  ASSERT_TRUE(private_nh.getParam("route", route_directory));
  const int frames = private_nh.param("frames", 16);
  const int corrupt_frames = private_nh.param("corrupt_frames", 0);

  // The camera at base_link, level (the synthetic route's mount).
  tf2_ros::StaticTransformBroadcaster static_tf;
  static_tf.sendTransform(test_support::levelCameraMount(0.0));

  // Every topic of the bag has a subscriber (rosbag play --wait-for-subscribers waits for them).
  int camera_infos = 0;
  ros::Subscriber info_sub = nh.subscribe<sensor_msgs::CameraInfo>(
      "camera/camera_info", 50, [&](const sensor_msgs::CameraInfoConstPtr&) { ++camera_infos; });
  int truths = 0;
  ros::Subscriber truth_sub =
      nh.subscribe<nav_msgs::Odometry>("ground_truth", 50, [&](const nav_msgs::OdometryConstPtr&) { ++truths; });
  TeachStatus status;
  ros::Subscriber status_sub = nh.subscribe<TeachStatus>("teach_node/status", 5,
                                                         [&](const TeachStatus::ConstPtr& s) { status = *s; });
  std::string dropped;
  ros::Subscriber diagnostics_sub = nh.subscribe<diagnostic_msgs::DiagnosticArray>("/diagnostics", 20, [&](const auto& m) {
    for (const auto& s : m->status) {
      if (s.name.find("teach_node") == std::string::npos) continue;
      for (const auto& value : s.values) {
        if (value.key == "undecodable images dropped") dropped = value.value;
      }
    }
  });
  ASSERT_TRUE(test_support::spinUntil([&] { return camera_infos == frames && truths == frames; }, 90.0))
      << "the bag was not played completely: " << camera_infos << " of " << frames << " frames";
  // The last image's processing, and a diagnostics update after it.
  ASSERT_TRUE(test_support::spinUntil([&] { return dropped == std::to_string(corrupt_frames); }, 10.0))
      << "diagnostics: undecodable images dropped '" << dropped << "'";
  ros::WallDuration(1.0).sleep();

  std_srvs::Trigger finish;
  ASSERT_TRUE(ros::service::waitForService("teach_node/finish", ros::Duration(10.0)));
  ASSERT_TRUE(ros::service::call("teach_node/finish", finish));
  EXPECT_TRUE(finish.response.success) << finish.response.message;

  const auto route = loadRoute(route_directory);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  // 16 images 10 cm apart, a keyframe every 0.25 m: 6 or 7 (one image lost).
  EXPECT_GE(route->keyframes.size(), 5u);
  const test_support::SyntheticWall wall;
  for (const auto& keyframe : route->keyframes) {
    ASSERT_TRUE(keyframe.plane.has_value()) << "keyframe " << keyframe.index << ": " << finish.response.message;
  }
  EXPECT_LT((route->keyframes.front().plane->normal - wall.plane.normal).norm(), 0.03);
  EXPECT_NEAR(route->keyframes.front().plane->distance, wall.plane.distance, 1e-9);
  // The taught poses are the bag's odometry (= the ground truth of the synthetic path).
  for (const auto& keyframe : route->keyframes) {
    const double s = keyframe.pose.x;  // the path's forward coordinate (cameraAxesToRep103: x = z)
    EXPECT_NEAR(keyframe.pose.y, -0.08 * s, 1e-6) << "keyframe " << keyframe.index;
  }
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_teach_node_bag");
  return RUN_ALL_TESTS();
}
