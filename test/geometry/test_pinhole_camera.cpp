#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "homography_teach_repeat/geometry/pinhole_camera.h"

using namespace homography_teach_repeat;

namespace {

CameraCalibration calibration(const std::string& model, std::vector<double> distortion) {
  CameraCalibration c;
  c.width = 640;
  c.height = 480;
  c.fx = 520.0;
  c.fy = 515.0;
  c.cx = 321.5;
  c.cy = 243.0;
  c.distortion_model = model;
  c.distortion = std::move(distortion);
  return c;
}

// Expects the constructor to throw std::invalid_argument whose message contains `fragment`.
void expectRejected(const CameraCalibration& c, const std::string& fragment) {
  try {
    PinholeCamera camera(c);
    FAIL() << "accepted a calibration that should fail with '" << fragment << "'";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find(fragment), std::string::npos) << e.what();
  }
}

void expectRoundTrip(const PinholeCamera& camera, double tolerance_px) {
  for (double u = 0.0; u <= 639.0; u += 71.0) {
    for (double v = 0.0; v <= 479.0; v += 53.0) {
      const cv::Point2d distorted(u, v);
      const cv::Point2d undistorted = camera.undistortPixel(distorted);
      ASSERT_TRUE(std::isfinite(undistorted.x) && std::isfinite(undistorted.y));
      const cv::Point2d back = camera.distortPixel(undistorted);
      EXPECT_NEAR(back.x, u, tolerance_px) << "at (" << u << ", " << v << ")";
      EXPECT_NEAR(back.y, v, tolerance_px) << "at (" << u << ", " << v << ")";
    }
  }
}

}  // namespace

TEST(PinholeCamera, IntrinsicMatrixAndInverse) {
  const PinholeCamera camera(calibration("none", {}));
  EXPECT_DOUBLE_EQ(camera.K()(0, 0), 520.0);
  EXPECT_DOUBLE_EQ(camera.K()(1, 2), 243.0);
  EXPECT_LT((camera.K() * camera.Kinverse() - Eigen::Matrix3d::Identity()).norm(), 1e-15);
  EXPECT_FALSE(camera.hasDistortion());
}

TEST(PinholeCamera, ProjectAndBackProjectWithoutDistortion) {
  const PinholeCamera camera(calibration("none", {}));
  const Eigen::Vector3d point(0.4, -0.2, 2.0);
  const cv::Point2d pixel = camera.project(point);
  EXPECT_NEAR(pixel.x, 520.0 * 0.2 + 321.5, 1e-12);
  EXPECT_NEAR(pixel.y, 515.0 * -0.1 + 243.0, 1e-12);
  const Eigen::Vector2d normalised = camera.pixelToNormalized(pixel);
  EXPECT_NEAR(normalised.x(), 0.2, 1e-15);
  EXPECT_NEAR(normalised.y(), -0.1, 1e-15);
  EXPECT_TRUE(std::isnan(camera.project(Eigen::Vector3d(0, 0, -1)).x));  // behind the camera
}

TEST(PinholeCamera, RejectsZeroNegativeAndNaNFocalLength) {
  auto c = calibration("none", {});
  c.fx = 0.0;
  expectRejected(c, "fx must be finite and > 0");
  c.fx = -300.0;
  expectRejected(c, "fx must be finite and > 0");
  c = calibration("none", {});
  c.fy = std::numeric_limits<double>::quiet_NaN();
  expectRejected(c, "fy must be finite and > 0");
  c = calibration("none", {});
  c.cx = std::numeric_limits<double>::infinity();
  expectRejected(c, "principal point");
}

TEST(PinholeCamera, RejectsMissingCalibrationAndBadSize) {
  CameraCalibration zero;  // what an all-zero camera_info becomes
  expectRejected(zero, "image size");
  auto c = calibration("none", {});
  c.height = -1;
  expectRejected(c, "image size");
}

