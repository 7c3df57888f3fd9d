#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>

#include "homography_teach_repeat/common/atomic_file.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/fast_hd/plane_estimation.h"
#include "homography_teach_repeat/teach_repeat/repeat_estimate.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"
#include "support/synthetic_route.h"

using namespace homography_teach_repeat;

namespace {
using test_support::makeTemporaryDirectory;
using test_support::SyntheticWall;
CameraCalibration calibration() { return test_support::syntheticCalibration(); }
// AKAZE, a keyframe every 0.25 m, into `dir`; the rest at the defaults.
TeachOptions wallTeachOptions(const std::string& dir) {
  TeachOptions options;
  options.route_directory = dir;
  options.features.type = FeatureType::kAkaze;
  options.keyframes.distance = 0.25;
  return options;
}
// 16 images 10 cm apart along a gently turning path towards the synthetic wall (six keyframes
// with wallTeachOptions), offered to `session`.
void offerAGentleTurnTowardsTheWall(TeachSession& session) {
  const SyntheticWall scene;
  for (int step = 0; step <= 15; ++step) {
    const double s = 0.1 * step;
    const PlanarPose camera_pose(0.08 * s, s, 0.04 * s);
    ASSERT_TRUE(session.offer(scene.imageAt(camera_pose), cameraAxesToRep103(camera_pose), 10.0 + step).isOk());
  }
}
}  // namespace

// Six keyframes along a gently turning path towards the wall; the planes estimated at the end
// agree with the truth propagated to every keyframe (docs/math.md §2.2).
TEST(TeachSession, StoresKeyframesAndEstimatesPlanes) {
  const std::string dir = makeTemporaryDirectory("htr_teach_test");
  TeachOptions options = wallTeachOptions(dir);
  options.first_plane_distance = 4.0;
  options.planes_from_odometry = false;  // the paper's single plane with the tape-measured scale
  auto session = TeachSession::start(options, calibration(), Pose2D(0.0, 0.0, 0.0));
  ASSERT_TRUE(session.isOk()) << session.status().toString();
  const SyntheticWall scene;
  std::vector<PlanarPose> camera_poses;
  int stored = 0;
  for (int step = 0; step <= 15; ++step) {
    const double s = 0.1 * step;  // 10 cm per image: every third image is a keyframe
    const PlanarPose camera_pose(0.08 * s, s, 0.04 * s);
    const Pose2D base = cameraAxesToRep103(camera_pose);  // mount at the base origin
    const auto offered = session->offer(scene.imageAt(camera_pose), base, 10.0 + step);
    ASSERT_TRUE(offered.isOk()) << offered.status().toString();
    if (*offered) {
      camera_poses.push_back(camera_pose);
      ++stored;
    }
  }
  EXPECT_EQ(stored, 6);
  const auto report = session->finish();
  ASSERT_TRUE(report.isOk()) << report.status().toString();
  for (const auto& m : report->messages) ADD_FAILURE() << m;
  EXPECT_EQ(report->planes, 6);
  const auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  ASSERT_EQ(route->keyframes.size(), 6u);
  for (std::size_t k = 0; k < camera_poses.size(); ++k) {
    const auto truth = transferPlane(scene.plane, camera_poses[k]);
    ASSERT_TRUE(truth.isOk());
    ASSERT_TRUE(route->keyframes[k].plane.has_value()) << k;
    const ScenePlane& p = *route->keyframes[k].plane;
    // The first normal comes from a 0.3 m baseline at 4 m: about a degree of error.
    EXPECT_LT(std::acos(std::min(1.0, p.normal.dot(truth->normal))), 2.0 * M_PI / 180.0) << k;
    EXPECT_NEAR(p.distance, truth->distance, 0.03 * truth->distance) << k;
  }
  std::filesystem::remove_all(dir);
}

