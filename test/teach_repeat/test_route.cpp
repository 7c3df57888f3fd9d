#include <gtest/gtest.h>

#include <sys/stat.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <utility>
#include <vector>

#include "homography_teach_repeat/common/atomic_file.h"
#include "homography_teach_repeat/teach_repeat/route.h"
#include "homography_teach_repeat/teach_repeat/teach_session.h"

using namespace homography_teach_repeat;

namespace {

// Temporary directories, removed when the test program exits.
std::string temporaryDirectory() {
  static struct Cleanup {
    std::vector<std::string> directories;
    ~Cleanup() {
      for (const auto& d : directories) {
        ::chmod(d.c_str(), 0755);
        std::error_code ignored;
        std::filesystem::remove_all(d, ignored);
      }
    }
  } cleanup;
  char pattern[] = "/tmp/htr_route_test_XXXXXX";
  const char* made = ::mkdtemp(pattern);
  if (made == nullptr) return std::string();
  cleanup.directories.emplace_back(made);
  return made;
}

RouteInfo info() {
  RouteInfo i;
  i.feature_type = FeatureType::kOrb;
  i.camera.width = 64;
  i.camera.height = 48;
  i.camera.fx = i.camera.fy = 50.0;
  i.camera.cx = 32.0;
  i.camera.cy = 24.0;
  i.camera.distortion_model = "plumb_bob";
  i.camera.distortion = {-0.1, 0.01, 0.0, 0.0, 0.0};
  i.camera_mount = Pose2D(0.2, 0.0, 0.0);
  return i;
}

ImageFeatures features(int n) {
  ImageFeatures f;
  f.type = FeatureType::kOrb;
  for (int k = 0; k < n; ++k) f.keypoints.emplace_back(cv::Point2f(k * 1.5f, k * 0.5f), 7.0f, 30.0f, 0.01f * k, 1);
  f.descriptors = cv::Mat(n, 32, CV_8U);
  cv::randu(f.descriptors, 0, 255);
  return f;
}

std::vector<VerticalLine> lines() {
  VerticalLine l;
  l.x = 12.25;
  l.top = Eigen::Vector2d(12.0, 3.0);
  l.bottom = Eigen::Vector2d(12.5, 40.0);
  l.top_undistorted = Eigen::Vector2d(12.1, 2.9);
  l.bottom_undistorted = Eigen::Vector2d(12.4, 40.2);
  l.length = 37.0;
  l.polarity = EdgePolarity::kDarkRight;
  l.left_brightness = 200.0;
  l.right_brightness = 40.0;
  l.contrast = 90.0;
  return {l, l};
}

cv::Mat image(int value) { return cv::Mat(48, 64, CV_8UC1, cv::Scalar(value)); }

Route writeRoute(const std::string& dir, int keyframes) {
  auto writer = RouteWriter::create(dir, info());
  EXPECT_TRUE(writer.isOk()) << writer.status().toString();
  for (int k = 0; k < keyframes; ++k) {
    EXPECT_TRUE(writer->addKeyframe(image(10 * k), features(5 + k), lines(), Pose2D(k, 0.5 * k, 0.1 * k), 100.0 + k)
                    .isOk());
  }
  return writer->route();
}

// Each `bad` text put in place of `good` in a route's index makes loadRoute refuse the route,
// its message naming the given words.
void expectEachRefused(const std::string& dir, const std::string& index, const std::string& good,
                       const std::vector<std::pair<std::string, std::string>>& bad_and_named) {
  for (const auto& [bad, named] : bad_and_named) {
    std::string text = index;
    const std::size_t at = text.find(good);
    ASSERT_NE(at, std::string::npos) << text;
    text.replace(at, good.size(), bad);
    ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", text).isOk());
    const auto refused = loadRoute(dir);
    ASSERT_FALSE(refused.isOk()) << bad;
    EXPECT_NE(refused.status().message().find(named), std::string::npos) << refused.status().message();
  }
}

}  // namespace

