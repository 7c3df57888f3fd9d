// teach_node under faults (issue 7). The test starts the node itself (fork/exec of the built
// executable, HTR_TEACH_NODE_BINARY) so it holds the pid:
//  - killed with SIGKILL while recording: the route on disk loads with every keyframe the node had
//    reported stored (at most the one being written is lost) and each keyframe's files load;
//  - a route directory that cannot be written: the node exits at start, before any image, with a
//    message naming the directory. Root ignores permission bits (CI runs as root), so the case
//    that always runs is a directory the kernel refuses to everyone (/proc/1, procfs); a chmod
//    0555 directory is checked too when the test does not run as root.
#include <gtest/gtest.h>

#include <nav_msgs/Odometry.h>
#include <ros/ros.h>
#include <sys/stat.h>
#include <tf2_ros/static_transform_broadcaster.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "support/synthetic_route.h"
#include "synthetic_camera.h"
#include "homography_teach_repeat/TeachStatus.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "node_test_helpers.h"

using namespace homography_teach_repeat;

namespace {

std::vector<std::string> teachNodeCommand(const std::string& name) {
  return {HTR_TEACH_NODE_BINARY, "__name:=" + name};
}

}  // namespace

TEST(TeachNodeFaults, SigkillMidRouteLosesAtMostTheKeyframeBeingWritten) {
  ros::NodeHandle nh;
  std::string route_dir;
  ASSERT_TRUE(ros::param::get("/killed_teach_node/route_directory", route_dir));
  tf2_ros::StaticTransformBroadcaster static_tf;
  static_tf.sendTransform(test_support::levelCameraMount(0.0));
  test_support::TestCamera camera(nh, "camera/image_raw", 5);
  ros::Publisher odom_pub = nh.advertise<nav_msgs::Odometry>("odom", 50);
  const test_support::SyntheticWall wall;
  const sensor_msgs::CameraInfo info_template = test_support::syntheticCameraInfo();

  // A temporary file in keyframes/: writeFileAtomically is writing a keyframe file (or the index).
  auto writeInProgress = [&] {
    std::error_code error;
    for (const auto& entry : std::filesystem::directory_iterator(route_dir + "/keyframes", error)) {
      if (entry.path().filename().string().find(".tmp.") != std::string::npos) return true;
    }
    return false;
  };
  // The kill lands at a different moment of the keyframe cycle in each round: right after a
  // keyframe was reported, while the next images are processed and written, and (-1) the moment
  // the test sees a keyframe file being written.
  for (const double kill_delay_s : {0.0, 0.03, 0.07, 0.12, -1.0}) {
    const bool kill_while_writing = kill_delay_s < 0.0;
    SCOPED_TRACE(kill_while_writing ? std::string("kill while a keyframe file is written")
                                    : "kill " + std::to_string(kill_delay_s) + " s after the status");
    std::filesystem::remove_all(route_dir);  // nothing left from the previous round
    TeachStatus status;
    ros::Subscriber status_sub = nh.subscribe<TeachStatus>(
        "killed_teach_node/status", 10, [&](const auto& m) { status = *m; });
    test_support::ChildProcess node(teachNodeCommand("killed_teach_node"));
    ASSERT_TRUE(node.started());
    ASSERT_TRUE(test_support::spinUntil(
        [&] { return camera.getNumSubscribers() > 0 && odom_pub.getNumSubscribers() > 0 && !status.state.empty(); },
        30.0));

    // Images 5 cm apart along the synthetic route's path (keyframe_distance 0.1: a keyframe
    // every second image), odometry bracketing each image stamp, about 15 images a second (the
    // node processes and writes while they come). Once 6 keyframes are reported, the kill comes
    // kill_delay_s later, between or during the writes of the next ones.
    std::optional<ros::WallTime> kill_at;
    for (int step = 0; step < 400; ++step) {
      const double s = 0.05 * step;
      const PlanarPose camera_pose(0.08 * s, s, 0.04 * s);
      const Pose2D base = cameraAxesToRep103(camera_pose);
      const ros::Time stamp = ros::Time::now();
      for (const double dt : {-0.02, 0.02}) {
        odom_pub.publish(test_support::makeOdometry(stamp + ros::Duration(dt), base.x, base.y, base.yaw));
      }
      ros::WallDuration(0.03).sleep();
      auto image = test_support::makeImage(wall.imageAt(camera_pose), "mono8");
      image->header.stamp = stamp;
      image->header.frame_id = "camera_optical_frame";
      sensor_msgs::CameraInfo info = info_template;
      info.header = image->header;
      camera.publish(*image, info);
      bool writing = false;
      const ros::WallTime next_image = ros::WallTime::now() + ros::WallDuration(0.035);
      while (ros::WallTime::now() < next_image && !(kill_at && ros::WallTime::now() >= *kill_at)) {
        ros::spinOnce();
        if (kill_while_writing && status.keyframes >= 6 && writeInProgress()) {
          writing = true;
          break;
        }
        ros::WallDuration(0.0005).sleep();
      }
      if (writing) {
        kill_at = ros::WallTime::now();
        break;
      }
      if (!kill_at && !kill_while_writing && status.keyframes >= 6) {
        kill_at = ros::WallTime::now() + ros::WallDuration(kill_delay_s);
      }
      if (kill_at && ros::WallTime::now() >= *kill_at) break;
    }
    ASSERT_TRUE(kill_at.has_value()) << status.state << ": " << status.message;
    ros::spinOnce();
    const uint32_t reported = status.keyframes;
    node.kill(SIGKILL);
    const auto exit_code = node.waitForExit(10.0);
    ASSERT_TRUE(exit_code.has_value());
    EXPECT_EQ(*exit_code, 128 + SIGKILL);

    const auto route = loadRoute(route_dir);
    ASSERT_TRUE(route.isOk()) << route.status().toString();
    EXPECT_GE(route->keyframes.size(), reported) << "keyframes reported stored before the kill";
    EXPECT_LE(route->keyframes.size(), reported + 2);
    // Temporary files left behind: a write the kill interrupted (they are never read).
    int interrupted = 0;
    for (const auto& entry : std::filesystem::recursive_directory_iterator(route_dir)) {
      interrupted += entry.path().filename().string().find(".tmp.") != std::string::npos ? 1 : 0;
    }
    std::printf("killed %s: %u keyframes reported, %zu on disk, %d interrupted writes left as temporary "
                "files\n",
                kill_while_writing ? "while a keyframe file was written"
                                   : (std::to_string(kill_delay_s) + " s after keyframe 6 was reported").c_str(),
                reported, route->keyframes.size(), interrupted);
    for (std::size_t k = 0; k < route->keyframes.size(); ++k) {
      const auto image = loadKeyframeImage(*route, k);
      ASSERT_TRUE(image.isOk()) << image.status().toString();
      EXPECT_FALSE(image->empty());
      const auto features = loadKeyframeFeatures(*route, k);
      ASSERT_TRUE(features.isOk()) << features.status().toString();
      EXPECT_GT(features->keypoints.size(), 50U);
      EXPECT_TRUE(loadKeyframeLines(*route, k).isOk());
    }
  }
}