// The teach run measures how closely each keyframe's features match the next keyframe's (the
// synthetic wall's images: a fraction of a pixel) and the pairs' relative tilt (none here: level
// images), stores them in the route, and the same measurement from the stored files
// (measureRouteNoise, the migration's) finds the same values. The repeat's pixel σ is
// match_residual_gain times the route's median residual, its tilt σ measured_tilt_gain times the
// route's; with a gain of 0 or on a route that was not measured the configured ones, and the log
// line says which.
TEST(TeachSession, MeasuresTheRoutesMatchNoise) {
  const std::string dir = makeTemporaryDirectory("htr_teach_noise");
  const TeachOptions options = wallTeachOptions(dir);
  EXPECT_TRUE(options.planes_from_odometry);  // no tape measure by default
  auto session = TeachSession::start(options, calibration(), Pose2D(0.0, 0.0, 0.0));
  ASSERT_TRUE(session.isOk()) << session.status().toString();
  ASSERT_NO_FATAL_FAILURE(offerAGentleTurnTowardsTheWall(*session));
  const auto report = session->finish();
  ASSERT_TRUE(report.isOk()) << report.status().toString();
  EXPECT_EQ(report->planes, 6);
  auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  ASSERT_EQ(route->keyframes.size(), 6u);
  EXPECT_TRUE(route->info.match_noise_measured);
  for (std::size_t k = 0; k + 1 < route->keyframes.size(); ++k) {
    ASSERT_TRUE(route->keyframes[k].match_residual.has_value()) << k;
    EXPECT_GT(route->keyframes[k].match_residual->rms_px, 0.0) << k;
    EXPECT_LT(route->keyframes[k].match_residual->rms_px, 1.0) << k;
    EXPECT_GE(route->keyframes[k].match_residual->inliers, 15) << k;
  }
  EXPECT_FALSE(route->keyframes.back().match_residual.has_value());  // no next keyframe
  const double residual = routeMatchResidual(*route).value_or(-1.0);
  EXPECT_GT(residual, 0.0);
  EXPECT_TRUE(route->info.tilt_measured);
  const double tilt = routeTiltSigma(*route).value_or(-1.0);
  EXPECT_GE(tilt, 0.0);
  EXPECT_LT(tilt, 0.002);  // level images: what the estimate's own noise leaves
  EXPECT_FALSE(route->keyframes.back().tilt_to_next.has_value());

  Route measured = *route;
  ASSERT_TRUE(measureRouteNoise(measured).isOk());
  for (std::size_t k = 0; k + 1 < route->keyframes.size(); ++k) {
    ASSERT_TRUE(measured.keyframes[k].match_residual.has_value()) << k;
    EXPECT_NEAR(measured.keyframes[k].match_residual->rms_px, route->keyframes[k].match_residual->rms_px, 0.01) << k;
    ASSERT_EQ(measured.keyframes[k].tilt_to_next.has_value(), route->keyframes[k].tilt_to_next.has_value()) << k;
    if (measured.keyframes[k].tilt_to_next) {
      EXPECT_NEAR(measured.keyframes[k].tilt_to_next->pitch, route->keyframes[k].tilt_to_next->pitch, 1e-3) << k;
    }
  }

  RepeatOptions repeat;
  repeat.pose.pixel_sigma_px = 0.5;
  repeat.match_residual_gain = 1.5;
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, *route).pose.pixel_sigma_px, 1.5 * residual);
  EXPECT_NE(describeMeasuredNoise(repeat, *route).find("match_residual_gain 1.50"), std::string::npos)
      << describeMeasuredNoise(repeat, *route);
  // Each fix's own residual with the same gain (pixel_noise_per_fix, docs/math.md §3.9).
  EXPECT_TRUE(repeat.pixel_noise_per_fix);
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, *route).pose.residual_sigma_gain, 1.5);
  EXPECT_NE(describeMeasuredNoise(repeat, *route).find("pixel_noise_per_fix"), std::string::npos);
  repeat.pixel_noise_per_fix = false;
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, *route).pose.residual_sigma_gain, 0.0);
  EXPECT_EQ(describeMeasuredNoise(repeat, *route).find("pixel_noise_per_fix"), std::string::npos);
  repeat.pixel_noise_per_fix = true;
  repeat.pose.tilt_sigma_rad = 0.03;
  repeat.measured_tilt_gain = 2.0;
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, *route).pose.tilt_sigma_rad, 2.0 * tilt);
  EXPECT_NE(describeMeasuredNoise(repeat, *route).find("measured_tilt_gain 2.00"), std::string::npos)
      << describeMeasuredNoise(repeat, *route);
  repeat.measured_tilt_gain = 0.0;
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, *route).pose.tilt_sigma_rad, 0.03);
  repeat.measured_tilt_gain = 1.0;
  repeat.match_residual_gain = 0.0;
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, *route).pose.pixel_sigma_px, 0.5);
  repeat.match_residual_gain = 1.5;
  Route older = *route;
  older.info.match_noise_measured = false;
  older.info.tilt_measured = false;
  older.loaded_format_version = 2;
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, older).pose.pixel_sigma_px, 0.5);
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, older).pose.tilt_sigma_rad, 0.03);
  EXPECT_NE(describeMeasuredNoise(repeat, older).find("route_info --migrate " + dir), std::string::npos)
      << describeMeasuredNoise(repeat, older);
  Route version3 = *route;  // noise measured, tilt not: still told to migrate
  version3.info.tilt_measured = false;
  version3.loaded_format_version = 3;
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, version3).pose.pixel_sigma_px, 1.5 * residual);
  EXPECT_DOUBLE_EQ(withMeasuredNoise(repeat, version3).pose.tilt_sigma_rad, 0.03);
  EXPECT_NE(describeMeasuredNoise(repeat, version3).find("route_info --migrate " + dir), std::string::npos)
      << describeMeasuredNoise(repeat, version3);
  repeat.match_residual_gain = -1.0;
  EXPECT_THROW(repeat.validate(), std::invalid_argument);
  repeat.match_residual_gain = 1.5;
  repeat.measured_tilt_gain = 11.0;
  EXPECT_THROW(repeat.validate(), std::invalid_argument);
  std::filesystem::remove_all(dir);
}