TEST(Route, RoundTrip) {
  const std::string dir = temporaryDirectory();
  auto writer = RouteWriter::create(dir, info());
  ASSERT_TRUE(writer.isOk());
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(writer->addKeyframe(image(10 * k), features(5 + k), lines(), Pose2D(k, 0.5 * k, 0.1 * k), 100.0 + k)
                    .isOk());
  }
  ScenePlane plane;
  plane.normal = Eigen::Vector3d(0.6, 0.0, 0.8);
  plane.distance = 4.5;
  ASSERT_TRUE(writer->setPlanes({plane, std::nullopt, plane}, 4.5).isOk());

  const auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  EXPECT_EQ(route->info.feature_type, FeatureType::kOrb);
  EXPECT_EQ(route->info.camera.distortion_model, "plumb_bob");
  EXPECT_EQ(route->info.camera.distortion.size(), 5u);
  EXPECT_DOUBLE_EQ(route->info.first_plane_distance, 4.5);
  ASSERT_EQ(route->keyframes.size(), 3u);
  EXPECT_DOUBLE_EQ(route->keyframes[2].pose.x, 2.0);
  EXPECT_DOUBLE_EQ(route->keyframes[2].stamp, 102.0);
  ASSERT_TRUE(route->keyframes[0].plane.has_value());
  EXPECT_FALSE(route->keyframes[1].plane.has_value());
  EXPECT_NEAR(route->keyframes[2].plane->distance, 4.5, 1e-12);

  const auto img = loadKeyframeImage(*route, 2);
  ASSERT_TRUE(img.isOk());
  EXPECT_EQ(img->at<uint8_t>(5, 5), 20);
  const auto f = loadKeyframeFeatures(*route, 1);
  ASSERT_TRUE(f.isOk()) << f.status().toString();
  EXPECT_EQ(f->keypoints.size(), 6u);
  EXPECT_EQ(cv::norm(f->descriptors, features(6).descriptors, cv::NORM_INF) >= 0, true);
  const auto l = loadKeyframeLines(*route, 0);
  ASSERT_TRUE(l.isOk()) << l.status().toString();
  ASSERT_EQ(l->size(), 2u);
  EXPECT_DOUBLE_EQ((*l)[0].x, 12.25);
  EXPECT_EQ((*l)[0].polarity, EdgePolarity::kDarkRight);
  EXPECT_EQ(loadKeyframeLines(*route, 7).status().code(), StatusCode::kInvalidInput);
}

// A crash while writing keyframe 3: its files (or a temporary) exist but the index was not
// rewritten. The route loads with the keyframes written before.
TEST(Route, CrashLosesAtMostTheLastKeyframe) {
  const std::string dir = temporaryDirectory();
  writeRoute(dir, 3);
  std::ofstream(dir + "/keyframes/000003.png") << "partial";
  std::ofstream(dir + "/route.yaml.tmp.12345") << "format_version: 1\nkeyf";
  const auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  EXPECT_EQ(route->keyframes.size(), 3u);
}

