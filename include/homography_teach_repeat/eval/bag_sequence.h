// A rosbag as a RecordedSequence (recorded_sequence.h) for evaluate_sequence: what users record on
// their robot. A ROS target of its own (src/eval/ros): the ROS-free evaluation never sees it.
//  - images (sensor_msgs/Image) and their camera_info (the first one is used; default topic: the
//    image topic's namespace + "/camera_info");
//  - wheel odometry (nav_msgs/Odometry, base_link in odom);
//  - optional ground truth (nav_msgs/Odometry, e.g. the simulator's /ground_truth or a motion
//    capture system's), required for scoring;
//  - the camera mount from the bag's /tf_static and /tf (base_frame -> the images' frame_id): its
//    planar part, and its tilt as the constant level rotation (a robot without an IMU).
// Stamps are the messages' header stamps.
#pragma once

#include <string>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/eval/recorded_sequence.h"

namespace homography_teach_repeat {
namespace eval {

struct BagTopics {
  std::string image = "/camera/image_raw";
  std::string camera_info;  // empty: <image topic namespace>/camera_info
  std::string odometry = "/odom";
  std::string ground_truth;  // empty: none
  std::string base_frame = "base_link";
};

// kInvalidInput naming the problem: a bag that cannot be opened, a topic that is not in it (with the
// topics of that type it has), no camera_info, no odometry, no tf from base_frame to the camera, a
// ground-truth topic without messages.
Expected<RecordedSequence> readBagSequence(const std::string& path, const BagTopics& topics);

}  // namespace eval
}  // namespace homography_teach_repeat