// The teach run measures each plane's uncertainty from its neighbours as the repeat would at load
// and stores it (format 5; docs/route_format.md, "Measured noise"); a route of format 4 lacks it:
// the repeat's log says it is measured at load and how to store it, and migrateRoute stores what
// the teach run would have.
TEST(TeachSession, StoresThePlanesUncertainty) {
  const std::string dir = makeTemporaryDirectory("htr_teach_planes");
  auto session = TeachSession::start(wallTeachOptions(dir), calibration(), Pose2D(0.0, 0.0, 0.0));
  ASSERT_TRUE(session.isOk()) << session.status().toString();
  ASSERT_NO_FATAL_FAILURE(offerAGentleTurnTowardsTheWall(*session));
  const auto report = session->finish();
  ASSERT_TRUE(report.isOk()) << report.status().toString();
  EXPECT_TRUE(report->messages.empty()) << report->messages.front();
  const auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  EXPECT_EQ(route->loaded_format_version, 5);
  ASSERT_TRUE(planeUncertaintyStored(*route));
  EXPECT_FALSE(planeUncertaintyMissing(*route));
  int with_fix_error = 0;
  for (const RouteKeyframe& keyframe : route->keyframes) {
    ASSERT_TRUE(keyframe.plane_uncertainty) << keyframe.index;
    const PlaneUncertainty& u = *keyframe.plane_uncertainty;
    EXPECT_LT(u.normal_sigma_rad, 0.1) << keyframe.index;  // one wall, seen from 0.25 m apart
    EXPECT_LT(u.distance_sigma, 0.1) << keyframe.index;
    ASSERT_TRUE(u.pivot) << keyframe.index;
    EXPECT_NEAR(keyframe.plane->normal.dot(*u.pivot), keyframe.plane->distance, 1e-9) << keyframe.index;  // on it
    with_fix_error += u.fix_error_per_m2 ? 1 : 0;
  }
  EXPECT_GE(with_fix_error, 4);
  RepeatOptions repeat;
  EXPECT_NE(describeMeasuredNoise(repeat, *route).find("as the route stores it"), std::string::npos)
      << describeMeasuredNoise(repeat, *route);
  EXPECT_EQ(describeMeasuredNoise(repeat, *route).find("--migrate"), std::string::npos)
      << describeMeasuredNoise(repeat, *route);

  // The same route as format 4.
  Route version4 = *route;
  for (RouteKeyframe& keyframe : version4.keyframes) keyframe.plane_uncertainty.reset();
  ASSERT_TRUE(writeRouteIndex(version4).isOk());
  auto index = readWholeFile(dir + "/route.yaml");
  ASSERT_TRUE(index.isOk());
  std::string older = *index;
  older.replace(older.find("format_version: 5"), 17, "format_version: 4");
  ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", older).isOk());
  const auto loaded4 = loadRoute(dir);
  ASSERT_TRUE(loaded4.isOk()) << loaded4.status().toString();
  EXPECT_EQ(loaded4->loaded_format_version, 4);
  EXPECT_TRUE(planeUncertaintyMissing(*loaded4));
  const std::string told = describeMeasuredNoise(repeat, *loaded4);
  EXPECT_NE(told.find("measured at load"), std::string::npos) << told;
  EXPECT_NE(told.find("route_info --migrate " + dir), std::string::npos) << told;
  ASSERT_TRUE(migrateRoute(dir).isOk());
  const auto migrated = loadRoute(dir);
  ASSERT_TRUE(migrated.isOk()) << migrated.status().toString();
  EXPECT_EQ(migrated->loaded_format_version, 5);
  ASSERT_TRUE(planeUncertaintyStored(*migrated));
  for (std::size_t k = 0; k < route->keyframes.size(); ++k) {
    const PlaneUncertainty& taught = *route->keyframes[k].plane_uncertainty;
    const PlaneUncertainty& again = *migrated->keyframes[k].plane_uncertainty;
    EXPECT_NEAR(again.normal_sigma_rad, taught.normal_sigma_rad, 1e-9) << k;
    EXPECT_NEAR(again.distance_sigma, taught.distance_sigma, 1e-9) << k;
    EXPECT_NEAR((*again.pivot - *taught.pivot).norm(), 0.0, 1e-9) << k;
    ASSERT_EQ(again.fix_error_per_m2.has_value(), taught.fix_error_per_m2.has_value()) << k;
  }
  std::filesystem::remove_all(dir);
}