TEST(Route, CorruptOrMissingFilesNameTheFile) {
  const std::string dir = temporaryDirectory();
  writeRoute(dir, 2);
  // Missing route.
  auto missing = loadRoute(dir + "/nowhere");
  EXPECT_EQ(missing.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(missing.status().message().find("route.yaml not found"), std::string::npos);
  // Truncated index.
  const auto index = readWholeFile(dir + "/route.yaml");
  ASSERT_TRUE(index.isOk());
  ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", index->substr(0, index->size() / 2)).isOk());
  auto truncated = loadRoute(dir);
  EXPECT_EQ(truncated.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(truncated.status().message().find("route.yaml"), std::string::npos)
      << truncated.status().message();
  // Unknown version.
  std::string newer = *index;
  newer.replace(newer.find("format_version: 5"), 17, "format_version: 7");
  ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", newer).isOk());
  auto version = loadRoute(dir);
  EXPECT_NE(version.status().message().find("unknown format_version 7"), std::string::npos);
  // A keyframe file missing.
  ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", *index).isOk());
  ASSERT_EQ(::unlink((dir + "/keyframes/000001.lines.yml").c_str()), 0);
  auto lost = loadRoute(dir);
  EXPECT_NE(lost.status().message().find("000001.lines.yml"), std::string::npos)
      << lost.status().message();
  // A corrupt features file.
  std::ofstream(dir + "/keyframes/000001.lines.yml") << "lines: [{x: 1}]\n";
  const auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  auto bad_lines = loadKeyframeLines(*route, 1);
  EXPECT_NE(bad_lines.status().message().find("000001.lines.yml"), std::string::npos);
  std::ofstream(dir + "/keyframes/000000.features.yml") << "%YAML:1.0\nkeypoints: [1, 2";
  auto bad_features = loadKeyframeFeatures(*route, 0);
  EXPECT_EQ(bad_features.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(bad_features.status().message().find("000000.features.yml"), std::string::npos);
}

TEST(Route, WriterRefusesToOverwriteAndBadInput) {
  const std::string dir = temporaryDirectory();
  writeRoute(dir, 1);
  EXPECT_EQ(RouteWriter::create(dir, info()).status().code(), StatusCode::kInvalidInput);
  auto writer = RouteWriter::create(dir, info(), /*overwrite=*/true);
  ASSERT_TRUE(writer.isOk());
  EXPECT_EQ(writer->addKeyframe(cv::Mat(), features(3), {}, Pose2D(), 1.0).code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(writer->addKeyframe(image(1), features(3), {}, Pose2D(std::nan(""), 0, 0), 1.0).code(),
            StatusCode::kInvalidInput);
  EXPECT_EQ(writer->setPlanes({std::nullopt, std::nullopt}, 1.0).code(), StatusCode::kInvalidInput);
  RouteInfo bad = info();
  bad.camera.fx = 0.0;
  EXPECT_EQ(RouteWriter::create(temporaryDirectory(), bad).status().code(), StatusCode::kInvalidInput);
}

TEST(Route, ReadOnlyDirectoryIsAClearErrorAtStart) {
  if (::geteuid() == 0) GTEST_SKIP() << "running as root: permissions do not stop writes";
  const std::string dir = temporaryDirectory();
  ASSERT_EQ(::mkdir((dir + "/keyframes").c_str(), 0755), 0);
  ASSERT_EQ(::chmod(dir.c_str(), 0555), 0);
  ASSERT_EQ(::chmod((dir + "/keyframes").c_str(), 0555), 0);
  const auto writer = RouteWriter::create(dir, info());
  EXPECT_EQ(writer.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(writer.status().message().find(dir), std::string::npos) << writer.status().message();
  const Status checked = checkRouteDirectoryWritable(dir, /*overwrite=*/true);
  EXPECT_EQ(checked.code(), StatusCode::kInvalidInput);
  EXPECT_NE(checked.message().find("not writable"), std::string::npos) << checked.message();
  ::chmod(dir.c_str(), 0755);
}

// A route directory that cannot be created (its parent is a file): a clear error at start, also
// when running as root.
TEST(Route, UncreatableDirectoryIsAClearErrorAtStart) {
  const std::string dir = temporaryDirectory();
  std::ofstream(dir + "/plain_file") << "x";
  const auto writer = RouteWriter::create(dir + "/plain_file/route", info());
  EXPECT_EQ(writer.status().code(), StatusCode::kInvalidInput);
  EXPECT_NE(writer.status().message().find("plain_file/route"), std::string::npos)
      << writer.status().message();
  const Status checked = checkRouteDirectoryWritable(dir + "/plain_file/route", true);
  EXPECT_EQ(checked.code(), StatusCode::kInvalidInput);
  EXPECT_NE(checked.message().find("plain_file/route"), std::string::npos) << checked.message();
}

// An existing directory that refuses new files to everyone, root included (procfs): the probe
// write fails and the message names the directory.
TEST(Route, DirectoryTheKernelRefusesIsNotWritable) {
  const Status checked = checkRouteDirectoryWritable("/proc/1", true);
  EXPECT_EQ(checked.code(), StatusCode::kInvalidInput);
  EXPECT_NE(checked.message().find("/proc/1"), std::string::npos) << checked.message();
}

TEST(Route, WritableDirectoryPassesTheCheckAndKeepsNoProbe) {
  const std::string dir = temporaryDirectory() + "/new_route";
  EXPECT_TRUE(checkRouteDirectoryWritable(dir, false).isOk());
  std::ifstream probe(dir + "/keyframes/.write_probe");
  EXPECT_FALSE(probe.good());
  auto writer = RouteWriter::create(dir, info());
  ASSERT_TRUE(writer.isOk()) << writer.status().toString();
  const Status existing = checkRouteDirectoryWritable(dir, false);
  EXPECT_EQ(existing.code(), StatusCode::kInvalidInput);
  EXPECT_NE(existing.message().find("refusing to overwrite"), std::string::npos) << existing.message();
  EXPECT_TRUE(checkRouteDirectoryWritable(dir, true).isOk());
}

// A route taught with a tilted mount keeps its levelling (the repeat levels its images the same
// way); a level route's file has no such field, and a malformed one names the field.
TEST(Route, KeepsTheLevellingOfATiltedMount) {
  const std::string dir = temporaryDirectory();
  RouteInfo tilted = info();
  tilted.camera.camera_to_level =
      (Eigen::AngleAxisd(-0.035, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(0.017, Eigen::Vector3d::UnitZ()))
          .toRotationMatrix();
  auto writer = RouteWriter::create(dir, tilted);
  ASSERT_TRUE(writer.isOk()) << writer.status().toString();
  ASSERT_TRUE(writer->addKeyframe(image(10), features(5), lines(), Pose2D(0, 0, 0), 100.0).isOk());
  ASSERT_TRUE(writer->addKeyframe(image(20), features(6), lines(), Pose2D(1, 0, 0), 101.0).isOk());
  const auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  EXPECT_LT((route->info.camera.camera_to_level - tilted.camera.camera_to_level).norm(), 1e-12);

  const std::string level_dir = temporaryDirectory();
  writeRoute(level_dir, 2);
  const auto level = loadRoute(level_dir);
  ASSERT_TRUE(level.isOk()) << level.status().toString();
  EXPECT_TRUE(level->info.camera.camera_to_level.isIdentity(0.0));
  std::ifstream level_index(level_dir + "/route.yaml");
  const std::string level_text((std::istreambuf_iterator<char>(level_index)), std::istreambuf_iterator<char>());
  EXPECT_EQ(level_text.find("camera_to_level"), std::string::npos);

  std::ifstream in(dir + "/route.yaml");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto at = text.find("camera_to_level: [");
  ASSERT_NE(at, std::string::npos) << text;
  text.replace(at, std::string("camera_to_level: [").size(), "camera_to_level: [2, 0, 0, 0, 2, 0, 0, 0, 2, ");
  std::ofstream(dir + "/route.yaml") << text;
  const auto bad = loadRoute(dir);
  ASSERT_FALSE(bad.isOk());
  EXPECT_NE(bad.status().message().find("camera_to_level"), std::string::npos) << bad.status().message();
}

// Versions 1 (before experiences), 2 (before the measured noise), 3 (before the measured tilt) and 4
// (before the planes' uncertainty; these keyframes have no plane)
// are read as they are and rewritten as the current version by migrateRoute, keyframes unchanged and
// the match noise and tilt measured.
TEST(Route, MigratesOlderRoutesMeasuringTheirNoise) {
  for (const char* version : {"1", "2", "3", "4"}) {
    const std::string dir = temporaryDirectory();
    writeRoute(dir, 3);
    auto index = readWholeFile(dir + "/route.yaml");
    ASSERT_TRUE(index.isOk());
    std::string old = *index;
    old.replace(old.find("format_version: 5"), 17, std::string("format_version: ") + version);
    ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", old).isOk());
    const auto before = loadRoute(dir);
    ASSERT_TRUE(before.isOk()) << before.status().toString();
    EXPECT_EQ(before->loaded_format_version, std::atoi(version));
    EXPECT_FALSE(before->info.match_noise_measured);
    EXPECT_FALSE(before->info.tilt_measured);
    EXPECT_FALSE(routeMatchResidual(*before).has_value());
    EXPECT_FALSE(routeTiltSigma(*before).has_value());
    ASSERT_TRUE(migrateRoute(dir).isOk());
    const auto after = loadRoute(dir);
    ASSERT_TRUE(after.isOk()) << after.status().toString();
    EXPECT_EQ(after->loaded_format_version, kRouteFormatVersion);
    EXPECT_TRUE(after->info.match_noise_measured);
    EXPECT_TRUE(after->info.tilt_measured);
    ASSERT_EQ(after->keyframes.size(), 3u);
    EXPECT_DOUBLE_EQ(after->keyframes[2].pose.x, before->keyframes[2].pose.x);
    EXPECT_EQ(after->keyframes[1].features_file, before->keyframes[1].features_file);
  }
  EXPECT_FALSE(migrateRoute(temporaryDirectory() + "/nowhere").isOk());
}

// The measured noise round-trips; a value that is not finite, not positive or from too few inliers
// is refused on load naming the keyframe, and by the writer; the route's value is the median.
TEST(Route, MeasuredMatchNoiseIsKeptAndValidated) {
  const std::string dir = temporaryDirectory();
  writeRoute(dir, 3);
  auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk());
  route->info.match_noise_measured = true;
  route->keyframes[0].match_residual = MatchResidual{0.5, 100};
  route->keyframes[1].match_residual = MatchResidual{0.25, 50};
  route->keyframes[2].match_residual = MatchResidual{0.375, 80};
  ASSERT_TRUE(writeRouteIndex(*route).isOk());
  const auto loaded = loadRoute(dir);
  ASSERT_TRUE(loaded.isOk()) << loaded.status().toString();
  ASSERT_TRUE(loaded->keyframes[1].match_residual.has_value());
  EXPECT_DOUBLE_EQ(loaded->keyframes[1].match_residual->rms_px, 0.25);
  EXPECT_EQ(loaded->keyframes[1].match_residual->inliers, 50);
  ASSERT_TRUE(routeMatchResidual(*loaded).has_value());
  EXPECT_DOUBLE_EQ(*routeMatchResidual(*loaded), 0.375);

  auto index = readWholeFile(dir + "/route.yaml");
  ASSERT_TRUE(index.isOk());
  expectEachRefused(dir, *index, "{rms_px: 0.25, inliers: 50}",
                    {{"{rms_px: .nan, inliers: 50}", "keyframe 1"}, {"{rms_px: -0.25, inliers: 50}", "keyframe 1"},
                     {"{rms_px: 0.25, inliers: 2}", "keyframe 1"}, {"{rms_px: 0.25}", "inliers"}});
  RouteInfo info = route->info;
  auto writer = RouteWriter::create(temporaryDirectory(), info);
  ASSERT_TRUE(writer.isOk());
  ASSERT_TRUE(writer->addKeyframe(image(1), features(3), {}, Pose2D(0, 0, 0), 1.0).isOk());
  EXPECT_FALSE(writer->setMeasuredNoise({MatchResidual{std::nan(""), 10}}, {std::nullopt}).isOk());
  EXPECT_FALSE(writer->setMeasuredNoise({MatchResidual{0.3, 3}}, {std::nullopt}).isOk());
  EXPECT_FALSE(writer->setMeasuredNoise({}, {}).isOk());
  EXPECT_FALSE(writer->setMeasuredNoise({MatchResidual{0.3, 10}}, {}).isOk());
  EXPECT_TRUE(writer->setMeasuredNoise({MatchResidual{0.3, 10}}, {std::nullopt}).isOk());
}

// The measured tilt round-trips; the route's tilt σ is the robust std of the pairs' pitch and roll
// (1.4826 × the median magnitude: one pair at a corner far off does not move it); a tilt that is
// not finite or beyond kMaxPairTilt is refused on load naming the keyframe, and by the writer; a
// version-3 index with a measured tilt is refused.
TEST(Route, MeasuredTiltIsKeptAndValidated) {
  const std::string dir = temporaryDirectory();
  writeRoute(dir, 4);
  auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk());
  EXPECT_FALSE(routeTiltSigma(*route).has_value());
  route->info.match_noise_measured = true;
  route->info.tilt_measured = true;
  route->keyframes[0].tilt_to_next = PairTilt{0.0078125, -0.005};
  route->keyframes[1].tilt_to_next = PairTilt{-0.015625, 0.00390625};  // exact in binary and text
  route->keyframes[2].tilt_to_next = PairTilt{0.09, -0.08};  // a corner's mixed homography
  ASSERT_TRUE(writeRouteIndex(*route).isOk());
  const auto loaded = loadRoute(dir);
  ASSERT_TRUE(loaded.isOk()) << loaded.status().toString();
  EXPECT_TRUE(loaded->info.tilt_measured);
  ASSERT_TRUE(loaded->keyframes[1].tilt_to_next.has_value());
  EXPECT_DOUBLE_EQ(loaded->keyframes[1].tilt_to_next->pitch, -0.015625);
  EXPECT_DOUBLE_EQ(loaded->keyframes[1].tilt_to_next->roll, 0.00390625);
  EXPECT_FALSE(loaded->keyframes[3].tilt_to_next.has_value());
  // Magnitudes 0.0039 0.005 0.0078 0.0156 0.08 0.09: the upper median (index 3) 0.015625.
  ASSERT_TRUE(routeTiltSigma(*loaded).has_value());
  EXPECT_NEAR(*routeTiltSigma(*loaded), 1.4826 * 0.015625, 1e-12);

  auto index = readWholeFile(dir + "/route.yaml");
  ASSERT_TRUE(index.isOk());
  expectEachRefused(dir, *index, "{pitch: -0.015625, roll: 0.00390625}",
                    {{"{pitch: .nan, roll: 0.002}", "keyframe 1"}, {"{pitch: -0.2, roll: 0.002}", "keyframe 1"},
                     {"{pitch: -0.02}", "roll"}});
  std::string older = *index;
  older.replace(older.find("format_version: 5"), 17, "format_version: 3");
  ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", older).isOk());
  const auto refused = loadRoute(dir);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("format_version 4"), std::string::npos) << refused.status().message();

  auto writer = RouteWriter::create(temporaryDirectory(), route->info);
  ASSERT_TRUE(writer.isOk());
  ASSERT_TRUE(writer->addKeyframe(image(1), features(3), {}, Pose2D(0, 0, 0), 1.0).isOk());
  EXPECT_FALSE(writer->setMeasuredNoise({std::nullopt}, {PairTilt{std::nan(""), 0.0}}).isOk());
  EXPECT_FALSE(writer->setMeasuredNoise({std::nullopt}, {PairTilt{0.0, 0.15}}).isOk());
  EXPECT_TRUE(writer->setMeasuredNoise({std::nullopt}, {PairTilt{0.0, 0.05}}).isOk());
  EXPECT_TRUE(writer->route().info.tilt_measured);
}

// Each plane's uncertainty (format 5) round-trips; stored counts only where every keyframe with a
// plane has it; a value out of range, not finite, an asymmetric fix error, a heading intercept without
// the fix error, one on a keyframe without a plane or in a format 4 index is refused on load naming
// the keyframe, and by the writer.
TEST(Route, PlaneUncertaintyIsKeptAndValidated) {
  const std::string dir = temporaryDirectory();
  writeRoute(dir, 3);
  auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk()) << route.status().toString();
  EXPECT_FALSE(planeUncertaintyStored(*route));  // no planes: nothing to store
  EXPECT_FALSE(planeUncertaintyMissing(*route));
  for (RouteKeyframe& keyframe : route->keyframes) keyframe.plane = ScenePlane{Eigen::Vector3d::UnitZ(), 4.0};
  EXPECT_TRUE(planeUncertaintyMissing(*route));
  PlaneUncertainty measured;
  measured.normal_sigma_rad = 0.0625;
  measured.distance_sigma = 0.03125;
  measured.pivot = Eigen::Vector3d(0.5, -0.25, 4.0);
  Eigen::Matrix3d error;
  error << 0.0004, 0.0001, 0.0, 0.0001, 0.0009, 0.0, 0.0, 0.0, 1e-6;
  measured.fix_error_per_m2 = error;
  measured.fix_heading_intercept_rad = -0.00025;
  route->keyframes[0].plane_uncertainty = measured;
  route->keyframes[1].plane_uncertainty = PlaneUncertainty{0.125, 0.25, std::nullopt, std::nullopt, std::nullopt};
  EXPECT_TRUE(planeUncertaintyMissing(*route));  // keyframe 2's
  EXPECT_FALSE(planeUncertaintyStored(*route));
  route->keyframes[2].plane.reset();
  EXPECT_FALSE(planeUncertaintyStored(*route));  // no method: as by no build
  route->info.plane_uncertainty_method = kPlaneUncertaintyMethod;
  EXPECT_TRUE(planeUncertaintyStored(*route));
  ASSERT_TRUE(writeRouteIndex(*route).isOk());
  const auto loaded = loadRoute(dir);
  ASSERT_TRUE(loaded.isOk()) << loaded.status().toString();
  EXPECT_TRUE(planeUncertaintyStored(*loaded));
  ASSERT_TRUE(loaded->keyframes[0].plane_uncertainty);
  const PlaneUncertainty& read = *loaded->keyframes[0].plane_uncertainty;
  EXPECT_DOUBLE_EQ(read.normal_sigma_rad, 0.0625);
  EXPECT_DOUBLE_EQ(read.distance_sigma, 0.03125);
  ASSERT_TRUE(read.pivot);
  EXPECT_DOUBLE_EQ(read.pivot->y(), -0.25);
  ASSERT_TRUE(read.fix_error_per_m2);
  EXPECT_LT((*read.fix_error_per_m2 - error).cwiseAbs().maxCoeff(), 1e-15);
  ASSERT_TRUE(read.fix_heading_intercept_rad);
  EXPECT_DOUBLE_EQ(*read.fix_heading_intercept_rad, -0.00025);
  ASSERT_TRUE(loaded->keyframes[1].plane_uncertainty);
  EXPECT_FALSE(loaded->keyframes[1].plane_uncertainty->fix_heading_intercept_rad);
  EXPECT_FALSE(loaded->keyframes[1].plane_uncertainty->pivot);
  EXPECT_FALSE(loaded->keyframes[1].plane_uncertainty->fix_error_per_m2);
  EXPECT_FALSE(loaded->keyframes[2].plane_uncertainty);
  Route replaned = *loaded;  // a plane changed after its uncertainty was measured
  replaned.keyframes[0].plane->distance = 4.5;
  EXPECT_TRUE(planeUncertaintyMissing(replaned));
  EXPECT_FALSE(planeUncertaintyStored(replaned));

  auto index = readWholeFile(dir + "/route.yaml");
  ASSERT_TRUE(index.isOk());
  expectEachRefused(dir, *index, "{normal_rad: 0.125, distance: 0.25}",
                    {{"{normal_rad: .nan, distance: 0.25}", "keyframe 1"},
                     {"{normal_rad: 0.6, distance: 0.25}", "keyframe 1"},
                     {"{normal_rad: 0.125, distance: -0.01}", "keyframe 1"},
                     {"{normal_rad: 0.125, distance: 0.25, pivot: [1, 2]}", "pivot"},
                     {"{normal_rad: 0.125, distance: 0.25, fix_error_per_m2: [1, 0, 0, 0, 1, 0, 0, 0, -1]}", "negative"},
                     {"{normal_rad: 0.125, distance: 0.25, fix_heading_intercept_rad: 0.001}",
                      "keyframe 1: plane_uncertainty: fix_heading_intercept_rad without fix_error_per_m2"},
                     {"{normal_rad: 0.125, distance: 0.25, fix_error_per_m2: [1, 0, 0, 0, 1, 0, 0, 0, 1], "
                      "fix_heading_intercept_rad: .nan}", "keyframe 1: plane_uncertainty: fix_heading_intercept_rad must be within"},
                     {"{normal_rad: 0.125, distance: 0.25, fix_error_per_m2: [1, 0, 0, 0, 1, 0, 0, 0, 1], "
                      "fix_heading_intercept_rad: -0.06}", "fix_heading_intercept_rad must be within [-0.05, 0.05]"},
                     {"{normal_rad: 0.125}", "distance"},
                     {"{normal_rad: 0.125, distance: 0.25, pivot: [0, 0, 3]}", "pivot is not on the keyframe's plane"}});
  // Measured by a build whose measurement differed: read, but measured again (missing).
  std::string other_method = *index;
  const std::string method_line = "plane_uncertainty_method: " + std::to_string(kPlaneUncertaintyMethod);
  ASSERT_NE(other_method.find(method_line), std::string::npos) << other_method;
  other_method.replace(other_method.find(method_line), method_line.size(), "plane_uncertainty_method: 99");
  ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", other_method).isOk());
  const auto measured_otherwise = loadRoute(dir);
  ASSERT_TRUE(measured_otherwise.isOk()) << measured_otherwise.status().toString();
  EXPECT_TRUE(planeUncertaintyMissing(*measured_otherwise));
  std::string without_method = *index;
  without_method.erase(without_method.find(method_line), method_line.size() + 1);
  ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", without_method).isOk());
  auto refused = loadRoute(dir);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("keyframe 0: plane_uncertainty without the route's plane_uncertainty_method"),
            std::string::npos) << refused.status().message();
  std::string older = *index;
  older.replace(older.find("format_version: 5"), 17, "format_version: 4");
  ASSERT_TRUE(writeFileAtomically(dir + "/route.yaml", older).isOk());
  refused = loadRoute(dir);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("format_version 5"), std::string::npos) << refused.status().message();
  Route asymmetric = *loaded;
  (*asymmetric.keyframes[0].plane_uncertainty->fix_error_per_m2)(0, 1) = 0.5;
  ASSERT_TRUE(writeRouteIndex(asymmetric).isOk());
  refused = loadRoute(dir);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("keyframe 0: plane_uncertainty: fix_error_per_m2 is not symmetric"),
            std::string::npos) << refused.status().message();
  Route planeless = *loaded;
  planeless.keyframes[0].plane.reset();
  ASSERT_TRUE(writeRouteIndex(planeless).isOk());
  refused = loadRoute(dir);
  ASSERT_FALSE(refused.isOk());
  EXPECT_NE(refused.status().message().find("keyframe 0: plane_uncertainty without a plane"), std::string::npos)
      << refused.status().message();

  auto writer = RouteWriter::create(temporaryDirectory(), route->info);
  ASSERT_TRUE(writer.isOk());
  ASSERT_TRUE(writer->addKeyframe(image(1), features(3), {}, Pose2D(0, 0, 0), 1.0).isOk());
  ASSERT_TRUE(writer->addKeyframe(image(2), features(3), {}, Pose2D(1, 0, 0), 2.0).isOk());
  EXPECT_FALSE(writer->setPlaneUncertainties({measured}).isOk());  // one per keyframe
  const Status planeless_refused = writer->setPlaneUncertainties({measured, std::nullopt});
  EXPECT_NE(planeless_refused.message().find("keyframe 0: plane uncertainty without a plane"), std::string::npos)
      << planeless_refused.message();
  ASSERT_TRUE(writer->setPlanes({ScenePlane{Eigen::Vector3d::UnitZ(), 4.0}, std::nullopt}, 0.0).isOk());
  PlaneUncertainty not_finite = measured;
  not_finite.pivot = Eigen::Vector3d(std::nan(""), 0.0, 4.0);
  const Status nan_refused = writer->setPlaneUncertainties({not_finite, std::nullopt});
  EXPECT_NE(nan_refused.message().find("keyframe 0"), std::string::npos) << nan_refused.message();
  EXPECT_NE(nan_refused.message().find("pivot"), std::string::npos) << nan_refused.message();
  ASSERT_TRUE(writer->setPlaneUncertainties({measured, std::nullopt}).isOk());
  const auto written = loadRoute(writer->route().directory);
  ASSERT_TRUE(written.isOk()) << written.status().toString();
  EXPECT_TRUE(planeUncertaintyStored(*written));
  // New planes make the old uncertainty stale: setPlanes clears it.
  ASSERT_TRUE(writer->setPlanes({ScenePlane{Eigen::Vector3d::UnitZ(), 5.0}, std::nullopt}, 0.0).isOk());
  EXPECT_TRUE(planeUncertaintyMissing(writer->route()));
}

