// checkSetup: a good set-up passes; each problem is named with the measured figure and a fix.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "homography_teach_repeat/teach_repeat/setup_check.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;

namespace {

// 5 s of a 640x480 camera at 10 Hz and odometry at 50 Hz on one clock, a level camera 0.2 m ahead.
SetupObservations goodSetup() {
  SetupObservations seen;
  seen.duration = 5.0;
  for (int i = 0; i < 50; ++i) seen.image_stamps.push_back(100.0 + 0.1 * i);
  for (int i = 0; i < 250; ++i) seen.odometry_stamps.push_back(100.0 + 0.02 * i);
  CameraCalibration c = test_support::syntheticCalibration();
  c.distortion_model = "plumb_bob";
  c.distortion = {0.0, 0.0, 0.0, 0.0, 0.0};
  seen.camera_info = c;
  seen.image_width = 640;
  seen.image_height = 480;
  Eigen::Matrix3d optical_in_base;  // columns: optical x (right) = -y, y (down) = -z, z (forward) = x
  optical_in_base << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  Eigen::Isometry3d mount = Eigen::Isometry3d::Identity();
  mount.linear() = optical_in_base;
  mount.translation() = Eigen::Vector3d(0.2, 0.0, 0.6);
  seen.camera_mount = mount;
  seen.features = 1200;
  seen.vertical_lines = 25;
  seen.shift_features = 2400;
  return seen;
}

// The problems' texts joined, for searching.
std::string problemsOf(const SetupObservations& seen, bool* blocking = nullptr) {
  std::string all;
  if (blocking != nullptr) *blocking = false;
  for (const SetupProblem& p : checkSetup(seen)) {
    EXPECT_FALSE(p.how_to_fix.empty()) << p.what;
    all += p.what + " | " + p.how_to_fix + "\n";
    if (blocking != nullptr) *blocking = *blocking || p.blocking;
  }
  return all;
}

bool mentions(const std::string& text, const std::string& needle) { return text.find(needle) != std::string::npos; }

}  // namespace

TEST(SetupCheck, AGoodSetupHasNoProblem) {
  EXPECT_TRUE(checkSetup(goodSetup()).empty()) << problemsOf(goodSetup());
  EXPECT_NEAR(stampRate(goodSetup().image_stamps), 10.0, 1e-9);
  EXPECT_EQ(stampRate({}), 0.0);
}

TEST(SetupCheck, CameraProblemsAreNamedWithTheFix) {
  bool blocking = false;
  SetupObservations no_images = goodSetup();
  no_images.image_stamps.clear();
  EXPECT_TRUE(mentions(problemsOf(no_images, &blocking), "no image in 5.0 s"));
  EXPECT_TRUE(blocking);
  SetupObservations no_info = goodSetup();
  no_info.camera_info.reset();
  EXPECT_TRUE(mentions(problemsOf(no_info), "no camera_info"));
  EXPECT_TRUE(mentions(problemsOf(no_info), "camera_calibration"));
  SetupObservations uncalibrated = goodSetup();
  uncalibrated.camera_info->fx = uncalibrated.camera_info->fy = 0.0;
  EXPECT_TRUE(mentions(problemsOf(uncalibrated), "not a calibration"));
  EXPECT_TRUE(mentions(problemsOf(uncalibrated), "all-zero K"));
  SetupObservations other_size = goodSetup();
  other_size.image_width = 1280;
  other_size.image_height = 960;
  EXPECT_TRUE(mentions(problemsOf(other_size), "camera_info is 640x480 but the images are 1280x960"));
  SetupObservations off_centre = goodSetup();
  off_centre.camera_info->cx = 700.0;
  EXPECT_TRUE(mentions(problemsOf(off_centre), "principal point (700.0, 239.5) is outside"));
  SetupObservations millimetres = goodSetup();
  millimetres.camera_info->fx = millimetres.camera_info->fy = 4.0;
  EXPECT_TRUE(mentions(problemsOf(millimetres, &blocking), "field of view"));
  EXPECT_FALSE(blocking);  // a warning: it might be a fisheye
}

TEST(SetupCheck, RatesStampsAndOdometry) {
  SetupObservations slow = goodSetup();
  slow.image_stamps = {100.0, 100.5, 101.0, 101.5};
  EXPECT_TRUE(mentions(problemsOf(slow), "images at 2.0 Hz"));
  SetupObservations no_odometry = goodSetup();
  no_odometry.odometry_stamps.clear();
  EXPECT_TRUE(mentions(problemsOf(no_odometry), "no odometry in 5.0 s"));
  SetupObservations other_clock = goodSetup();
  for (double& s : other_clock.odometry_stamps) s += 1e9;
  EXPECT_TRUE(mentions(problemsOf(other_clock), "do not overlap"));
  EXPECT_TRUE(mentions(problemsOf(other_clock), "use_sim_time"));
  SetupObservations late = goodSetup();
  for (double& s : late.image_stamps) s += 0.5;
  // overlapping, but the newest image is 0.42 s ahead of the newest odometry
  bool blocking = true;
  EXPECT_TRUE(mentions(problemsOf(late, &blocking), "the newest image is 0.420 s ahead of the newest odometry"))
      << problemsOf(late);
  EXPECT_FALSE(blocking);
  SetupObservations nan = goodSetup();
  nan.non_finite_odometry = 3;
  nan.odometry_covariance_zero = true;
  EXPECT_TRUE(mentions(problemsOf(nan), "3 odometry messages with NaN"));
  EXPECT_TRUE(mentions(problemsOf(nan), "covariance is all zero"));
}

TEST(SetupCheck, CameraMountAndView) {
  SetupObservations no_tf = goodSetup();
  no_tf.camera_mount.reset();
  no_tf.camera_mount_problem = "\"camera_optical_frame\" passed to lookupTransform does not exist";
  EXPECT_TRUE(mentions(problemsOf(no_tf), "no tf from base_link"));
  EXPECT_TRUE(mentions(problemsOf(no_tf), "does not exist"));
  SetupObservations pitched = goodSetup();
  // Pitched 5° down about base y.
  pitched.camera_mount->linear() = Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()) * pitched.camera_mount->linear();
  const std::string text = problemsOf(pitched);
  EXPECT_TRUE(mentions(text, "5.0 deg from level (its axis 5.0 deg down)")) << text;
  EXPECT_TRUE(mentions(text, "estimate_keyframe_tilt"));
  SetupObservations bare = goodSetup();
  bare.features = 40;
  bare.vertical_lines = 2;
  bare.shift_features = 90;
  bool blocking = true;
  EXPECT_TRUE(mentions(problemsOf(bare, &blocking), "40 features"));
  EXPECT_FALSE(blocking);  // warnings: teaching works, worse
  EXPECT_TRUE(mentions(problemsOf(bare), "2 vertical lines"));
  EXPECT_TRUE(mentions(problemsOf(bare), "90 features for the seasonal heading fix"));
}
