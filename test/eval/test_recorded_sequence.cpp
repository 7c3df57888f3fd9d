// The recorded-data readers of evaluate_sequence (recorded_sequence.h) on small data sets written
// here in the KITTI and Strecha layouts, the level-camera ground truth, and the image preparation.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <unistd.h>

#include "homography_teach_repeat/eval/recorded_sequence.h"
#include "homography_teach_repeat/eval/sequence_evaluation.h"

using namespace homography_teach_repeat;
namespace fs = std::filesystem;

namespace {

// Camera -> world rotation of a camera (x right, y down, z forward) turned left by `yaw` about the
// world's up (−y) and pitched down by `pitch` about its own x.
Eigen::Matrix3d cameraRotation(double yaw, double pitch) {
  return Eigen::AngleAxisd(-yaw, Eigen::Vector3d::UnitY()).toRotationMatrix() *
         Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitX()).toRotationMatrix();
}

class KittiFolder : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("htr_kitti_test_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "image_0");
    for (int i = 0; i < 3; ++i) {
      char name[32];
      std::snprintf(name, sizeof(name), "%06d.png", i);
      cv::imwrite((dir_ / "image_0" / name).string(), cv::Mat(10, 20, CV_8UC1, cv::Scalar(40 * i)));
    }
    std::ofstream(dir_ / "calib.txt") << "P0: 700 0 10 0 0 700 5 0 0 0 1 0\nP1: 700 0 10 -380 0 700 5 0 0 0 1 0\n";
    std::ofstream(dir_ / "times.txt") << "0.0\n0.1\n0.2\n0.3\n";
    std::ofstream poses(dir_ / "07.txt");
    // Straight ahead along the camera's z: 0, 0.5, 1.0 m, then turned.
    poses << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0.5\n1 0 0 0 0 1 0 0 0 0 1 1.0\n";
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

}  // namespace

TEST(LevelTrajectory, RemovesTheTiltAndGivesRep103Poses) {
  // Three cameras 2 deg pitched down on average, driving 1 m forward then turning 10 deg left.
  const std::vector<Eigen::Matrix3d> rotations{cameraRotation(0.0, 0.03), cameraRotation(0.0, 0.035),
                                               cameraRotation(0.1745, 0.04)};
  const std::vector<Eigen::Vector3d> centres{Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0, 0, 1),
                                             Eigen::Vector3d(-0.2, 0, 2)};
  const auto level = eval::levelTrajectory(rotations, centres);
  ASSERT_EQ(level.planar.size(), 3u);
  EXPECT_NEAR(level.planar[1].x, 1.0, 1e-3);  // forward
  EXPECT_NEAR(level.planar[1].y, 0.0, 1e-3);
  EXPECT_NEAR(level.planar[2].y, 0.2, 1e-3);  // x = -0.2 (left) -> y = +0.2
  EXPECT_NEAR(level.planar[2].yaw, 0.1745, 1e-3);
  // Each level rotation makes the camera's y axis the common down.
  for (std::size_t i = 0; i < 3; ++i) {
    const Eigen::Matrix3d level_to_world = rotations[i] * level.camera_to_level[i].transpose();
    EXPECT_NEAR(level_to_world.col(1).dot(level.down), 1.0, 1e-9);
  }
  // The centres move in the plane y = 0: its normal is down, not the cameras' mean axis.
  EXPECT_NEAR(level.down.dot(Eigen::Vector3d::UnitY()), 1.0, 1e-9);
  EXPECT_NEAR(Eigen::AngleAxisd(level.camera_to_level[0]).angle(), 0.03, 1e-6);
  for (const double h : level.height) EXPECT_NEAR(h, 0.0, 1e-9);
}