// A camera levelled by one constant mount still pitches and rolls with the body (docs/math.md
// §2.5): images tilted by up to 0.7° taught with planes from odometry. With
// estimate_keyframe_tilt every keyframe's plane is right (measured: worst normal 1.3°, distance
// 0.3 %); without it the tilt reads as a wrong plane (13°, 2.5 %). Either way the teach run
// measures each pair's relative tilt (pairTiltOf), near the images' own difference. The default,
// auto, estimates it here (the pairs' tilt above kTiltedBodySigma) and not for the same camera level.
TEST(TeachSession, KeyframeTiltKeepsThePlanesOfATiltingCamera) {
  const SyntheticWall scene;
  const PinholeCamera camera(calibration());
  std::vector<Eigen::Vector2d> image_tilts;  // (pitch, roll) of each keyframe's image
  std::optional<PlaneEstimationReport> report;  // of the last teach run
  auto teach = [&](KeyframeTilt mode, std::vector<PlanarPose>* camera_poses, double tilt_scale = 1.0) {
    const std::string dir = makeTemporaryDirectory("htr_teach_tilt");
    TeachOptions options;
    options.route_directory = dir;
    options.features.type = FeatureType::kAkaze;
    options.keyframes.distance = 0.25;
    options.planes_from_odometry = true;
    options.keyframe_tilt = mode;
    auto session = TeachSession::start(options, calibration(), Pose2D(0.0, 0.0, 0.0));
    EXPECT_TRUE(session.isOk()) << session.status().toString();
    camera_poses->clear();
    image_tilts.clear();
    for (int step = 0; step <= 15; ++step) {
      const double s = 0.1 * step;
      const PlanarPose camera_pose(0.08 * s, s, 0.04 * s);
      const double pitch = tilt_scale * 0.012 * std::sin(1.3 * step), roll = tilt_scale * 0.008 * std::cos(0.9 * step);
      const Eigen::Matrix3d T =
          (Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()))
              .toRotationMatrix();
      const Eigen::Matrix3d H =
          camera.K() * T * camera.Kinverse() * planeInducedHomography(camera, camera_pose, scene.plane);
      const auto offered = session->offer(test_support::warp(scene.texture, H), cameraAxesToRep103(camera_pose), 10.0 + step);
      EXPECT_TRUE(offered.isOk()) << offered.status().toString();
      if (offered.isOk() && *offered) {
        camera_poses->push_back(camera_pose);
        image_tilts.emplace_back(pitch, roll);
      }
    }
    const auto finished = session->finish();
    EXPECT_TRUE(finished.isOk()) << finished.status().toString();
    report.reset();
    if (finished.isOk()) report = *finished;
    auto route = loadRoute(dir);
    std::filesystem::remove_all(dir);
    return route;
  };
  // The largest normal error [rad] and relative distance error over the keyframes.
  auto worst = [&](const Route& route, const std::vector<PlanarPose>& camera_poses) {
    std::pair<double, double> errors{0.0, 0.0};
    for (std::size_t k = 0; k < camera_poses.size(); ++k) {
      const auto truth = transferPlane(scene.plane, camera_poses[k]);
      if (!truth || !route.keyframes[k].plane) return std::make_pair(M_PI, 1.0);
      const ScenePlane& p = *route.keyframes[k].plane;
      errors.first = std::max(errors.first, std::acos(std::min(1.0, p.normal.dot(truth->normal))));
      errors.second = std::max(errors.second, std::abs(p.distance - truth->distance) / truth->distance);
    }
    return errors;
  };
  std::vector<PlanarPose> poses;
  const auto with_tilt = teach(KeyframeTilt::kEstimate, &poses);
  ASSERT_TRUE(with_tilt.isOk()) << with_tilt.status().toString();
  ASSERT_EQ(with_tilt->keyframes.size(), 6u);
  const auto tilt_errors = worst(*with_tilt, poses);
  EXPECT_LT(tilt_errors.first, 1.5 * M_PI / 180.0);
  EXPECT_LT(tilt_errors.second, 0.03);
  double true_squares = 0.0;
  for (std::size_t k = 0; k + 1 < image_tilts.size(); ++k) {
    const Eigen::Vector2d truth = image_tilts[k + 1] - image_tilts[k];
    true_squares += truth.squaredNorm();
    const auto& measured = with_tilt->keyframes[k].tilt_to_next;
    ASSERT_TRUE(measured.has_value()) << k;
    EXPECT_NEAR(measured->pitch, truth.x(), 0.004) << k;
    EXPECT_NEAR(measured->roll, truth.y(), 0.004) << k;
  }
  const double true_sigma = std::sqrt(true_squares / (2.0 * static_cast<double>(image_tilts.size() - 1)));
  ASSERT_TRUE(routeTiltSigma(*with_tilt).has_value());
  EXPECT_GT(*routeTiltSigma(*with_tilt), 0.5 * true_sigma);
  EXPECT_LT(*routeTiltSigma(*with_tilt), 2.0 * true_sigma);
  const auto without = teach(KeyframeTilt::kLevel, &poses);
  ASSERT_TRUE(without.isOk()) << without.status().toString();
  ASSERT_TRUE(report.has_value());
  EXPECT_FALSE(report->keyframe_tilt_estimated);
  const auto planar_errors = worst(*without, poses);
  EXPECT_GT(planar_errors.first, 3.0 * tilt_errors.first);

  const auto automatic = teach(KeyframeTilt::kAuto, &poses);
  ASSERT_TRUE(automatic.isOk()) << automatic.status().toString();
  ASSERT_TRUE(report.has_value() && report->measured_tilt_rad.has_value());
  EXPECT_GT(*report->measured_tilt_rad, kTiltedBodySigma);
  EXPECT_TRUE(report->keyframe_tilt_estimated) << describeKeyframeTilt(*report, KeyframeTilt::kAuto);
  const auto automatic_errors = worst(*automatic, poses);
  EXPECT_NEAR(automatic_errors.first, tilt_errors.first, 1e-9);
  EXPECT_NEAR(automatic_errors.second, tilt_errors.second, 1e-9);

  const auto level = teach(KeyframeTilt::kAuto, &poses, 0.0);
  ASSERT_TRUE(level.isOk()) << level.status().toString();
  ASSERT_TRUE(report.has_value() && report->measured_tilt_rad.has_value());
  EXPECT_LT(*report->measured_tilt_rad, kTiltedBodySigma);
  EXPECT_FALSE(report->keyframe_tilt_estimated) << describeKeyframeTilt(*report, KeyframeTilt::kAuto);
  std::printf("%s\n", describeKeyframeTilt(*report, KeyframeTilt::kAuto).c_str());
}