TEST(PinholeCamera, RejectsNaNCoefficientsAndWrongCounts) {
  expectRejected(calibration("plumb_bob", {0.1, NAN, 0.0, 0.0, 0.0}), "D[1] is not finite");
  expectRejected(calibration("single_parameter_radial", {NAN}), "D[0] is not finite");
  expectRejected(calibration("plumb_bob", {0.1, 0.2}), "plumb_bob needs 4 or 5");
  expectRejected(calibration("rational_polynomial", {0.1, 0.2, 0, 0, 0}), "needs 8");
  expectRejected(calibration("single_parameter_radial", {0.1, 0.2}), "needs 1 coefficient");
  expectRejected(calibration("none", {0.1}), "non-zero distortion");
  expectRejected(calibration("fisheye42", {}), "unknown distortion model 'fisheye42'");
}

TEST(PinholeCamera, PlumbBobRoundTrip) {
  // Coefficients of the OpenCV sample camera (opencv_chessboard/left_intrinsics.yml, k1 = −0.266).
  const PinholeCamera camera(calibration("plumb_bob", {-0.266, 0.0887, 0.0002, -0.0004, 0.0}));
  EXPECT_TRUE(camera.hasDistortion());
  expectRoundTrip(camera, 1e-6);
}

TEST(PinholeCamera, PlumbBobWithFourCoefficientsIsPadded) {
  const PinholeCamera camera(calibration("plumb_bob", {-0.1, 0.01, 0.0, 0.0}));
  EXPECT_EQ(camera.distortionCoefficients().size(), 5u);
}

TEST(PinholeCamera, RationalPolynomialRoundTrip) {
  const PinholeCamera camera(
      calibration("rational_polynomial", {0.2, -0.05, 0.001, 0.0005, 0.01, 0.15, -0.02, 0.005}));
  expectRoundTrip(camera, 1e-6);
}

TEST(PinholeCamera, SingleParameterRadialRoundTripBarrelAndPincushion) {
  expectRoundTrip(PinholeCamera(calibration("single_parameter_radial", {-0.2})), 1e-9);
  expectRoundTrip(PinholeCamera(calibration("single_parameter_radial", {0.3})), 1e-9);
}

// The single-parameter model is plumb_bob with only k1: both forward models must agree.
TEST(PinholeCamera, SingleParameterRadialEqualsPlumbBobK1) {
  const PinholeCamera single(calibration("single_parameter_radial", {-0.15}));
  const PinholeCamera plumb(calibration("plumb_bob", {-0.15, 0.0, 0.0, 0.0, 0.0}));
  for (const cv::Point2d& p : {cv::Point2d(10, 20), cv::Point2d(600, 400), cv::Point2d(321, 243)}) {
    const cv::Point2d a = single.distortPixel(p), b = plumb.distortPixel(p);
    EXPECT_NEAR(a.x, b.x, 1e-9);
    EXPECT_NEAR(a.y, b.y, 1e-9);
  }
}

TEST(PinholeCamera, SingleParameterRadialKnownValue) {
  // A point at normalised radius 0.5 with k1 = −0.2 is imaged at radius 0.5 (1 − 0.2·0.25) = 0.475.
  const PinholeCamera camera(calibration("single_parameter_radial", {-0.2}));
  const cv::Point2d distorted(321.5 + 520.0 * 0.475, 243.0);
  const Eigen::Vector2d normalised = camera.pixelToNormalized(distorted);
  EXPECT_NEAR(normalised.x(), 0.5, 1e-14);
  EXPECT_NEAR(normalised.y(), 0.0, 1e-14);
}

// Beyond the fold of a barrel model (r_d > 2/(3 sqrt(−3k))) no undistorted point exists.
TEST(PinholeCamera, SingleParameterRadialOutsideValidRegionIsNaN) {
  const PinholeCamera camera(calibration("single_parameter_radial", {-1.0}));
  // r_peak = 1/sqrt(3) -> r_d max = 0.3849; normalised radius 0.5 is beyond.
  const cv::Point2d outside(321.5 + 520.0 * 0.5, 243.0);
  EXPECT_TRUE(std::isnan(camera.undistortPixel(outside).x));
}