TEST(LevelTrajectory, LevelsToThePlaneTheCentresMoveIn) {
  // A camera pitched 3 deg down on its mount, driven over a floor that is not the world's y = 0:
  // the floor's normal is 2 deg off the world's y axis. Levelled by the cameras' mean y axis the
  // route would climb; levelled to the floor it stays at one height.
  const Eigen::Matrix3d floor_to_world = Eigen::AngleAxisd(0.035, Eigen::Vector3d::UnitX()).toRotationMatrix();
  std::vector<Eigen::Matrix3d> rotations;
  std::vector<Eigen::Vector3d> centres;
  const double yaws[] = {0.0, 0.0, 0.3, 0.8, 1.2};
  const Eigen::Vector2d floor_points[] = {{0, 0}, {0, 2}, {-0.5, 4}, {-2, 5.5}, {-4, 6}};  // (x, z)
  for (int i = 0; i < 5; ++i) {
    rotations.push_back(floor_to_world * cameraRotation(yaws[i], 0.05));
    centres.push_back(floor_to_world * Eigen::Vector3d(floor_points[i].x(), 0.0, floor_points[i].y()));
  }
  const auto level = eval::levelTrajectory(rotations, centres);
  EXPECT_NEAR(level.down.dot(floor_to_world.col(1)), 1.0, 1e-9);
  for (std::size_t i = 0; i < 5; ++i) {
    EXPECT_NEAR(level.height[i], 0.0, 1e-9);
    EXPECT_NEAR(Eigen::AngleAxisd(level.camera_to_level[i]).angle(), 0.05, 1e-9);  // the mount's pitch
    EXPECT_NEAR(level.planar[i].yaw, yaws[i], 1e-9);
  }
  EXPECT_NEAR(level.planar[1].x, 2.0, 1e-9);

  // Two centres, or a cloud as thick as it is wide, give no floor: the cameras' mean axis stays.
  const auto meanAxis = [](const std::vector<Eigen::Matrix3d>& r) {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto& m : r) sum += m.col(1);
    return sum.normalized();
  };
  auto two = rotations;
  auto two_centres = centres;
  two.resize(2);
  two_centres.resize(2);
  EXPECT_NEAR(eval::levelTrajectory(two, two_centres).down.dot(meanAxis(two)), 1.0, 1e-9);
  EXPECT_NEAR(eval::levelTrajectory(rotations, centres, eval::LevelTo::kMeanCameraAxis).down.dot(meanAxis(rotations)),
              1.0, 1e-9);  // asked for
  centres[2] += floor_to_world.col(1) * 1.0;  // 1 m below the floor
  centres[4] -= floor_to_world.col(1) * 1.5;
  EXPECT_NEAR(eval::levelTrajectory(rotations, centres).down.dot(meanAxis(rotations)), 1.0, 1e-9);
}

TEST_F(KittiFolder, ReadsImagesStampsCameraAndGroundTruth) {
  const auto sequence = eval::readKittiSequence(dir_.string());
  ASSERT_TRUE(sequence.isOk()) << sequence.status().toString();
  ASSERT_EQ(sequence->stamps.size(), 3u);  // times.txt is longer: the whole recording
  EXPECT_DOUBLE_EQ(sequence->stamps[2], 0.2);
  ASSERT_EQ(sequence->ground_truth.size(), 3u);
  EXPECT_NEAR(sequence->ground_truth[2].pose.x, 1.0, 1e-9);
  EXPECT_TRUE(sequence->odometry.empty());  // KITTI has no wheel odometry
  const auto image = sequence->load_image(1);
  ASSERT_TRUE(image.isOk());
  EXPECT_EQ(image->camera.width, 20);
  EXPECT_DOUBLE_EQ(image->camera.fx, 700.0);
  EXPECT_DOUBLE_EQ(image->camera.cy, 5.0);
  EXPECT_EQ(image->image.at<unsigned char>(0, 0), 40);
  ASSERT_TRUE(image->camera_to_level.has_value());
}