TEST(TeachSession, KeyframeTiltIsAutoTrueOrFalse) {
  EXPECT_EQ(keyframeTiltFromString("auto"), KeyframeTilt::kAuto);
  EXPECT_EQ(keyframeTiltFromString("true"), KeyframeTilt::kEstimate);
  EXPECT_EQ(keyframeTiltFromString("false"), KeyframeTilt::kLevel);
  EXPECT_THROW(keyframeTiltFromString("sometimes"), std::invalid_argument);
  for (const KeyframeTilt mode : {KeyframeTilt::kAuto, KeyframeTilt::kEstimate, KeyframeTilt::kLevel}) {
    EXPECT_EQ(keyframeTiltFromString(toString(mode)), mode);
  }
  EXPECT_TRUE(estimatesKeyframeTilt(KeyframeTilt::kAuto, 2.0 * kTiltedBodySigma));
  EXPECT_FALSE(estimatesKeyframeTilt(KeyframeTilt::kAuto, 0.5 * kTiltedBodySigma));
  EXPECT_FALSE(estimatesKeyframeTilt(KeyframeTilt::kAuto, std::nullopt));  // not measured: level
  EXPECT_TRUE(estimatesKeyframeTilt(KeyframeTilt::kEstimate, std::nullopt));
  EXPECT_FALSE(estimatesKeyframeTilt(KeyframeTilt::kLevel, 1.0));
}