TEST(TeachNodeFaults, UnwritableRouteDirectoryStopsTheNodeAtStart) {
  struct Case {
    std::string name, directory;
  };
  std::vector<Case> cases{{"procfs_teach_node", "/proc/1"}};
  std::string read_only_dir;
  if (::geteuid() != 0) {
    read_only_dir = test_support::makeTemporaryDirectory("htr_read_only_route");
    ASSERT_EQ(::chmod(read_only_dir.c_str(), 0555), 0);
    cases.push_back({"read_only_teach_node", read_only_dir});
  } else {
    std::printf("running as root: permission bits do not stop root, the chmod 0555 case is not run\n");
  }
  for (const auto& c : cases) {
    SCOPED_TRACE(c.directory);
    ros::param::set("/" + c.name + "/route_directory", c.directory);
    ros::param::set("/" + c.name + "/overwrite", true);
    test_support::ChildProcess node(teachNodeCommand(c.name), /*capture_stderr=*/true);
    ASSERT_TRUE(node.started());
    const auto exit_code = node.waitForExit(30.0);
    ASSERT_TRUE(exit_code.has_value()) << "teach_node still runs with route_directory " << c.directory;
    EXPECT_EQ(*exit_code, 1);
    const std::string message = node.standardError();
    EXPECT_NE(message.find("route_directory"), std::string::npos) << message;
    EXPECT_NE(message.find("'" + c.directory + "'"), std::string::npos) << message;
    EXPECT_NE(message.find("not writable"), std::string::npos) << message;
  }
  if (!read_only_dir.empty()) ::chmod(read_only_dir.c_str(), 0755);
}

int main(int argc, char** argv) {
  testing::InitGoogleTest(&argc, argv);
  ros::init(argc, argv, "test_teach_node_faults");
  return RUN_ALL_TESTS();
}
