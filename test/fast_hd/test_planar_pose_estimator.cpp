#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>

#include "support/geometry_fixtures.h"
#include "homography_teach_repeat/fast_hd/fast_hd.h"
#include "homography_teach_repeat/fast_hd/planar_pose_estimator.h"
#include "homography_teach_repeat/geometry/point_match.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/eval/synthetic_plane_scene.h"

using namespace homography_teach_repeat;
using test_support::expectPoseNear;
using test_support::mathCamera;
using test_support::planeFromAngles;

namespace {
const PlanarPose kTruth(0.6, -1.4, -0.25);
const ScenePlane kPlane = planeFromAngles(0.35, 0.2, 5.0);

PointMatches exactMatches(int count, unsigned seed) {
  std::mt19937_64 rng(seed);
  return sampleVisiblePlaneMatches(mathCamera(), kPlane, kTruth, count, &rng);
}
}  // namespace

TEST(PlanarPoseEstimator, ExactFromInliers) {
  PlanarPoseEstimatorOptions options;
  const auto estimate = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane,
                                                      options);
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_TRUE(estimate->refined);
  expectPoseNear(estimate->pose, kTruth, 1e-9);
  expectPoseNear(estimate->fast_hd_pose, kTruth, 1e-9);
  EXPECT_EQ(estimate->inliers.size(), 30u);
}

TEST(PlanarPoseEstimator, RobustToOutliers) {
  PointMatches matches = exactMatches(80, 2);
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 639.0), v(0.0, 479.0);
  for (int i = 0; i < 30; ++i) matches.push_back({{u(rng), v(rng)}, {u(rng), v(rng)}});
  PlanarPoseEstimatorOptions options;
  const auto estimate = estimatePlanarPose(matches, mathCamera(), kPlane, options);
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  expectPoseNear(estimate->pose, kTruth, 1e-8);
  EXPECT_GE(estimate->inliers.size(), 80u);
  EXPECT_LE(estimate->inliers.size(), 82u);
}

// Every failure is a status, never a pose (issue: fewer than 4 matches, collinear points,
// floor/ceiling plane, non-finite input).
TEST(PlanarPoseEstimator, FailureStatuses) {
  PlanarPoseEstimatorOptions options;
  const PointMatches three = exactMatches(3, 4);
  EXPECT_EQ(estimatePlanarPoseFromInliers(three, mathCamera(), kPlane, options).status().code(),
            StatusCode::kTooFewPoints);
  EXPECT_EQ(estimatePlanarPose(three, mathCamera(), kPlane, options).status().code(),
            StatusCode::kTooFewPoints);

  PointMatches collinear;
  for (int i = 0; i < 10; ++i) {
    const Eigen::Vector2d p(50.0 + 40.0 * i, 100.0 + 20.0 * i);
    collinear.push_back({p, p + Eigen::Vector2d(3.0, 1.0)});
  }
  EXPECT_EQ(estimatePlanarPoseFromInliers(collinear, mathCamera(), kPlane, options).status().code(),
            StatusCode::kDegenerate);

  ScenePlane floor;
  floor.normal = Eigen::Vector3d::UnitY();
  floor.distance = 0.8;
  EXPECT_EQ(estimatePlanarPoseFromInliers(exactMatches(20, 5), mathCamera(), floor, options)
                .status()
                .code(),
            StatusCode::kDegenerate);

  PointMatches with_nan = exactMatches(20, 6);
  with_nan[4].reference.y() = std::nan("");
  EXPECT_EQ(estimatePlanarPoseFromInliers(with_nan, mathCamera(), kPlane, options).status().code(),
            StatusCode::kInvalidInput);
}

TEST(PlanarPoseEstimator, OptionsValidation) {
  PlanarPoseEstimatorOptions options;
  EXPECT_NO_THROW(options.validate());
  options.pixel_sigma_px = 0.0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options.pixel_sigma_px = 1.0;
  options.refinement_max_iterations = 0;
  EXPECT_THROW(options.validate(), std::invalid_argument);
}