// Experiences: written file by file then the index (each atomically), read back with their pose
// and covariance; at most max_experiences per keyframe (the oldest dropped and its files removed);
// bad input refused; a missing experience file or a NaN in an index named on load.
TEST(Route, ExperiencesAreKeptBoundedAndValidated) {
  const std::string dir = temporaryDirectory();
  writeRoute(dir, 3);
  auto route = loadRoute(dir);
  ASSERT_TRUE(route.isOk());
  Eigen::Matrix3d covariance = Eigen::Vector3d(4e-4, 9e-4, 1e-5).asDiagonal();
  covariance(0, 1) = covariance(1, 0) = 1e-4;
  for (int e = 0; e < 4; ++e) {
    ASSERT_TRUE(addExperience(*route, 1, image(100 + e), features(8), Pose2D(1.0 + 0.01 * e, 0.5, 0.1), covariance,
                              200.0 + e, 3)
                    .isOk());
  }
  const auto reloaded = loadRoute(dir);
  ASSERT_TRUE(reloaded.isOk()) << reloaded.status().toString();
  const auto& experiences = reloaded->keyframes[1].experiences;
  ASSERT_EQ(experiences.size(), 3u);
  EXPECT_EQ(experiences.front().id, 2);
  EXPECT_EQ(experiences.back().id, 4);
  EXPECT_DOUBLE_EQ(experiences.back().pose.x, 1.03);
  EXPECT_DOUBLE_EQ(experiences.back().stamp, 203.0);
  EXPECT_TRUE(experiences.back().pose_covariance.isApprox(covariance));
  EXPECT_TRUE(reloaded->keyframes[0].experiences.empty());
  EXPECT_FALSE(std::filesystem::exists(dir + "/keyframes/000001.e1.png"));  // dropped with its files
  EXPECT_FALSE(std::filesystem::exists(dir + "/keyframes/000001.e1.features.yml"));
  const auto f = loadExperienceFeatures(*reloaded, 1, 2);
  ASSERT_TRUE(f.isOk()) << f.status().toString();
  EXPECT_EQ(f->keypoints.size(), 8u);
  EXPECT_FALSE(loadExperienceFeatures(*reloaded, 1, 3).isOk());

  Route r = *reloaded;
  Eigen::Matrix3d nan = covariance;
  nan(2, 2) = std::nan("");
  EXPECT_FALSE(addExperience(r, 1, image(1), features(8), Pose2D(1, 0.5, 0.1), nan, 1.0).isOk());
  EXPECT_FALSE(addExperience(r, 9, image(1), features(8), Pose2D(1, 0.5, 0.1), covariance, 1.0).isOk());
  EXPECT_FALSE(addExperience(r, 1, cv::Mat(), features(8), Pose2D(1, 0.5, 0.1), covariance, 1.0).isOk());
  ImageFeatures sift = features(8);
  sift.type = FeatureType::kSift;
  EXPECT_FALSE(addExperience(r, 1, image(1), sift, Pose2D(1, 0.5, 0.1), covariance, 1.0).isOk());

  ASSERT_EQ(::unlink((dir + "/keyframes/000001.e3.features.yml").c_str()), 0);
  const auto lost = loadRoute(dir);
  ASSERT_FALSE(lost.isOk());
  EXPECT_NE(lost.status().message().find("000001.e3.features.yml"), std::string::npos) << lost.status().message();
}
