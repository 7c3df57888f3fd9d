// undistortMatches: the one place measured pixels become pinhole pixels.
#include <gtest/gtest.h>

#include <cmath>

#include "homography_teach_repeat/geometry/point_match.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;

namespace {

CameraCalibration calibration(const std::string& model, std::vector<double> coefficients) {
  CameraCalibration c = test_support::syntheticCalibration();
  c.distortion_model = model;
  c.distortion = std::move(coefficients);
  return c;
}

}  // namespace

TEST(UndistortMatches, WithoutDistortionTheMatchesStayAndEveryIndexIsKept) {
  const PinholeCamera camera(calibration("none", {}));
  const PointMatches measured{{Eigen::Vector2d(10, 20), Eigen::Vector2d(30, 40)},
                              {Eigen::Vector2d(600, 400), Eigen::Vector2d(610, 420)}};
  std::vector<int> kept;
  const PointMatches out = undistortMatches(camera, measured, &kept);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(kept, (std::vector<int>{0, 1}));
  EXPECT_EQ(out[1].current, measured[1].current);
}

// Each undistorted pixel distorts back to the measured one.
TEST(UndistortMatches, InvertsTheLens) {
  const PinholeCamera camera(calibration("plumb_bob", {-0.2, 0.05, 0.001, -0.001, 0.0}));
  const PointMatches measured{{Eigen::Vector2d(50, 60), Eigen::Vector2d(320, 240)},
                              {Eigen::Vector2d(600, 30), Eigen::Vector2d(100, 450)}};
  const PointMatches out = undistortMatches(camera, measured);
  ASSERT_EQ(out.size(), 2u);
  for (std::size_t i = 0; i < out.size(); ++i) {
    const cv::Point2d back = camera.distortPixel({out[i].reference.x(), out[i].reference.y()});
    EXPECT_NEAR(back.x, measured[i].reference.x(), 1e-3);
    EXPECT_NEAR(back.y, measured[i].reference.y(), 1e-3);
  }
  EXPECT_GT((out[0].reference - measured[0].reference).norm(), 1.0);  // the lens moved the corner pixel
}

// A pixel that does not undistort to a finite point drops its match; `kept` maps the rest back.
TEST(UndistortMatches, NonFinitePixelsDropTheirMatch) {
  const PinholeCamera camera(calibration("plumb_bob", {-0.2, 0.05, 0.0, 0.0, 0.0}));
  const PointMatches measured{{Eigen::Vector2d(50, 60), Eigen::Vector2d(70, 80)},
                              {Eigen::Vector2d(NAN, 60), Eigen::Vector2d(70, 80)},
                              {Eigen::Vector2d(200, 210), Eigen::Vector2d(220, INFINITY)},
                              {Eigen::Vector2d(300, 310), Eigen::Vector2d(320, 330)}};
  std::vector<int> kept;
  const PointMatches out = undistortMatches(camera, measured, &kept);
  EXPECT_EQ(kept, (std::vector<int>{0, 3}));
  ASSERT_EQ(out.size(), 2u);
  for (const auto& m : out) EXPECT_TRUE(m.reference.allFinite() && m.current.allFinite());
  const PinholeCamera pinhole(calibration("none", {}));
  EXPECT_EQ(undistortMatches(pinhole, measured).size(), 2u);  // the same rule without a lens
}
