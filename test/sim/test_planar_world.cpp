#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iostream>
#include <utility>

#include "homography_teach_repeat/sim/differential_drive.h"
#include "homography_teach_repeat/geometry/camera_tilt.h"
#include "homography_teach_repeat/geometry/scene_plane.h"
#include "homography_teach_repeat/features/feature_extractor.h"
#include "homography_teach_repeat/features/feature_matcher.h"
#include "homography_teach_repeat/homography/homography.h"
#include "homography_teach_repeat/eval/path_deviation.h"
#include "homography_teach_repeat/sim/planar_world.h"
#include "homography_teach_repeat/homography/robust_homography.h"
#include "homography_teach_repeat/sim/waypoint_driver.h"
#include "homography_teach_repeat/sim/world_renderer.h"
#include "support/synthetic_route.h"
#include "support/test_images.h"

using namespace homography_teach_repeat;

namespace {

// The 640x480, f = 500 px camera of the synthetic route tests.
PinholeCamera simCamera() { return PinholeCamera(test_support::syntheticCalibration()); }

cv::Mat colourTexture(int seed) {
  cv::Mat grey = test_support::makeTexture(400, 300, seed);
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

Wall makeWall(Eigen::Vector2d a, Eigen::Vector2d b, cv::Mat texture, double height = 2.0) {
  Wall w;
  w.start = a;
  w.end = b;
  w.height = height;
  w.texture = texture;
  w.texture_width = 2.0;
  w.texture_height = 1.5;
  return w;
}

// The wall x = 4 (world), seen from cameras near the origin looking along +x; one copy of the
// texture covers it (a tiled texture repeats, and repeated patterns mismatch).
PlanarWorld oneWall() {
  PlanarWorld world;
  world.source = "test";
  cv::Mat grey = test_support::makeTexture(800, 400, 21), texture;
  cv::cvtColor(grey, texture, cv::COLOR_GRAY2BGR);
  Wall wall = makeWall({4.0, 3.0}, {4.0, -3.0}, texture, 3.0);
  wall.texture_width = 6.0;
  wall.texture_height = 3.0;
  world.walls.push_back(wall);
  return world;
}

// The plane of the wall x = 4 in the camera frame of a camera at `pose` (x right, y down, z forward).
ScenePlane wallPlaneInCamera(const Pose2D& pose, double wall_x) {
  // World normal pointing away from the camera: +x. In camera axes: n = (-m.left, 0, m.forward).
  const Eigen::Vector2d m(1.0, 0.0);
  const Eigen::Vector2d forward(std::cos(pose.yaw), std::sin(pose.yaw));
  const Eigen::Vector2d left(-std::sin(pose.yaw), std::cos(pose.yaw));
  ScenePlane plane;
  plane.normal = Eigen::Vector3d(-m.dot(left), 0.0, m.dot(forward));
  plane.distance = wall_x - pose.x;
  return plane;
}

// The image of `world` from `pose` with one sample per pixel and with `supersampling`, both with
// the simulator's lens blur (0.5 px) and no noise.
std::pair<cv::Mat, cv::Mat> sampledAndSupersampled(const PlanarWorld& world, const Pose2D& pose, int supersampling) {
  RenderOptions options;
  options.texture_filtering = false;
  options.blur_sigma = 0.5;
  const WorldRenderer sampled(simCamera(), options);
  options.supersampling = supersampling;
  const WorldRenderer supersampled(simCamera(), options);
  cv::RNG rng(1);
  return {sampled.render(world, pose, 1.0, rng), supersampled.render(world, pose, 1.0, rng)};
}

}  // namespace

// The rendered images of a textured wall from two poses are related by exactly the plane-induced
// homography of docs/math.md §1.2: features matched between them fit it within a fraction of a pixel.
TEST(WorldRenderer, TwoViewsOfAWallAreRelatedByThePlaneHomography) {
  const PlanarWorld world = oneWall();
  const WorldRenderer renderer(simCamera(), RenderOptions());
  cv::RNG rng(1);
  const Pose2D a(0.0, 0.0, 0.0), b(0.6, 0.25, 0.12);
  const cv::Mat image_a = renderer.render(world, a, 1.0, rng);
  const cv::Mat image_b = renderer.render(world, b, 1.0, rng);
  const PlanarPose relative = rep103ToCameraAxes(a.inverse().compose(b));
  const Eigen::Matrix3d H = planeInducedHomography(simCamera(), relative, wallPlaneInCamera(a, 4.0));
  FeatureOptions fo;
  fo.type = FeatureType::kSift;
  FeatureExtractor extractor(fo);
  const auto fa = extractor.extract(image_a);
  const auto fb = extractor.extract(image_b);
  ASSERT_TRUE(fa.isOk() && fb.isOk());
  const auto matches = matchFeatures(*fa, *fb, MatchOptions());
  ASSERT_TRUE(matches.isOk());
  const PointMatches points = toPointMatches(*fa, *fb, *matches);
  ASSERT_GT(points.size(), 100u);
  std::vector<double> errors;
  for (const auto& m : points) errors.push_back(transferError(H, m));
  std::sort(errors.begin(), errors.end());
  EXPECT_LT(errors[errors.size() / 2], 0.3) << "median transfer error of the analytic homography [px]";
}

// Supersampling renders the same geometry: a wall seen from 1 m (a texel spans several pixels, so
// one sample per pixel does not alias it) looks the same with k = 2, closer than the same image
// moved by a quarter pixel (what a wrong pixel centre of the fine image, (k − 1)/2, would do).
TEST(WorldRenderer, SupersamplingKeepsThePixelsWhereTheyAre) {
  const auto [one_sample, supersampled] = sampledAndSupersampled(oneWall(), Pose2D(3.0, 0.1, 0.05), 2);
  cv::Mat a, b, moved;
  one_sample.convertTo(a, CV_32F);
  supersampled.convertTo(b, CV_32F);
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 0.25, 0, 1, 0.25);
  cv::warpAffine(a, moved, shift, a.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  const cv::Rect inner(20, 20, a.cols - 40, a.rows - 40);
  const double same = cv::mean(cv::abs(a(inner) - b(inner)))[0];
  const double quarter_pixel = cv::mean(cv::abs(a(inner) - moved(inner)))[0];
  EXPECT_LT(same, 0.5 * quarter_pixel) << "mean |difference| [grey levels]: " << same << " against " << quarter_pixel;
}

// A texture finer than the pixels (stripes of 8 mm seen from 3 m, a pixel spans 6 mm): one sample
// per pixel aliases it into coarse full-contrast stripes; supersampled, the lens and the pixel's
// area average it to its mean grey, as a camera would.
TEST(WorldRenderer, SupersamplingBandLimitsATextureFinerThanThePixels) {
  cv::Mat stripes(96, 96, CV_8UC3);  // whole periods: the tiled texture is periodic
  for (int c = 0; c < stripes.cols; ++c) stripes.col(c).setTo(cv::Scalar::all((c / 4) % 2 == 0 ? 0 : 255));
  PlanarWorld world;
  world.source = "test";
  Wall wall = makeWall({4.0, 3.0}, {4.0, -3.0}, stripes, 3.0);
  wall.texture_width = 0.096;  // 1 mm per texel, tiled
  wall.texture_height = 0.096;
  world.walls.push_back(wall);
  const auto [one_sample, supersampled] = sampledAndSupersampled(world, Pose2D(1.0, 0.0, 0.0), 4);
  const cv::Rect on_wall(200, 200, 240, 80);  // the wall fills the image's middle rows
  cv::Scalar mean, deviation;
  cv::meanStdDev(one_sample(on_wall), mean, deviation);
  EXPECT_GT(deviation[0], 30.0) << "one sample per pixel aliases the stripes";  // 100 when written
  cv::meanStdDev(supersampled(on_wall), mean, deviation);
  // 8 when written: the stripes' sharp edges have harmonics beyond even the fine image's pixels.
  EXPECT_LT(deviation[0], 12.0);
  EXPECT_NEAR(mean[0], 127.5, 8.0);
}

// The image of `world` from `pose` with the simulator's lens blur (0.5 px), no noise, and `change`
// made to the options.
cv::Mat renderWith(const PlanarWorld& world, const Pose2D& pose, const std::function<void(RenderOptions&)>& change) {
  RenderOptions options;
  options.blur_sigma = 0.5;
  change(options);
  const WorldRenderer renderer(simCamera(), options);
  cv::RNG rng(1);
  return renderer.render(world, pose, 1.0, rng);
}

double meanAbsoluteDifference(const cv::Mat& a, const cv::Mat& b, const cv::Rect& region) {
  cv::Mat fa, fb;
  a(region).convertTo(fa, CV_32F);
  b(region).convertTo(fb, CV_32F);
  return cv::mean(cv::abs(fa - fb))[0];
}

// Texture filtering band-limits the stripes as supersampling does (8 mm from 3 m, 6 mm a pixel),
// with the level camera (rendered by columns) and a tilted one (a ray per pixel).
TEST(WorldRenderer, TextureFilteringBandLimitsATextureFinerThanThePixels) {
  cv::Mat stripes(96, 96, CV_8UC3);
  for (int c = 0; c < stripes.cols; ++c) stripes.col(c).setTo(cv::Scalar::all((c / 4) % 2 == 0 ? 0 : 255));
  PlanarWorld world;
  world.source = "test";
  Wall wall = makeWall({4.0, 3.0}, {4.0, -3.0}, stripes, 3.0);
  wall.texture_width = 0.096;
  wall.texture_height = 0.096;
  world.walls.push_back(wall);
  for (const double pitch : {0.0, -0.1}) {  // (looking up: the wall's foot stays below the rows)
    const cv::Mat image = renderWith(world, Pose2D(1.0, 0.0, 0.0), [&](RenderOptions& o) {
      o.texture_filtering = true;
      o.camera_pitch = pitch;
    });
    cv::Scalar mean, deviation;
    cv::meanStdDev(image(cv::Rect(200, 200, 240, 80)), mean, deviation);
    EXPECT_LT(deviation[0], 12.0) << "pitch " << pitch;  // 100 with one sample per pixel; 3.2-3.4 when written
    EXPECT_NEAR(mean[0], 127.5, 8.0) << "pitch " << pitch;
  }
}

// Texture filtering gives the band-limited image that fine supersampling (k = 8) does: of a wall
// 10 m away (2.7 texels a pixel, where one sample per pixel aliases) several times closer to it
// than one sample per pixel is (0.26 against 1.57 grey levels when written), and of a wall 1 m
// away (a texel spans 3.7 pixels) closer than the same image moved by a quarter pixel (0.07
// against 0.39).
TEST(WorldRenderer, TextureFilteringIsTheBandLimitedImage) {
  const PlanarWorld world = oneWall();
  const auto filtered = [](RenderOptions& o) { o.texture_filtering = true; };
  const auto fine = [](RenderOptions& o) {
    o.texture_filtering = false;
    o.supersampling = 8;
  };
  const auto one_sample = [](RenderOptions& o) { o.texture_filtering = false; };
  const Pose2D far(-6.0, 0.3, 0.0);
  const cv::Rect far_wall(190, 150, 260, 100);  // the wall 10 m away: columns 175-475, rows 115-265
  const cv::Mat reference = renderWith(world, far, fine);
  const double filtered_off = meanAbsoluteDifference(renderWith(world, far, filtered), reference, far_wall);
  const double one_sample_off = meanAbsoluteDifference(renderWith(world, far, one_sample), reference, far_wall);
  EXPECT_LT(filtered_off, 0.3 * one_sample_off) << filtered_off << " against " << one_sample_off << " grey levels";

  const Pose2D near(3.0, 0.1, 0.05);
  const cv::Mat near_reference = renderWith(world, near, fine), near_filtered = renderWith(world, near, filtered);
  cv::Mat moved;
  const cv::Mat shift = (cv::Mat_<double>(2, 3) << 1, 0, 0.25, 0, 1, 0.25);
  cv::warpAffine(near_reference, moved, shift, near_reference.size(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  const cv::Rect inner(20, 20, 600, 440);
  const double same = meanAbsoluteDifference(near_filtered, near_reference, inner);
  const double quarter_pixel = meanAbsoluteDifference(moved, near_reference, inner);
  EXPECT_LT(same, 0.5 * quarter_pixel) << same << " against " << quarter_pixel << " grey levels";
}

// Two ways to band-limit the image at once are refused.
TEST(WorldRenderer, TextureFilteringWithSupersamplingIsRefused) {
  RenderOptions options;
  options.texture_filtering = true;
  options.supersampling = 2;
  EXPECT_THROW(WorldRenderer(simCamera(), options), std::invalid_argument);
}

// RenderOptions::supersampling is 1-8.
TEST(WorldRenderer, SupersamplingOutsideItsRangeIsRefused) {
  RenderOptions options;
  options.texture_filtering = false;
  for (const int k : {0, 9}) {
    options.supersampling = k;
    EXPECT_THROW(WorldRenderer(simCamera(), options), std::invalid_argument);
  }
}

// A near wall hides the far one in the columns it covers; walls behind the camera are not drawn.
TEST(WorldRenderer, OcclusionAndClippingBehindTheCamera) {
  PlanarWorld world;
  world.source = "test";
  world.walls.push_back(makeWall({6.0, 5.0}, {6.0, -5.0}, cv::Mat(10, 10, CV_8UC3, cv::Scalar(255, 0, 0))));
  world.walls.push_back(makeWall({2.0, 0.5}, {2.0, -0.5}, cv::Mat(10, 10, CV_8UC3, cv::Scalar(0, 0, 255))));
  world.walls.push_back(makeWall({-1.0, 5.0}, {-1.0, -5.0}, cv::Mat(10, 10, CV_8UC3, cv::Scalar(0, 255, 0))));
  RenderOptions options;
  options.camera_height = 1.0;
  const WorldRenderer renderer(simCamera(), options);
  cv::RNG rng(1);
  const cv::Mat image = renderer.render(world, Pose2D(0.0, 0.0, 0.0), 1.0, rng);
  // Centre column: the near (red) wall; the near wall spans |x_n| < 0.25 -> |u - cx| < 125 px.
  EXPECT_EQ(image.at<cv::Vec3b>(240, 320), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(image.at<cv::Vec3b>(240, 320 + 150), cv::Vec3b(255, 0, 0));  // far (blue) wall beside it
  // No green anywhere: the wall behind the camera is clipped.
  cv::Mat green;
  cv::inRange(image, cv::Scalar(0, 250, 0), cv::Scalar(5, 255, 5), green);
  EXPECT_EQ(cv::countNonZero(green), 0);
  // Floor below the near wall's foot, ceiling above the far wall's top (height 2 m at 6 m: 1 m
  // above the camera -> 500 * 1 / 6 = 83 px above the centre).
  EXPECT_EQ(image.at<cv::Vec3b>(479, 470), world.floor_colour);
  EXPECT_EQ(image.at<cv::Vec3b>(240 - 100, 470), world.ceiling_colour);
  // Facing away from every wall but the green one: only green, floor and ceiling.
  const cv::Mat back = renderer.render(world, Pose2D(0.0, 0.0, M_PI), 1.0, rng);
  EXPECT_EQ(back.at<cv::Vec3b>(240, 320), cv::Vec3b(0, 255, 0));
}

// Mean absolute difference [grey levels] between `image` and `reference` sampled (bilinearly) at
// `reference_pixel(u, v)`, over the pixels of `image` 40 px or more inside both images.
template <typename Map>
double meanDifferenceAfterMapping(const cv::Mat& image, const cv::Mat& reference, Map reference_pixel) {
  cv::Mat map_x(image.size(), CV_32F), map_y(image.size(), CV_32F);
  for (int v = 0; v < image.rows; ++v) {
    for (int u = 0; u < image.cols; ++u) {
      const cv::Point2d p = reference_pixel(u, v);
      map_x.at<float>(v, u) = static_cast<float>(p.x);
      map_y.at<float>(v, u) = static_cast<float>(p.y);
    }
  }
  cv::Mat warped, a, b;
  cv::remap(reference, warped, map_x, map_y, cv::INTER_LINEAR);
  cv::cvtColor(image, a, cv::COLOR_BGR2GRAY);
  cv::cvtColor(warped, b, cv::COLOR_BGR2GRAY);
  double sum = 0.0;
  int count = 0;
  for (int v = 40; v < image.rows - 40; ++v) {
    for (int u = 40; u < image.cols - 40; ++u) {
      const float x = map_x.at<float>(v, u), y = map_y.at<float>(v, u);
      if (x < 40 || y < 40 || x > reference.cols - 41 || y > reference.rows - 41) continue;
      sum += std::abs(static_cast<double>(a.at<uchar>(v, u)) - b.at<uchar>(v, u));
      ++count;
    }
  }
  EXPECT_GT(count, image.rows * image.cols / 4);
  return sum / std::max(count, 1);
}

// A lens that distorts: each pixel shows what the ideal pinhole camera shows at its undistorted
// position; camera_info's plumb_bob model maps one onto the other.
TEST(WorldRenderer, ADistortingLensShowsTheUndistortedPinholeImage) {
  const PlanarWorld world = oneWall();
  CameraCalibration calibration = test_support::syntheticCalibration();
  calibration.distortion_model = "plumb_bob";
  calibration.distortion = {-0.25, 0.08, 0.001, -0.0005, 0.0};
  const PinholeCamera lens(calibration);
  const WorldRenderer distorted(lens, RenderOptions());
  const WorldRenderer ideal(simCamera(), RenderOptions());
  cv::RNG rng(1);
  const Pose2D pose(0.3, 0.2, 0.1);
  const cv::Mat image = distorted.render(world, pose, 1.0, rng);
  const cv::Mat pinhole = ideal.render(world, pose, 1.0, rng);
  const double mapped = meanDifferenceAfterMapping(image, pinhole, [&](int u, int v) { return lens.undistortPixel(cv::Point2d(u, v)); });
  const double unmapped = meanDifferenceAfterMapping(image, pinhole, [](int u, int v) { return cv::Point2d(u, v); });
  EXPECT_LT(mapped, 2.0) << "mean difference [grey levels] after undoing the lens";
  EXPECT_GT(unmapped, 4.0 * mapped) << "the lens must visibly move the image";
}

// A camera one pixel wide or high through a lens, band-limited: its edge pixels have no neighbour
// to take their points' rays from, and still render (a column of the wall, its top and foot).
TEST(WorldRenderer, ASinglePixelColumnThroughALensRenders) {
  const PlanarWorld world = oneWall();
  for (const auto& [width, height] : {std::pair<int, int>{1, 480}, std::pair<int, int>{640, 1}, std::pair<int, int>{1, 1}}) {
    CameraCalibration calibration = test_support::syntheticCalibration();
    calibration.width = width;
    calibration.height = height;
    calibration.cx = (width - 1) / 2.0;
    calibration.cy = (height - 1) / 2.0;
    calibration.distortion_model = "plumb_bob";
    calibration.distortion = {-0.25, 0.08, 0.0, 0.0, 0.0};
    RenderOptions options;
    options.camera_height = 0.6;
    options.blur_sigma = 0.5;
    const WorldRenderer renderer(PinholeCamera(calibration), options);
    cv::RNG rng(1);
    const cv::Mat image = renderer.render(world, Pose2D(0.0, 0.0, 0.0), 1.0, rng);
    EXPECT_EQ(image.cols, width);
    EXPECT_EQ(image.rows, height);
  }
}

// A mount that is not level is a rotation of the level camera: the tilted image is the level one
// through K T K⁻¹. REP-103 roll ρ then pitch φ of base_link give T = Rz(−ρ) Rx(φ) in optical axes,
// to first order the package's tilt Rx(φ) Rz(ψ) of docs/math.md §1.10 with ψ = −ρ.
TEST(WorldRenderer, ATiltedMountIsTheLevelImageThroughTheTiltRotation) {
  const PlanarWorld world = oneWall();
  RenderOptions tilted_options;
  tilted_options.camera_height = 1.2;
  tilted_options.camera_pitch = 0.04;
  tilted_options.camera_roll = -0.03;
  RenderOptions level_options;
  level_options.camera_height = 1.2;
  const WorldRenderer tilted(simCamera(), tilted_options);
  const WorldRenderer level(simCamera(), level_options);
  cv::RNG rng(1);
  const Pose2D pose(0.2, -0.1, 0.05);
  const cv::Mat image = tilted.render(world, pose, 1.0, rng);
  const cv::Mat reference = level.render(world, pose, 1.0, rng);
  const Eigen::Matrix3d T = (Eigen::AngleAxisd(0.03, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(0.04, Eigen::Vector3d::UnitX())).toRotationMatrix();  // tilted = T · level
  EXPECT_LT((T - cameraTilt(0.04, 0.03).T).norm(), 2e-3);
  const Eigen::Matrix3d K = simCamera().K();
  const Eigen::Matrix3d tilted_to_level = K * T.transpose() * K.inverse();
  const double mapped = meanDifferenceAfterMapping(image, reference, [&](int u, int v) {
    const Eigen::Vector3d p = tilted_to_level * Eigen::Vector3d(u, v, 1.0);
    return cv::Point2d(p.x() / p.z(), p.y() / p.z());
  });
  const double unmapped = meanDifferenceAfterMapping(image, reference, [](int u, int v) { return cv::Point2d(u, v); });
  EXPECT_LT(mapped, 2.0);
  EXPECT_GT(unmapped, 4.0 * mapped);
  // Looking down: the optical axis points below the horizon, the level mount's is horizontal.
  const Eigen::Matrix3d optical_to_base = tilted.opticalToBase();
  EXPECT_NEAR(optical_to_base(2, 2), -std::sin(0.04), 1e-12);
  EXPECT_NEAR(level.opticalToBase().col(2).z(), 0.0, 1e-12);
  EXPECT_NEAR((optical_to_base.transpose() * optical_to_base - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-12);
}

// Lamps along the walls: each column's brightness is 1 + c cos(2π s / spacing) times the unlit
// one, s the distance along the wall where the column's ray meets it.
TEST(WorldRenderer, LampsModulateTheBrightnessAlongTheWall) {
  PlanarWorld world;
  world.source = "test";
  world.walls.push_back(makeWall({4.0, 3.0}, {4.0, -3.0}, cv::Mat(10, 10, CV_8UC3, cv::Scalar(100, 100, 100)), 3.0));
  RenderOptions lit;
  lit.lamp_contrast = 0.4;
  lit.lamp_spacing = 2.0;
  const WorldRenderer lamps(simCamera(), lit), plain(simCamera(), RenderOptions());
  cv::RNG rng(1);
  const cv::Mat image = lamps.render(world, Pose2D(), 1.0, rng);
  const cv::Mat reference = plain.render(world, Pose2D(), 1.0, rng);
  for (const int u : {50, 200, 319, 450, 600}) {
    const double xn = (u - simCamera().cx()) / simCamera().fx();
    const double along = 3.0 + 4.0 * xn;  // the wall starts at y = 3 and runs towards −y; a ray meets y = −4 x_n
    const double expected = 100.0 * (1.0 + 0.4 * std::cos(2.0 * M_PI * along / 2.0));
    EXPECT_NEAR(image.at<cv::Vec3b>(240, u)[0], expected, 1.0) << "column " << u;
    EXPECT_EQ(reference.at<cv::Vec3b>(240, u)[0], 100);
  }
}

// Turning during the exposure smears the image along its rows, not along its columns.
namespace {
// One 6 x 3 m wall 4 m ahead of the origin with a uniform random texture of 600 x 300 texels,
// smoothed by a Gaussian of `smoothing` texels (0: none).
PlanarWorld randomTextureWall(int seed, double smoothing) {
  PlanarWorld world;
  world.source = "test";
  cv::Mat texture(300, 600, CV_8UC3);
  cv::RNG texture_rng(static_cast<uint64_t>(seed));
  texture_rng.fill(texture, cv::RNG::UNIFORM, 0, 256);
  if (smoothing > 0.0) cv::GaussianBlur(texture, texture, cv::Size(), smoothing);
  Wall wall = makeWall({4.0, 3.0}, {4.0, -3.0}, texture, 3.0);
  wall.texture_width = 6.0;
  wall.texture_height = 3.0;
  world.walls.push_back(wall);
  return world;
}
}  // namespace

TEST(WorldRenderer, MotionBlurFollowsTheRotation) {
  const PlanarWorld world = randomTextureWall(3, 0.0);  // about a texel per pixel at 4 m
  RenderOptions options;
  options.exposure_time = 0.02;
  const WorldRenderer renderer(simCamera(), options);
  cv::RNG rng(1);
  const cv::Mat still = renderer.render(world, Pose2D(), 1.0, rng, 0.0);
  const cv::Mat turning = renderer.render(world, Pose2D(), 1.0, rng, 1.0);  // 1 rad/s: 10 px in 20 ms
  auto gradient = [](const cv::Mat& image, int dx, int dy) {
    cv::Mat grey, g;
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
    cv::Sobel(grey, g, CV_32F, dx, dy);
    return cv::mean(cv::abs(g))[0];
  };
  const double across_still = gradient(still, 1, 0), along_still = gradient(still, 0, 1);
  const double across_turning = gradient(turning, 1, 0), along_turning = gradient(turning, 0, 1);
  std::cout << "mean |gradient| along rows / columns: still " << across_still << " / " << along_still
            << ", turning " << across_turning << " / " << along_turning << "\n";
  EXPECT_LT(across_turning / along_turning, 0.5 * across_still / along_still);
}

// The blur is centred on the pose of the image's stamp: it smears the image but does not move it
// (an even box kernel anchored off centre moved it by half a pixel, a bias in every heading fix
// taken while turning).
TEST(WorldRenderer, MotionBlurDoesNotShiftTheImage) {
  const PlanarWorld world = randomTextureWall(5, 2.0);
  RenderOptions options;
  options.exposure_time = 0.008;
  const WorldRenderer renderer(simCamera(), options);
  cv::RNG rng(1);
  auto grey = [](const cv::Mat& image) {
    cv::Mat g, f;
    cv::cvtColor(image, g, cv::COLOR_BGR2GRAY);
    g.convertTo(f, CV_64F);
    return f;
  };
  const cv::Mat still = grey(renderer.render(world, Pose2D(), 1.0, rng, 0.0));
  for (const double yaw_rate : {0.3, -0.45, 1.0, 2.5}) {  // blur of 1.2, 1.8, 4 and 10 px at f = 500 px
    const cv::Mat turning = grey(renderer.render(world, Pose2D(), 1.0, rng, yaw_rate));
    const cv::Point2d shift = cv::phaseCorrelate(still, turning);
    EXPECT_LT(std::abs(shift.x), 0.05) << "yaw rate " << yaw_rate << " rad/s";
    EXPECT_LT(std::abs(shift.y), 0.05) << "yaw rate " << yaw_rate << " rad/s";
  }
}

TEST(WorldRenderer, RefusesImpossibleCameraOptions) {
  for (const auto& set : std::vector<std::function<void(RenderOptions&)>>{
           [](RenderOptions& o) { o.camera_pitch = std::nan(""); }, [](RenderOptions& o) { o.camera_roll = 0.5; },
           [](RenderOptions& o) { o.exposure_time = -0.01; }, [](RenderOptions& o) { o.lamp_contrast = 1.0; },
           [](RenderOptions& o) { o.lamp_spacing = 0.0; }}) {
    RenderOptions options;
    set(options);
    EXPECT_THROW(WorldRenderer(simCamera(), options), std::invalid_argument);
  }
}

TEST(WorldRenderer, ScanOfASquareRoom) {
  PlanarWorld world;
  world.source = "test";
  const cv::Mat t(4, 4, CV_8UC3, cv::Scalar(128, 128, 128));
  world.walls = {makeWall({-2, -2}, {2, -2}, t), makeWall({2, -2}, {2, 2}, t), makeWall({2, 2}, {-2, 2}, t),
                 makeWall({-2, 2}, {-2, -2}, t)};
  const auto ranges = castScan(world, Pose2D(1.0, 0.0, 0.0), -M_PI / 2, M_PI / 2, 3, 10.0);
  ASSERT_EQ(ranges.size(), 3u);
  EXPECT_NEAR(ranges[0], 2.0, 1e-6);  // right: y = -2
  EXPECT_NEAR(ranges[1], 1.0, 1e-6);  // ahead: x = 2
  EXPECT_NEAR(ranges[2], 2.0, 1e-6);
  const auto short_range = castScan(world, Pose2D(1.0, 0.0, 0.0), 0.0, 0.0, 1, 0.5);
  EXPECT_TRUE(std::isinf(short_range[0]));
}

TEST(PlanarWorld, LoaderNamesTheBadField) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "htr_world_test";
  std::filesystem::create_directories(dir);
  cv::imwrite((dir / "t.png").string(), colourTexture(3));
  auto write = [&](const std::string& walls) {
    std::ofstream((dir / "w.yaml").string()) << "format_version: 1\nwalls:\n" << walls;
    return loadPlanarWorld((dir / "w.yaml").string());
  };
  const std::string good = "  - {name: a, start: [0, 0], end: [2, 0], height: 2, texture: t.png, texture_size: [1, 1]}\n";
  const auto ok = write(good);
  ASSERT_TRUE(ok.isOk()) << ok.status().toString();
  EXPECT_EQ(ok->walls.size(), 1u);
  EXPECT_EQ(ok->walls[0].texture.type(), CV_8UC3);
  auto expectError = [&](const std::string& walls, const std::string& needle) {
    const auto world = write(walls);
    ASSERT_FALSE(world.isOk()) << walls;
    EXPECT_NE(world.status().message().find(needle), std::string::npos) << world.status().message();
  };
  expectError("  - {start: [0, 0], end: [2, 0], height: 2, texture: missing.png, texture_size: [1, 1]}\n",
              "walls[0].texture");
  expectError("  - {start: [1, 1], end: [1, 1], height: 2, texture: t.png, texture_size: [1, 1]}\n",
              "zero-length");
  expectError("  - {start: [0, .nan], end: [2, 0], height: 2, texture: t.png, texture_size: [1, 1]}\n",
              "walls[0].start[1]");
  expectError("  - {start: [0, 0], end: [2, 0], height: -1, texture: t.png, texture_size: [1, 1]}\n",
              "height");
  expectError("  - {start: [0, 0], end: [2, 0], height: 2, texture: t.png}\n", "texture_size");
  EXPECT_FALSE(loadPlanarWorld((dir / "absent.yaml").string()).isOk());
  std::ofstream((dir / "v.yaml").string()) << "format_version: 7\nwalls: []\n";
  EXPECT_NE(loadPlanarWorld((dir / "v.yaml").string()).status().message().find("format_version"), std::string::npos);
  std::filesystem::remove_all(dir);
}

// Covered-camera boxes: loaded, looked up by the base's position, refused when inverted or NaN.
TEST(PlanarWorld, CameraCoveredRegions) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "htr_world_covered_test";
  std::filesystem::create_directories(dir);
  cv::imwrite((dir / "t.png").string(), colourTexture(3));
  auto write = [&](const std::string& covered) {
    std::ofstream((dir / "w.yaml").string())
        << "format_version: 1\ncamera_covered:\n" << covered
        << "walls:\n  - {start: [0, 0], end: [2, 0], height: 2, texture: t.png, texture_size: [1, 1]}\n";
    return loadPlanarWorld((dir / "w.yaml").string());
  };
  const auto world = write("  - {name: hand, min: [1, 0.5], max: [3, 1.5]}\n");
  ASSERT_TRUE(world.isOk()) << world.status().toString();
  ASSERT_EQ(world->camera_covered.size(), 1u);
  EXPECT_EQ(world->camera_covered[0].name, "hand");
  EXPECT_TRUE(world->cameraCoveredAt(Eigen::Vector2d(2.0, 1.0)));
  EXPECT_TRUE(world->cameraCoveredAt(Eigen::Vector2d(1.0, 0.5)));
  EXPECT_FALSE(world->cameraCoveredAt(Eigen::Vector2d(0.9, 1.0)));
  EXPECT_FALSE(world->cameraCoveredAt(Eigen::Vector2d(2.0, 1.6)));
  const auto inverted = write("  - {name: hand, min: [3, 0.5], max: [1, 1.5]}\n");
  ASSERT_FALSE(inverted.isOk());
  EXPECT_NE(inverted.status().message().find("camera_covered[0] (hand): min must be below max"), std::string::npos)
      << inverted.status().message();
  const auto nan = write("  - {min: [.nan, 0.5], max: [1, 1.5]}\n");
  ASSERT_FALSE(nan.isOk());
  EXPECT_NE(nan.status().message().find("camera_covered[0].min[0]"), std::string::npos) << nan.status().message();
  std::filesystem::remove_all(dir);
}

// Appearance change between runs: a wall's texture variants, chosen per run; variant 0 is the
// world as taught, a wall without the variant keeps its texture, and a variant no wall has, a
// negative one or an unreadable variant image are refused naming them.
TEST(PlanarWorld, AppearanceVariantsReplaceTheirWallsTextures) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "htr_world_variant_test";
  std::filesystem::create_directories(dir);
  cv::imwrite((dir / "t.png").string(), colourTexture(3));
  cv::imwrite((dir / "poster.png").string(), colourTexture(4));
  auto write = [&](const std::string& variants) {
    std::ofstream((dir / "w.yaml").string())
        << "format_version: 1\nwalls:\n"
        << "  - {name: a, start: [0, 0], end: [2, 0], height: 2, texture: t.png, texture_size: [1, 1]" << variants << "}\n"
        << "  - {name: b, start: [2, 0], end: [2, 2], height: 2, texture: t.png, texture_size: [1, 1]}\n";
    return loadPlanarWorld((dir / "w.yaml").string());
  };
  const auto world = write(", variants: [poster.png]");
  ASSERT_TRUE(world.isOk()) << world.status().toString();
  ASSERT_EQ(world->walls[0].variants.size(), 1u);
  const auto taught = world->withAppearance(0);
  ASSERT_TRUE(taught.isOk());
  EXPECT_EQ(cv::norm(taught->walls[0].texture, world->walls[0].texture, cv::NORM_INF), 0.0);
  const auto changed = world->withAppearance(1);
  ASSERT_TRUE(changed.isOk()) << changed.status().toString();
  EXPECT_GT(cv::norm(changed->walls[0].texture, world->walls[0].texture, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(changed->walls[0].texture, world->walls[0].variants[0], cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(changed->walls[1].texture, world->walls[1].texture, cv::NORM_INF), 0.0);  // no variant
  // The renderer sees the change.
  const WorldRenderer renderer(simCamera(), RenderOptions());
  cv::RNG rng(1);
  const Pose2D facing_a(1.0, 1.5, -M_PI / 2);
  const cv::Mat before = renderer.render(*world, facing_a, 1.0, rng);
  const cv::Mat after = renderer.render(*changed, facing_a, 1.0, rng);
  EXPECT_GT(cv::norm(before, after, cv::NORM_L1) / static_cast<double>(before.total()), 10.0);
  auto expectRefused = [](const Expected<PlanarWorld>& w, const std::string& needle) {
    ASSERT_FALSE(w.isOk());
    EXPECT_NE(w.status().message().find(needle), std::string::npos) << w.status().message();
  };
  expectRefused(world->withAppearance(2), "no wall has appearance variant 2");
  expectRefused(world->withAppearance(-1), "appearance variant -1");
  expectRefused(write(", variants: [missing.png]"), "walls[0].variants[0]");
  expectRefused(write(", variants: poster.png"), "walls[0].variants' must be a list");
  std::filesystem::remove_all(dir);
}

// Clutter and people from the world file: a box's four sides join the walls only with
// withClutter(); a person walks the path at their speed, stands at its ends, and joins the walls
// where they stand at that time; a path of zero length, a NaN or a bad speed are refused naming
// the person and the field.
TEST(PlanarWorld, ClutterAndPeopleFromTheWorldFile) {
  const std::filesystem::path dir = std::filesystem::temp_directory_path() / "htr_world_people_test";
  std::filesystem::create_directories(dir);
  cv::imwrite((dir / "t.png").string(), colourTexture(3));
  auto write = [&](const std::string& extra) {
    std::ofstream((dir / "w.yaml").string())
        << "format_version: 1\nwalls:\n  - {start: [0, 0], end: [6, 0], height: 2, texture: t.png, texture_size: [1, 1]}\n"
        << extra;
    return loadPlanarWorld((dir / "w.yaml").string());
  };
  const auto world = write(
      "clutter:\n  - {name: crate, centre: [2, 1], size: [0.8, 0.4], yaw: 0.5, height: 0.4, texture: t.png, "
      "texture_size: [0.8, 0.4]}\n"
      "people:\n  - {name: visitor, path: [[1, 1], [3, 1], [3, 2]], speed: 1.0, pause: [2.0, 5.0], start_time: 10, "
      "size: [0.3, 0.5], height: 1.7, texture: t.png, texture_size: [0.5, 1.7]}\n");
  ASSERT_TRUE(world.isOk()) << world.status().toString();
  ASSERT_EQ(world->clutter.size(), 1u);
  ASSERT_EQ(world->people.size(), 1u);
  EXPECT_EQ(world->walls.size(), 1u);  // neither is a wall until asked for
  const PlanarWorld cluttered = world->withClutter();
  ASSERT_EQ(cluttered.walls.size(), 5u);
  EXPECT_TRUE(cluttered.walls[1].see_over);
  EXPECT_FALSE(cluttered.walls[0].see_over);
  EXPECT_NEAR(cluttered.walls[1].length() + cluttered.walls[2].length(), 1.2, 1e-12);
  EXPECT_NEAR(cluttered.walls[1].height, 0.4, 1e-12);

  const Person& visitor = world->people[0];
  EXPECT_NEAR(visitor.pathLength(), 3.0, 1e-12);
  auto expectAt = [&](double time, double x, double y, double yaw) {
    const Pose2D p = visitor.poseAt(time);
    EXPECT_NEAR(p.x, x, 1e-9) << "t = " << time;
    EXPECT_NEAR(p.y, y, 1e-9) << "t = " << time;
    EXPECT_NEAR(std::abs(wrapToPi(p.yaw - yaw)), 0.0, 1e-9) << "t = " << time;
  };
  expectAt(0.0, 1.0, 1.0, 0.0);            // waiting for start_time at the first point
  expectAt(11.5, 2.5, 1.0, 0.0);           // on the first leg
  expectAt(12.5, 3.0, 1.5, M_PI / 2);      // on the second leg
  expectAt(15.0, 3.0, 2.0, M_PI / 2);      // standing at the end (3 s walked, pause 5 s)
  expectAt(18.5, 3.0, 1.5, -M_PI / 2);     // walking back
  expectAt(20.5, 1.5, 1.0, M_PI);          // back on the first leg
  expectAt(22.0, 1.0, 1.0, M_PI);          // standing at the start (pause 2 s)
  expectAt(13.0 + 11.5, 2.5, 1.0, 0.0);    // the next round: a cycle of 3 + 5 + 3 + 2 s
  EXPECT_NEAR(distanceToBox(Eigen::Vector2d(3.0, 0.5), visitor.poseAt(15.0), 0.3, 0.5), 1.5 - 0.15, 1e-12);
  EXPECT_NEAR(distanceToBox(Eigen::Vector2d(3.0, 2.0), visitor.poseAt(15.0), 0.3, 0.5), 0.0, 1e-12);  // inside
  EXPECT_NEAR(distanceToBox(Eigen::Vector2d(4.25, 3.15), visitor.poseAt(15.0), 0.3, 0.5), std::hypot(1.0, 1.0), 1e-12);
  const PlanarWorld with_people = world->withPeople({visitor.poseAt(15.0)});
  ASSERT_EQ(with_people.walls.size(), 5u);
  // The laser sees the person standing at (3, 2): from (3, 0.5) looking north, 1.5 m minus half a depth.
  const auto ranges = castScan(with_people, Pose2D(3.0, 0.5, M_PI / 2), 0.0, 0.0, 1, 8.0);
  EXPECT_NEAR(ranges[0], 1.5 - 0.15, 1e-6);

  auto expectRefused = [&](const std::string& extra, const std::string& needle) {
    const auto bad = write(extra);
    ASSERT_FALSE(bad.isOk()) << extra;
    EXPECT_NE(bad.status().message().find(needle), std::string::npos) << bad.status().message();
  };
  const std::string body = ", height: 1.7, texture: t.png, texture_size: [0.5, 1.7]}\n";
  expectRefused("people:\n  - {name: statue, path: [[1, 1], [1, 1]]" + body, "people[0] (statue): path of zero length");
  expectRefused("people:\n  - {name: ghost, path: [[1, 1]]" + body, "people[0] (ghost): path needs at least two points");
  expectRefused("people:\n  - {path: [[1, .nan], [2, 1]]" + body, "people[0].path[0][1]");
  expectRefused("people:\n  - {name: runner, path: [[1, 1], [2, 1]], speed: 9" + body, "people[0] (runner): speed");
  expectRefused("people:\n  - {name: p, path: [[1, 1], [2, 1]], pause: -1" + body, "pause");
  expectRefused("clutter:\n  - {name: flat, centre: [1, 1], size: [0, 1], height: 1, texture: t.png, texture_size: [1, 1]}\n",
                "clutter[0] (flat): size");
  expectRefused("clutter:\n  - {centre: [1, 1], size: [1, 1], height: 1, texture: none.png, texture_size: [1, 1]}\n",
                "clutter[0].texture");
  std::filesystem::remove_all(dir);
}

// People let a robot pass: a person walking towards a robot standing on their path stops at the
// yield distance and walks on once it has gone; one who would pass beside it (outside the yield
// width) never waits, nor does someone crossing in front of a robot that waits for them; someone
// about to cross the path of a robot driving towards them waits at its edge until it has gone by.
TEST(PlanarWorld, PeopleStandRatherThanWalkIntoTheRobot) {
  Person walker;
  walker.name = "walker";
  walker.path = {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(6.0, 0.0)};
  walker.speed = 1.0;
  const double dt = 0.01;
  Crowd crowd({walker}, CrowdOptions{1.0, 0.55});
  int i = 0;
  for (; i < 500; ++i) crowd.advance(i * dt, dt, Pose2D(3.0, 0.2, 0.0));
  EXPECT_NEAR(crowd.poses()[0].x, 2.0, 0.011);  // stood 1 m before the robot
  EXPECT_NEAR(crowd.yieldedSeconds(0), 3.0, 0.02);
  for (; i < 700; ++i) crowd.advance(i * dt, dt, Pose2D(3.0, 5.0, 0.0));  // the robot went
  EXPECT_NEAR(crowd.poses()[0].x, 4.0, 0.011);
  // Passing 0.7 m beside the robot: walks on.
  Crowd passer({walker}, CrowdOptions{1.0, 0.55});
  for (int k = 0; k < 500; ++k) passer.advance(k * dt, dt, Pose2D(3.0, 0.7, 0.0));
  EXPECT_NEAR(passer.yieldedSeconds(0), 0.0, 1e-12);
  EXPECT_NEAR(passer.poses()[0].x, 5.0, 0.011);
  // Crossing in front of a robot that waits for them (they are in its way, 0.63 m ahead of it and
  // 0.6 m beside their own way): they walk on out of its way instead of both waiting for ever.
  Person crossing = walker;
  crossing.path = {Eigen::Vector2d(3.0, 0.1), Eigen::Vector2d(3.0, -2.0)};
  Crowd crosser({crossing}, CrowdOptions{1.0, 0.55});
  for (int k = 0; k < 200; ++k) crosser.advance(k * dt, dt, Pose2D(2.4, -0.1, 0.0));
  EXPECT_NEAR(crosser.poses()[0].y, 0.1 - 2.0, 1e-6);
  EXPECT_NEAR(crosser.yieldedSeconds(0), 0.0, 1e-12);
  // Crossing the path of a robot driving towards them (0.5 m/s along y = 0): they wait at its
  // edge (yield_width from its line) until it has gone by, then cross; in front of a robot that
  // stands they just cross.
  Person across = walker;
  across.path = {Eigen::Vector2d(3.0, -3.5), Eigen::Vector2d(3.0, 2.0)};
  Crowd waiting({across}, CrowdOptions{1.0, 0.55});
  for (i = 0; i < 500; ++i) waiting.advance(i * dt, dt, Pose2D(0.5 * i * dt, 0.0, 0.0));
  EXPECT_NEAR(waiting.poses()[0].y, -0.55, 0.011);  // the robot at x = 2.5: 0.5 m before them
  for (; i < 800; ++i) waiting.advance(i * dt, dt, Pose2D(0.5 * i * dt, 0.0, 0.0));
  EXPECT_NEAR(waiting.yieldedSeconds(0), 3.55 / 0.5 - 2.95, 0.03);  // from 2.95 s to the robot past
  EXPECT_NEAR(waiting.poses()[0].y, -0.55 + (8.0 - 3.55 / 0.5), 0.03);
  Crowd not_waiting({across}, CrowdOptions{1.0, 0.55});
  for (i = 0; i < 500; ++i) not_waiting.advance(i * dt, dt, Pose2D(2.0, 0.0, 0.0));
  EXPECT_NEAR(not_waiting.yieldedSeconds(0), 0.0, 1e-12);
  EXPECT_NEAR(not_waiting.poses()[0].y, -3.5 + 5.0, 0.011);
  // A robot standing in their way for good: with a patience of 2 s they stand 2 s, then turn back
  // (walking back the way they came, away from the robot) instead of standing there for ever.
  Crowd patient({walker}, CrowdOptions{1.0, 0.55, 2.0});
  for (i = 0; i < 500; ++i) patient.advance(i * dt, dt, Pose2D(3.0, 0.2, 0.0));
  EXPECT_NEAR(patient.yieldedSeconds(0), 2.0, 0.02);
  EXPECT_NEAR(patient.poses()[0].x, 2.0 - 1.0, 0.02);  // 1 s walking back from x = 2
  EXPECT_NEAR(std::abs(patient.poses()[0].yaw), M_PI, 1e-9);
  // Turned back at every point of the way, both legs: the same place, the other direction.
  Person paused = walker;
  paused.pause_at_start = 1.0;
  paused.pause_at_end = 2.0;
  paused.start_time = 0.5;
  for (const double time : {0.7, 3.0, 6.4, 9.0, 12.5, 20.0}) {
    const Pose2D before = paused.poseAt(time), after = paused.poseAt(paused.turnedBackAt(time));
    EXPECT_NEAR(after.x, before.x, 1e-9) << time;
    const bool pausing = paused.turnedBackAt(time) == time;
    if (!pausing) {
      EXPECT_NEAR(std::abs(wrapToPi(after.yaw - before.yaw)), M_PI, 1e-9) << time;
    }
  }
}

// A box lower than the camera is a partial occluder: the camera sees over it to the wall behind,
// and the box hides the wall's lower part; a box taller than the camera hides the wall's middle.
TEST(WorldRenderer, TheCameraSeesOverALowBox) {
  PlanarWorld world;
  world.source = "test";
  world.walls.push_back(makeWall({6.0, 5.0}, {6.0, -5.0}, cv::Mat(10, 10, CV_8UC3, cv::Scalar(255, 0, 0))));
  BoxSurface low;
  low.height = 0.5;
  low.texture = cv::Mat(10, 10, CV_8UC3, cv::Scalar(0, 0, 255));
  ClutterBox crate;
  crate.centre = Eigen::Vector2d(2.0, 0.0);
  crate.length = 0.4;
  crate.width = 1.0;
  crate.surface = low;
  world.clutter.push_back(crate);
  RenderOptions options;
  options.camera_height = 1.0;
  const WorldRenderer renderer(simCamera(), options);
  cv::RNG rng(1);
  const cv::Mat image = renderer.render(world.withClutter(), Pose2D(0.0, 0.0, 0.0), 1.0, rng);
  // The crate's near side at 1.8 m spans heights 0..0.5 m: rows 240 + 500 * (1 - z) / 1.8, i.e.
  // 379..518 (clipped at 479), and columns within ±0.5 m: ±139 px.
  EXPECT_EQ(image.at<cv::Vec3b>(420, 320), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(image.at<cv::Vec3b>(240, 320), cv::Vec3b(255, 0, 0));  // over it: the far wall
  EXPECT_EQ(image.at<cv::Vec3b>(300, 320), cv::Vec3b(255, 0, 0));  // the wall at 6 m, down to row 323
  EXPECT_EQ(image.at<cv::Vec3b>(420, 320 + 200), world.floor_colour);  // beside the crate: floor
  // Just above the near side's top edge the ray comes down onto the crate's top (flat grey).
  EXPECT_EQ(image.at<cv::Vec3b>(375, 320), cv::Vec3b(128, 128, 128));
  // A tall box hides the wall's middle.
  world.clutter[0].surface.height = 2.5;
  const cv::Mat tall = renderer.render(world.withClutter(), Pose2D(0.0, 0.0, 0.0), 1.0, rng);
  EXPECT_EQ(tall.at<cv::Vec3b>(240, 320), cv::Vec3b(0, 0, 255));
  EXPECT_EQ(tall.at<cv::Vec3b>(240, 320 + 200), cv::Vec3b(255, 0, 0));
}

TEST(DifferentialDrive, ExactArcsAndOdometryDrift) {
  // A full circle returns to the start.
  Pose2D pose(1.0, 2.0, 0.3);
  for (int i = 0; i < 100; ++i) pose = integrateArc(pose, 0.5, 2.0 * M_PI / 10.0, 0.1);
  EXPECT_NEAR(pose.x, 1.0, 1e-9);
  EXPECT_NEAR(pose.y, 2.0, 1e-9);
  // 10 m straight with a heading bias of 0.01 rad/m and a 2% scale error.
  OdometryErrorModel errors;
  errors.heading_bias_per_metre = 0.01;
  errors.scale_error = 0.02;
  DifferentialDriveSim robot(Pose2D(), errors, DriveLimits());
  for (int i = 0; i < 200; ++i) robot.step(0.5, 0.0, 0.1);
  EXPECT_NEAR(robot.truth().x, 10.0, 1e-9);
  EXPECT_NEAR(robot.truth().y, 0.0, 1e-9);
  EXPECT_NEAR(robot.odometry().yaw, 0.1, 1e-9);
  EXPECT_NEAR(robot.distanceTravelled(), 10.0, 1e-9);
  // The odometry believes 10.2 m along an arc turning 0.1 rad.
  EXPECT_NEAR(std::hypot(robot.odometry().x, robot.odometry().y), 10.2 * std::sin(0.05) / 0.05, 1e-3);
  // Limits and NaN commands.
  const auto applied = robot.step(5.0, std::nan(""), 0.1);
  EXPECT_EQ(applied.first, DriveLimits().max_linear_velocity);
  EXPECT_EQ(applied.second, 0.0);
  OdometryErrorModel bad;
  bad.distance_noise = -1.0;
  EXPECT_THROW(DifferentialDriveSim(Pose2D(), bad, DriveLimits()), std::invalid_argument);
}

// driveWaypoints: frames every frame_period of simulated time, the drive ends at the loop's start,
// a failing frame stops it with its status, and a drive too long for max_duration is an error.
TEST(WaypointDriver, DriveWaypointsCallsFramesAtTheirPeriod) {
  const std::vector<Eigen::Vector2d> loop = {{2, 0}, {2, 1}, {0, 1}, {0, 0}};
  WaypointDriver driver(loop, WaypointDriverOptions());
  DifferentialDriveSim robot{Pose2D(), OdometryErrorModel(), DriveLimits()};
  std::vector<double> times;
  const Status done = driveWaypoints(driver, robot, 1.0 / 300.0, 1.0 / 30.0, 600.0,
                                     [&](const DifferentialDriveSim&, double t) {
                                       times.push_back(t);
                                       return Status::ok();
                                     });
  ASSERT_TRUE(done.isOk()) << done.toString();
  EXPECT_TRUE(driver.finished());
  EXPECT_LT(std::hypot(robot.truth().x, robot.truth().y), 0.05);
  ASSERT_GT(times.size(), 100U);
  for (std::size_t k = 0; k < times.size(); ++k) EXPECT_NEAR(times[k], k / 30.0, 0.5 / 300.0 + 1e-12);

  WaypointDriver again(loop, WaypointDriverOptions());
  DifferentialDriveSim robot2{Pose2D(), OdometryErrorModel(), DriveLimits()};
  int calls = 0;
  const Status failed = driveWaypoints(again, robot2, 0.01, 0.1, 600.0, [&](const DifferentialDriveSim&, double) {
    return ++calls == 3 ? Status(StatusCode::kInvalidInput, "frame 3 refused") : Status::ok();
  });
  EXPECT_EQ(failed.message(), "frame 3 refused");
  EXPECT_EQ(calls, 3);

  WaypointDriver slow(loop, WaypointDriverOptions());
  DifferentialDriveSim robot3{Pose2D(), OdometryErrorModel(), DriveLimits()};
  const auto none = [](const DifferentialDriveSim&, double) { return Status::ok(); };
  EXPECT_EQ(driveWaypoints(slow, robot3, 0.01, 0.1, 2.0, none).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(driveWaypoints(slow, robot3, 0.0, 0.1, 2.0, none).code(), StatusCode::kInvalidInput);
  EXPECT_EQ(driveWaypoints(slow, robot3, 0.01, std::nan(""), 2.0, none).code(), StatusCode::kInvalidInput);
}

// The scripted teach drive goes round a 4 x 3 m loop and stops at its start.
TEST(WaypointDriver, DrivesTheLoopAndStops) {
  const std::vector<Eigen::Vector2d> loop = {{4, 0}, {4, 3}, {0, 3}, {0, 0}};
  WaypointDriver driver(loop, WaypointDriverOptions());
  Pose2D pose(0.0, 0.0, 0.0);
  double max_off_path = 0.0;
  int steps = 0;
  for (; steps < 20000 && !driver.finished(); ++steps) {
    const VelocityCommand c = driver.update(pose);
    pose = integrateArc(pose, c.linear, c.angular, 0.02);
    // Distance to the loop's rectangle outline.
    const double dx = std::min(std::abs(pose.x), std::abs(pose.x - 4.0));
    const double dy = std::min(std::abs(pose.y), std::abs(pose.y - 3.0));
    max_off_path = std::max(max_off_path, std::min(dx, dy));
  }
  EXPECT_TRUE(driver.finished());
  EXPECT_LT(std::hypot(pose.x, pose.y), 0.05);
  EXPECT_LT(max_off_path, 0.05);
  const VelocityCommand stopped = driver.update(pose);
  EXPECT_EQ(stopped.linear, 0.0);
  EXPECT_EQ(stopped.angular, 0.0);
  EXPECT_THROW(WaypointDriver({}, WaypointDriverOptions()), std::invalid_argument);

  // With turn_to_final_yaw it then turns in place to face as it started.
  WaypointDriverOptions turning;
  turning.turn_to_final_yaw = true;
  turning.final_yaw = 0.0;
  WaypointDriver closing(loop, turning);
  pose = Pose2D(0.0, 0.0, 0.0);
  for (steps = 0; steps < 20000 && !closing.finished(); ++steps) {
    const VelocityCommand c = closing.update(pose);
    pose = integrateArc(pose, c.linear, c.angular, 0.02);
  }
  EXPECT_TRUE(closing.finished());
  EXPECT_LT(std::hypot(pose.x, pose.y), 0.05);
  EXPECT_LT(std::abs(pose.yaw), turning.final_yaw_tolerance + 0.01);
  turning.final_yaw = NAN;
  EXPECT_THROW(WaypointDriver(loop, turning), std::invalid_argument);
}

TEST(PathDeviation, DistanceToThePolylineAndHeadingOfTheNearestKeyframe) {
  const std::vector<Pose2D> path = {Pose2D(0, 0, 0), Pose2D(2, 0, 0), Pose2D(2, 2, M_PI / 2)};
  const PathDeviation beside = deviationFromPath(path, Pose2D(1.0, 0.3, 0.1));
  EXPECT_NEAR(beside.distance, 0.3, 1e-12);
  EXPECT_NEAR(beside.heading_error, 0.1, 1e-12);
  const PathDeviation up = deviationFromPath(path, Pose2D(2.2, 1.8, M_PI / 2));
  EXPECT_NEAR(up.distance, 0.2, 1e-12);
  EXPECT_EQ(up.nearest_keyframe, 2);
  EXPECT_NEAR(up.heading_error, 0.0, 1e-12);
  const PathDeviation beyond = deviationFromPath(path, Pose2D(-1.0, 0.0, 0.0));
  EXPECT_NEAR(beyond.distance, 1.0, 1e-12);
  EXPECT_TRUE(std::isnan(deviationFromPath({}, Pose2D()).distance));
  EXPECT_TRUE(std::isnan(deviationFromPath(path, Pose2D(NAN, 0, 0)).distance));
}