// The normal's error turns the plane about a pivot (docs/math.md §3.6): about the plane's point
// nearest the camera by default, about `pivot` (its features' centroid) when given. Its term is the
// spread of the poses Fast-HD gives with the plane turned about that point (central differences of
// 1 mrad across the normal), and a pivot 4 m along the wall from the nearest point gives another.
TEST(PlanarPoseEstimator, ThePlanesNormalTurnsAboutItsPivot) {
  const Eigen::Matrix3d H = planeInducedHomography(mathCamera(), kTruth, kPlane);
  const double sigma = 0.02;
  const auto spreadTurnedAbout = [&](const Eigen::Vector3d& pivot) {
    const auto [across1, across2] = directionsAcrossNormal(kPlane.normal);
    Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
    for (const Eigen::Vector3d& across : {across1, across2}) {
      const auto plus = solveFastHd(H, mathCamera(), turnedAbout(kPlane, kPlane.normal + 1e-3 * across, pivot));
      const auto minus = solveFastHd(H, mathCamera(), turnedAbout(kPlane, kPlane.normal - 1e-3 * across, pivot));
      EXPECT_TRUE(plus.isOk() && minus.isOk());
      if (!plus || !minus) return covariance;
      const Eigen::Vector3d column = Eigen::Vector3d(plus->pose.x - minus->pose.x, plus->pose.z - minus->pose.z,
                                                     plus->pose.theta - minus->pose.theta) / 2e-3;
      covariance += sigma * sigma * column * column.transpose();
    }
    return covariance;
  };
  const Eigen::Vector3d nearest = kPlane.distance * kPlane.normal;
  const auto about_nearest = planeUncertaintyCovariance(H, mathCamera(), kPlane, sigma, 0.0);
  ASSERT_TRUE(about_nearest.isOk()) << about_nearest.status().toString();
  EXPECT_LT((*about_nearest - spreadTurnedAbout(nearest)).norm(), 1e-4 * about_nearest->norm());
  const Eigen::Vector3d along = directionsAcrossNormal(kPlane.normal).first;
  const Eigen::Vector3d pivot = nearest + 4.0 * along;
  const auto about_pivot = planeUncertaintyCovariance(H, mathCamera(), kPlane, sigma, 0.0, pivot);
  ASSERT_TRUE(about_pivot.isOk()) << about_pivot.status().toString();
  EXPECT_LT((*about_pivot - spreadTurnedAbout(pivot)).norm(), 1e-4 * about_pivot->norm());
  EXPECT_GT((*about_pivot - *about_nearest).norm(), 0.2 * about_nearest->norm());
}