TEST(PinholeCamera, CalibrationRoundTrip) {
  const PinholeCamera camera(calibration("plumb_bob", {-0.1, 0.01, 0.0, 0.0, 0.0}));
  const PinholeCamera copy(camera.calibration());
  EXPECT_EQ(copy.distortionModel(), DistortionModel::kPlumbBob);
  EXPECT_EQ(copy.distortionCoefficients(), camera.distortionCoefficients());
  EXPECT_EQ(distortionModelFromString("plumb_bob"), DistortionModel::kPlumbBob);
  EXPECT_EQ(toString(DistortionModel::kSingleParameterRadial), "single_parameter_radial");
}

TEST(PinholeCamera, IsInside) {
  const PinholeCamera camera(calibration("none", {}));
  EXPECT_TRUE(camera.isInside(cv::Point2d(0, 0)));
  EXPECT_TRUE(camera.isInside(cv::Point2d(639, 479)));
  EXPECT_FALSE(camera.isInside(cv::Point2d(639.5, 10)));
  EXPECT_FALSE(camera.isInside(cv::Point2d(NAN, 10)));
}

namespace {
// A mount pitched `pitch` (down, about the optical x axis) and rolled `roll` (about the optical z
// axis): the rotation of the optical frame into the level camera frame.
Eigen::Matrix3d mountTilt(double pitch, double roll) {
  return (Eigen::AngleAxisd(-pitch, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
      .toRotationMatrix();
}
}  // namespace

// A tilted camera's measured pixel of a point is the level camera's pixel of it once levelled.
TEST(PinholeCamera, LevellingTurnsMeasuredPixelsIntoTheLevelCamera) {
  CameraCalibration c = calibration("plumb_bob", {-0.15, 0.03, 0.0, 0.0, 0.0});
  c.camera_to_level = mountTilt(0.05, 0.02);
  const PinholeCamera tilted(c);
  EXPECT_TRUE(tilted.isLevelled());
  EXPECT_FALSE(tilted.isIdealPinhole());
  const PinholeCamera level(calibration("none", {}));
  for (const Eigen::Vector3d& point_level : {Eigen::Vector3d(0.4, -0.2, 2.0), Eigen::Vector3d(-1.0, 0.3, 3.0),
                                            Eigen::Vector3d(0.0, 0.0, 5.0)}) {
    // What the tilted camera measures: the point in its own optical frame through its lens.
    const cv::Point2d measured = tilted.project(point_level);
    const Eigen::Vector3d in_optical = c.camera_to_level.transpose() * point_level;
    const PinholeCamera lens_only(calibration("plumb_bob", {-0.15, 0.03, 0.0, 0.0, 0.0}));
    const cv::Point2d expected_measured = lens_only.project(in_optical);
    EXPECT_NEAR(measured.x, expected_measured.x, 1e-9);
    EXPECT_NEAR(measured.y, expected_measured.y, 1e-9);
    const cv::Point2d levelled = tilted.undistortPixel(measured);
    const cv::Point2d ideal = level.project(point_level);
    EXPECT_NEAR(levelled.x, ideal.x, 1e-6);
    EXPECT_NEAR(levelled.y, ideal.y, 1e-6);
  }
  expectRoundTrip(tilted, 1e-6);
  EXPECT_LT((tilted.calibration().camera_to_level - c.camera_to_level).norm(), 1e-15);
}

TEST(PinholeCamera, RejectsALevellingThatIsNotARotation) {
  CameraCalibration c = calibration("none", {});
  c.camera_to_level = 2.0 * Eigen::Matrix3d::Identity();
  expectRejected(c, "camera_to_level is not a rotation");
  c.camera_to_level = -Eigen::Matrix3d::Identity();
  expectRejected(c, "camera_to_level is not a rotation");  // a reflection (det −1)
  c.camera_to_level = Eigen::Matrix3d::Identity();
  c.camera_to_level(0, 0) = std::numeric_limits<double>::quiet_NaN();
  expectRejected(c, "camera_to_level is not finite");
  c.camera_to_level = Eigen::AngleAxisd(1.2, Eigen::Vector3d::UnitX()).toRotationMatrix();
  expectRejected(c, "more than 60 deg");
}