TEST_F(KittiFolder, NamesWhatIsMissingOrShort) {
  fs::remove(dir_ / "calib.txt");
  auto sequence = eval::readKittiSequence(dir_.string());
  ASSERT_FALSE(sequence.isOk());
  EXPECT_NE(sequence.status().message().find("calib.txt"), std::string::npos) << sequence.status().message();

  std::ofstream(dir_ / "calib.txt") << "P0: 700 0 10 0 0 700 5 0 0 0 1 0\n";
  std::ofstream(dir_ / "07.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 0.5\n";
  sequence = eval::readKittiSequence(dir_.string());
  ASSERT_FALSE(sequence.isOk());
  EXPECT_NE(sequence.status().message().find("2 poses for 3 images"), std::string::npos) << sequence.status().message();

  std::ofstream(dir_ / "07.txt") << "1 0 0 0 0 1 0 0 0 0 1 0\n1 0 0 0 0 1 0 0 0 0 1 nan\n1 0 0 0 0 1 0 0 0 0 1 1\n";
  sequence = eval::readKittiSequence(dir_.string());
  ASSERT_FALSE(sequence.isOk());
  EXPECT_NE(sequence.status().message().find("line 2"), std::string::npos) << sequence.status().message();

  fs::remove_all(dir_ / "image_0");
  sequence = eval::readKittiSequence(dir_.string());
  ASSERT_FALSE(sequence.isOk());
  EXPECT_NE(sequence.status().message().find("image_0"), std::string::npos) << sequence.status().message();
  EXPECT_FALSE(eval::readKittiSequence((dir_ / "nowhere").string()).isOk());
}

TEST(StrechaSequence, ReadsAnyNumberOfViews) {
  const fs::path dir = fs::temp_directory_path() / ("htr_strecha_test_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "images");
  fs::create_directories(dir / "gt_dense_cameras");
  for (int i = 0; i < 4; ++i) {
    cv::imwrite((dir / "images" / eval::strechaImageName(i)).string(), cv::Mat(8, 12, CV_8UC1, cv::Scalar(9)));
    std::ofstream camera(dir / "gt_dense_cameras" / (eval::strechaImageName(i) + ".camera"));
    camera << "100 0 6\n0 100 4\n0 0 1\n0 0 0\n1 0 0\n0 1 0\n0 0 1\n" << 0.5 * i << " 0 0\n12 8\n";
  }
  auto sequence = eval::readStrechaSequence(dir.string());
  ASSERT_TRUE(sequence.isOk()) << sequence.status().toString();
  EXPECT_EQ(sequence->stamps.size(), 4u);
  EXPECT_NEAR(sequence->ground_truth[3].pose.y, -1.5, 1e-9);  // 1.5 m to the right
  // A view whose camera file is missing is named.
  fs::remove(dir / "gt_dense_cameras" / "0002.jpg.camera");
  sequence = eval::readStrechaSequence(dir.string());
  ASSERT_FALSE(sequence.isOk());
  EXPECT_NE(sequence.status().message().find("0002.jpg.camera"), std::string::npos);
  fs::remove_all(dir);
}

TEST(PrepareImage, ScalesKeepingPixelCentresAndLevelsByTheRotation) {
  eval::SequenceImage frame;
  frame.image = cv::Mat(40, 60, CV_8UC1, cv::Scalar(0));
  cv::rectangle(frame.image, cv::Rect(28, 18, 4, 4), cv::Scalar(255), cv::FILLED);
  frame.camera.width = 60;
  frame.camera.height = 40;
  frame.camera.fx = frame.camera.fy = 50.0;
  frame.camera.cx = 29.5;
  frame.camera.cy = 19.5;
  const auto half = eval::prepareImage(frame, std::nullopt, 0.5);
  ASSERT_TRUE(half.isOk());
  EXPECT_EQ(half->image.cols, 30);
  EXPECT_DOUBLE_EQ(half->camera.fx, 25.0);
  EXPECT_DOUBLE_EQ(half->camera.cx, 14.5);  // the centre stays the centre
  // A 5.7 deg pitch: the spot at the principal point moves by f·tan(0.1) = 5 px in y.
  const Eigen::Matrix3d pitch = Eigen::AngleAxisd(0.1, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const auto level = eval::prepareImage(frame, pitch, 1.0);
  ASSERT_TRUE(level.isOk());
  const cv::Moments m = cv::moments(level->image, false);
  EXPECT_NEAR(m.m01 / m.m00, 19.5 - 50.0 * std::tan(0.1), 0.6);
  EXPECT_NEAR(m.m10 / m.m00, 29.5, 0.6);
  frame.camera.fx = 0.0;
  EXPECT_FALSE(eval::prepareImage(frame, std::nullopt, 1.0).isOk());
}