// The plane's uncertainty in the covariance (docs/math.md §3.6). The translation scales with the
// plane distance, so a relative distance std σ adds exactly σ² t tᵀ to (Cx, Cz) and nothing to θ;
// a normal std adds a positive semi-definite term; zero stds add nothing.
TEST(PlanarPoseEstimator, PlaneUncertaintyAddsToTheCovariance) {
  const Eigen::Matrix3d H = planeInducedHomography(mathCamera(), kTruth, kPlane);
  const auto none = planeUncertaintyCovariance(H, mathCamera(), kPlane, 0.0, 0.0);
  ASSERT_TRUE(none.isOk());
  EXPECT_EQ(*none, Eigen::Matrix3d::Zero());
  const auto distance = planeUncertaintyCovariance(H, mathCamera(), kPlane, 0.0, 0.03);
  ASSERT_TRUE(distance.isOk());
  const Eigen::Vector2d t(kTruth.x, kTruth.z);
  const Eigen::Matrix2d expected = 0.03 * 0.03 * t * t.transpose();
  EXPECT_NEAR((distance->topLeftCorner(2, 2) - expected).norm(), 0.0, 1e-8);
  EXPECT_NEAR((*distance)(2, 2), 0.0, 1e-10);
  const auto normal = planeUncertaintyCovariance(H, mathCamera(), kPlane, 0.02, 0.0);
  ASSERT_TRUE(normal.isOk());
  EXPECT_GT(normal->trace(), 0.0);
  EXPECT_GE(Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(*normal).eigenvalues().minCoeff(), -1e-12);

  PlanarPoseEstimatorOptions options;
  options.common_shift_sigma_px = 0.0;  // the pixel noise alone
  const auto pixels_only = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  options.plane_normal_sigma_rad = 0.02;
  options.plane_distance_sigma = 0.03;
  const auto with_plane = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  ASSERT_TRUE(pixels_only.isOk());
  ASSERT_TRUE(with_plane.isOk());
  expectPoseNear(with_plane->pose, pixels_only->pose, 1e-12);  // the pose does not change
  EXPECT_GT(with_plane->covariance.trace(), pixels_only->covariance.trace());
  // The plane's term is the model covariance, which every fix against this plane shares (the
  // hybrid filter keeps it, docs/math.md §7.1): the covariance is the pixel noise's plus it.
  EXPECT_EQ(pixels_only->model_covariance, Eigen::Matrix3d::Zero());
  EXPECT_GT(with_plane->model_covariance.trace(), 0.0);
  EXPECT_LT((with_plane->covariance - pixels_only->covariance - with_plane->model_covariance).cwiseAbs().maxCoeff(),
            1e-15);
  options.plane_distance_sigma = -0.1;
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options.plane_distance_sigma = 0.03;
  options.plane_normal_sigma_rad = std::nan("");
  EXPECT_THROW(options.validate(), std::invalid_argument);
  options.plane_normal_sigma_rad = 0.02;
  for (const double bad : {-0.01, 0.3, std::nan("")}) {
    options.tilt_sigma_rad = bad;
    EXPECT_THROW(options.validate(), std::invalid_argument) << bad;
  }
  options.tilt_sigma_rad = 0.02;
  EXPECT_NO_THROW(options.validate());
  // On level data the tilt nuisance leaves the pose and reports no tilt.
  const auto with_tilt = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  ASSERT_TRUE(with_tilt.isOk()) << with_tilt.status().toString();
  expectPoseNear(with_tilt->pose, pixels_only->pose, 1e-9);
  EXPECT_LT((with_tilt->tilt - Eigen::Matrix3d::Identity()).norm(), 1e-9);
}

