// Recorded data for evaluate_sequence (docs/evaluation.md, "Recorded sequences"): images with
// their camera, wheel odometry, ground truth and the camera mount, read from a data set's own
// layout. One structure for every source, so the teach and repeat runs over them (
// sequence_evaluation.h) never know where the data came from:
//  - the KITTI odometry layout (readKittiSequence): image_0/NNNNNN.png, calib.txt, times.txt and a
//    poses file (3x4 [R|t] per line, camera i -> camera 0);
//  - a Strecha multi-view set of any number of views (readStrechaSequence; fountain_dataset.h);
//  - a rosbag (bag_sequence.h, a ROS target of its own).
// Ground truth is the planar pose (REP-103: x forward, y left, yaw CCW) of the level camera
// (docs/math.md §1.1): the camera rotated about its centre until its y axis is gravity's "down",
// projected onto the horizontal plane. Data sets without wheel odometry have an empty `odometry`;
// the evaluation synthesizes it from the ground truth with a stated error model.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "homography_teach_repeat/common/status.h"
#include "homography_teach_repeat/geometry/pinhole_camera.h"
#include "homography_teach_repeat/geometry/planar_pose.h"

namespace homography_teach_repeat {
namespace eval {

struct StampedPose2D {
  double stamp = 0.0;
  Pose2D pose;
};

struct SequenceImage {
  cv::Mat image;  // as recorded (8-bit grey or colour; distorted when the camera says so)
  CameraCalibration camera;
  // Rotation of the optical frame into the level camera frame at this instant, from gravity (the
  // ground truth here; an IMU on a robot). Absent: the data set does not know it.
  std::optional<Eigen::Matrix3d> camera_to_level;
};

struct RecordedSequence {
  std::string description;    // the source, for the output
  std::vector<double> stamps;  // [s] one per image, increasing
  // Loads image `index` (0 <= index < stamps.size()); kInvalidInput naming the file or message.
  std::function<Expected<SequenceImage>(int index)> load_image;
  std::vector<StampedPose2D> odometry;      // base_link in odom; empty: none recorded
  std::vector<StampedPose2D> ground_truth;  // base_link, planar; empty: none
  // The camera in base_link: planar part (optical centre, yaw of the optical axis) and the
  // rotation of the optical frame into the level frame of a constant mount (a calibrated tf, or a
  // robot without an IMU that measured its mount once).
  Pose2D camera_mount;
  Eigen::Matrix3d mount_camera_to_level = Eigen::Matrix3d::Identity();
  std::string mount_source;  // how the mount was found, for the output
};

// The axes of the level frame of a camera (columns, world coordinates): y = `down`, z = the
// optical axis made horizontal, x = y × z. `camera_to_world`: the camera's rotation (columns: its
// axes in the world). The camera -> level rotation is levelAxes(...)ᵀ · camera_to_world.
Eigen::Matrix3d levelAxes(const Eigen::Matrix3d& camera_to_world, const Eigen::Vector3d& down);

// What levelTrajectory takes as down: the plane the centres move in (a robot's floor; the default),
// or the cameras' mean y axis (gravity for photographs held level on average: the world's vertical
// edges stay vertical, which μ's vertical lines need).
enum class LevelTo { kMotionPlane, kMeanCameraAxis };

// Ground-truth cameras (rotation camera -> world, centre in the world; x right, y down, z forward)
// as level cameras: `camera_to_level` per camera and the planar pose of each in the horizontal
// frame of the first (origin at its centre, x along its level optical axis, y to its left).
// `down` with LevelTo::kMotionPlane: the normal of the plane the centres move in (least squares,
// signed like the cameras' mean y axis), a robot's floor, in which the planar model holds whatever
// the camera's pitch or roll on its mount (KITTI 07's camera is 0.8° off its road: levelled by its
// own mean axis the car climbed 0.9 m in 90 m; fountain-P11's hand-held views 2.7°, heights 23 cm apart;
// docs/evaluation.md). Where the centres do not give a plane (fewer than three, on a line, or a
// cloud more than 5 % as thick as it is wide) or that plane is more than 15° from the cameras' mean
// y axis, and with LevelTo::kMeanCameraAxis, that mean axis.
struct LevelTrajectory {
  std::vector<Eigen::Matrix3d> camera_to_level;
  std::vector<Pose2D> planar;
  std::vector<double> height;  // [m] of each centre above the first's (up positive)
  Eigen::Vector3d down = Eigen::Vector3d::UnitY();
};
LevelTrajectory levelTrajectory(const std::vector<Eigen::Matrix3d>& camera_to_world,
                                const std::vector<Eigen::Vector3d>& centres, LevelTo level_to = LevelTo::kMotionPlane);

// KITTI odometry layout: `directory` holds image_0/ (000000.png ...), calib.txt (P0 of the left
// grey camera), times.txt and a poses file (`poses_file`; empty: the only *.txt other than
// calib.txt, times.txt and README*, e.g. 07.txt). Images are counted from 000000 up to the first missing
// one; times and poses may be longer (the whole recording) but not shorter. kInvalidInput naming
// the missing or malformed file.
Expected<RecordedSequence> readKittiSequence(const std::string& directory, const std::string& poses_file = "");

// A Strecha ground-truth camera file (NNNN.jpg.camera: K, 3 distortion terms, R camera -> world,
// centre, width height).
struct GroundTruthCamera {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();  // camera-to-world
  Eigen::Vector3d C = Eigen::Vector3d::Zero();      // centre, world
  int width = 0, height = 0;
};
// kInvalidInput naming the file when it is missing, truncated or not finite.
Expected<GroundTruthCamera> readStrechaCamera(const std::string& path);
// "0003.jpg" for 3.
std::string strechaImageName(int index);

// A Strecha set (images/NNNN.jpg and gt_dense_cameras/NNNN.jpg.camera from 0000, any count),
// stamped 0.1 s apart in view order. kInvalidInput naming the missing or malformed file.
Expected<RecordedSequence> readStrechaSequence(const std::string& directory);

}  // namespace eval
}  // namespace homography_teach_repeat