TEST(TeachSession, BadInputAndTooFewKeyframes) {
  const std::string dir = makeTemporaryDirectory("htr_teach_test");
  TeachOptions options;
  options.route_directory = dir;
  options.first_plane_distance = 3.0;
  auto session = TeachSession::start(options, calibration(), Pose2D());
  ASSERT_TRUE(session.isOk());
  const SyntheticWall scene;
  EXPECT_EQ(session->offer(cv::Mat(), Pose2D(), 1.0).status().code(), StatusCode::kInvalidInput);
  EXPECT_EQ(session->offer(cv::Mat(240, 320, CV_8UC1, cv::Scalar(0)), Pose2D(), 1.0).status().code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(session->offer(scene.imageAt(PlanarPose()), Pose2D(std::nan(""), 0, 0), 1.0)
                .status()
                .code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(session->offer(cv::Mat(480, 640, CV_32FC1, cv::Scalar(0)), Pose2D(), 1.0).status().code(),
            StatusCode::kInvalidInput);
  ASSERT_TRUE(*session->offer(scene.imageAt(PlanarPose()), Pose2D(), 1.0));
  EXPECT_EQ(session->finish().status().code(), StatusCode::kTooFewPoints);
  TeachOptions bad = options;
  bad.keyframes.angle = -1.0;
  EXPECT_EQ(TeachSession::start(bad, calibration(), Pose2D()).status().code(),
            StatusCode::kInvalidInput);
  for (const double gap : {-0.5, std::nan("")}) {  // closed_route_gap: finite and >= 0
    TeachOptions bad_gap = options;
    bad_gap.closed_route_gap = gap;
    const auto refused = TeachSession::start(bad_gap, calibration(), Pose2D());
    EXPECT_EQ(refused.status().code(), StatusCode::kInvalidInput) << gap;
    EXPECT_NE(refused.status().message().find("closed_route_gap"), std::string::npos) << refused.status().toString();
  }
  std::filesystem::remove_all(dir);
}