// The heading's error floor (docs/math.md §3.8) adds σ² to the heading's variance of both
// covariances and nothing else; the pose does not change; values outside [0, 0.05] rad throw.
TEST(PlanarPoseEstimator, HeadingSigmaAddsToTheHeadingVarianceOnly) {
  PlanarPoseEstimatorOptions options;
  options.common_shift_sigma_px = 0.0;
  const auto pixels_only = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  options.heading_sigma_rad = 0.0007;
  EXPECT_NO_THROW(options.validate());
  const auto with_floor = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  ASSERT_TRUE(pixels_only.isOk()) << pixels_only.status().toString();
  ASSERT_TRUE(with_floor.isOk()) << with_floor.status().toString();
  expectPoseNear(with_floor->pose, pixels_only->pose, 1e-12);
  Eigen::Matrix3d added = Eigen::Matrix3d::Zero();
  added(2, 2) = 0.0007 * 0.0007;
  EXPECT_LT((with_floor->covariance - pixels_only->covariance - added).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((with_floor->model_covariance - added).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((with_floor->fast_hd_covariance - pixels_only->fast_hd_covariance - added).cwiseAbs().maxCoeff(), 1e-15);
  for (const double bad : {-0.001, 0.06, std::nan(""), std::numeric_limits<double>::infinity()}) {
    options.heading_sigma_rad = bad;
    EXPECT_THROW(options.validate(), std::invalid_argument) << bad;
  }
}

// The floor in pixels (docs/math.md §3.8): a common shift of σ px is a heading of σ / fx, its
// variance added to the heading's alone and to heading_sigma_rad's; the default is 0.5 px; outside
// [0, 5] px throws.
TEST(PlanarPoseEstimator, ACommonShiftInPixelsIsAHeadingFloorOfShiftOverFocalLength) {
  PlanarPoseEstimatorOptions options;
  EXPECT_EQ(options.common_shift_sigma_px, 0.5);
  options.common_shift_sigma_px = 0.0;
  const auto pixels_only = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  options.common_shift_sigma_px = 0.5;
  options.heading_sigma_rad = 0.0003;
  const auto with_floor = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  ASSERT_TRUE(pixels_only.isOk()) << pixels_only.status().toString();
  ASSERT_TRUE(with_floor.isOk()) << with_floor.status().toString();
  expectPoseNear(with_floor->pose, pixels_only->pose, 1e-12);
  const double shift_rad = 0.5 / mathCamera().fx();
  Eigen::Matrix3d added = Eigen::Matrix3d::Zero();
  added(2, 2) = shift_rad * shift_rad + 0.0003 * 0.0003;
  EXPECT_LT((with_floor->covariance - pixels_only->covariance - added).cwiseAbs().maxCoeff(), 1e-15);
  EXPECT_LT((with_floor->model_covariance - added).cwiseAbs().maxCoeff(), 1e-15);
  for (const double bad : {-0.1, 5.5, std::nan("")}) {
    options.common_shift_sigma_px = bad;
    EXPECT_THROW(options.validate(), std::invalid_argument) << bad;
  }
}

// A camera on a tilted mount (pitched 3°, rolled 1.5°, with a lens): its measured pixels, levelled
// by its camera_to_level (undistortMatches), give the level camera's pose exactly; the same pixels
// taken as level give a pose that is centimetres off (what a tilted mount did before levelling).
TEST(PlanarPoseEstimator, ATiltedMountIsExactOnceLevelled) {
  const PointMatches level_pixels = exactMatches(60, 7);
  CameraCalibration c = mathCamera().calibration();
  c.distortion_model = "plumb_bob";
  c.distortion = {-0.12, 0.02, 0.0, 0.0, 0.0};
  c.camera_to_level = (Eigen::AngleAxisd(-0.052, Eigen::Vector3d::UnitX()) *
                       Eigen::AngleAxisd(0.026, Eigen::Vector3d::UnitZ())).toRotationMatrix();
  const PinholeCamera tilted(c);
  PointMatches measured;
  for (const auto& m : level_pixels) {
    const cv::Point2d a = tilted.distortPixel({m.reference.x(), m.reference.y()});
    const cv::Point2d b = tilted.distortPixel({m.current.x(), m.current.y()});
    measured.push_back({{a.x, a.y}, {b.x, b.y}});
  }
  PlanarPoseEstimatorOptions options;
  const auto levelled = estimatePlanarPoseFromInliers(undistortMatches(tilted, measured), mathCamera(), kPlane, options);
  ASSERT_TRUE(levelled.isOk()) << levelled.status().toString();
  expectPoseNear(levelled->pose, kTruth, 1e-6);
  CameraCalibration lens_only = c;
  lens_only.camera_to_level = Eigen::Matrix3d::Identity();
  const auto unlevelled =
      estimatePlanarPoseFromInliers(undistortMatches(PinholeCamera(lens_only), measured), mathCamera(), kPlane, options);
  ASSERT_TRUE(unlevelled.isOk()) << unlevelled.status().toString();
  EXPECT_GT(std::hypot(unlevelled->pose.x - kTruth.x, unlevelled->pose.z - kTruth.z), 0.01);
}

// A camera 5 cm lower than when the route was taught (a passenger): the refinement's height
// offset takes it, and the plane-induced homography with that offset is the model the repeat's
// plane check compares the matches with (without it, a wall 5 m away is several pixels off).
TEST(PlanarPoseEstimator, AHeightChangeIsInThePlaneModel) {
  const double height = 0.05;
  const ScenePlane near_wall = planeFromAngles(0.2, 0.0, 2.0);
  const Eigen::Matrix3d H_true = planeInducedHomography(mathCamera(), kTruth, near_wall, height);
  PointMatches matches;
  for (double u = 80.0; u < 600.0; u += 60.0) {
    for (double v = 60.0; v < 440.0; v += 60.0) {
      const Eigen::Vector3d p = H_true * Eigen::Vector3d(u, v, 1.0);
      matches.push_back({{u, v}, p.head<2>() / p.z()});
    }
  }
  PlanarPoseEstimatorOptions options;
  const auto estimate = estimatePlanarPoseFromInliers(matches, mathCamera(), near_wall, options);
  ASSERT_TRUE(estimate.isOk()) << estimate.status().toString();
  EXPECT_NEAR(estimate->height_offset, height, 1e-6);
  expectPoseNear(estimate->pose, kTruth, 1e-6);
  auto rms = [&](double offset) {
    const Eigen::Matrix3d H = planeInducedHomography(mathCamera(), estimate->pose, near_wall, offset);
    double sum = 0.0;
    for (const auto& m : matches) sum += std::pow(transferError(H, m), 2);
    return std::sqrt(sum / static_cast<double>(matches.size()));
  };
  EXPECT_LT(rms(estimate->height_offset), 1e-4);
  EXPECT_GT(rms(0.0), 3.0);
}

// A fix's pixel σ from its own inliers (residual_sigma_gain, docs/math.md §3.9): matches with 1 px
// of noise against a configured σ of 0.2 px claim the gain times their rms transfer error, as if
// that σ were configured (the covariance about that σ's square over 0.2's larger); matches that
// fit more closely than the configured σ keep it (an exact fit claims what the keyframe's σ says,
// not nothing). 0 is the configured σ alone; outside [0, 10] throws.
TEST(PlanarPoseEstimator, APixelSigmaFromTheFixsOwnResidualWhereItIsLarger) {
  PointMatches noisy = exactMatches(200, 7);
  std::mt19937_64 rng(8);
  std::normal_distribution<double> noise(0.0, 1.0);
  for (PointMatch& m : noisy) m.current += Eigen::Vector2d(noise(rng), noise(rng));
  PlanarPoseEstimatorOptions options;
  options.pixel_sigma_px = 0.2;
  options.common_shift_sigma_px = 0.0;
  options.refine = false;  // the closed form's covariance: about linear in σ² (and a σ⁴ term)
  const auto configured = estimatePlanarPoseFromInliers(noisy, mathCamera(), kPlane, options);
  options.residual_sigma_gain = 0.75;
  EXPECT_NO_THROW(options.validate());
  const auto measured = estimatePlanarPoseFromInliers(noisy, mathCamera(), kPlane, options);
  ASSERT_TRUE(configured.isOk()) << configured.status().toString();
  ASSERT_TRUE(measured.isOk()) << measured.status().toString();
  EXPECT_DOUBLE_EQ(configured->pixel_sigma_px, 0.2);
  // One image's noise of 1 px per coordinate: a transfer error of about √2 px, less the fit's share.
  EXPECT_NEAR(measured->rms_transfer_error_px, std::sqrt(2.0), 0.15);
  EXPECT_DOUBLE_EQ(measured->pixel_sigma_px, 0.75 * measured->rms_transfer_error_px);
  expectPoseNear(measured->pose, configured->pose, 1e-12);
  // Exactly the estimate with that σ configured, and more than with 0.2 px.
  PlanarPoseEstimatorOptions as_configured = options;
  as_configured.residual_sigma_gain = 0.0;
  as_configured.pixel_sigma_px = measured->pixel_sigma_px;
  const auto same = estimatePlanarPoseFromInliers(noisy, mathCamera(), kPlane, as_configured);
  ASSERT_TRUE(same.isOk()) << same.status().toString();
  EXPECT_LT((measured->covariance - same->covariance).cwiseAbs().maxCoeff(), 1e-15);
  const double ratio = std::pow(measured->pixel_sigma_px / 0.2, 2);
  EXPECT_NEAR(measured->covariance(0, 0) / configured->covariance(0, 0), ratio, 0.05 * ratio);
  EXPECT_NEAR(measured->covariance(2, 2) / configured->covariance(2, 2), ratio, 0.05 * ratio);

  options.refine = true;
  const auto exact = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  options.residual_sigma_gain = 0.0;
  const auto exact_configured = estimatePlanarPoseFromInliers(exactMatches(30, 1), mathCamera(), kPlane, options);
  ASSERT_TRUE(exact.isOk()) << exact.status().toString();
  ASSERT_TRUE(exact_configured.isOk()) << exact_configured.status().toString();
  EXPECT_DOUBLE_EQ(exact->pixel_sigma_px, 0.2);
  EXPECT_LT((exact->covariance - exact_configured->covariance).cwiseAbs().maxCoeff(), 1e-18);
  for (const double bad : {-0.1, 10.5, std::nan("")}) {
    options.residual_sigma_gain = bad;
    EXPECT_THROW(options.validate(), std::invalid_argument) << bad;
  }
}
