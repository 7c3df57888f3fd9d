#include "homography_teach_repeat/eval/synthetic_bearing_scene.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

Eigen::Matrix2d rotation(double theta) {
  Eigen::Matrix2d R;
  R << std::cos(theta), std::sin(theta), -std::sin(theta), std::cos(theta);
  return R;
}

// The noisy triplet of a landmark, or false when a view does not see it.
bool observe(const TrifocalMotion& motion, const LineCamera1d& camera, const Eigen::Vector2d& landmark,
             double noise_px, std::mt19937& rng, BearingTriplet* triplet) {
  std::normal_distribution<double> noise(0.0, 1.0);
  const Eigen::Vector2d points[3] = {landmark, rotation(motion.theta_second) * landmark + motion.t_second,
                                     rotation(motion.theta_third) * landmark + motion.t_third};
  Bearing* out[3] = {&triplet->first, &triplet->second, &triplet->third};
  for (int view = 0; view < 3; ++view) {
    double x = 0.0;
    if (!camera.project(points[view], &x)) return false;
    *out[view] = camera.bearing(x + noise_px * noise(rng));
  }
  return true;
}

}  // namespace

LineCamera1d LineCamera1d::withFieldOfView(double fov_rad, double width_px) {
  if (!(fov_rad > 0.0 && fov_rad < M_PI) || !(width_px > 0.0)) {
    throw std::invalid_argument("LineCamera1d: field of view must be in (0, pi) and width > 0");
  }
  LineCamera1d camera;
  camera.width_px = width_px;
  camera.principal_px = width_px / 2.0;
  camera.focal_px = (width_px / 2.0) / std::tan(fov_rad / 2.0);
  return camera;
}

bool LineCamera1d::project(const Eigen::Vector2d& camera_point, double* x_px) const {
  if (!(camera_point.y() > 1e-9)) return false;
  const double x = focal_px * camera_point.x() / camera_point.y() + principal_px;
  if (!(std::abs(x - principal_px) < width_px / 2.0)) return false;
  *x_px = x;
  return true;
}

TrifocalMotion motionFromCentres(const Eigen::Vector2d& centre_second, double theta_second,
                                 const Eigen::Vector2d& centre_third, double theta_third) {
  TrifocalMotion m;
  m.theta_second = theta_second;
  m.theta_third = theta_third;
  m.t_second = -rotation(theta_second) * centre_second;
  m.t_third = -rotation(theta_third) * centre_third;
  return m;
}

TrifocalMotion movementA() {
  // θ > 0 turns left (towards −X): the robot on the left (x = −2) turns right, towards the field.
  return motionFromCentres(Eigen::Vector2d(-2.0, 1.0), -0.15, Eigen::Vector2d(2.0, 1.0), 0.15);
}

TrifocalMotion movementB() {
  return motionFromCentres(Eigen::Vector2d(0.2, 1.5), 0.05, Eigen::Vector2d(0.5, 3.0), 0.1);
}

namespace {

// Up to `count` landmarks drawn by `draw` (depth along view 1's axis, then the column across its
// field) that all three views see.
template <typename DrawDepth>
BearingScene visibleScene(const TrifocalMotion& motion, const LineCamera1d& camera, int count,
                          const BearingSceneOptions& options, std::mt19937& rng, DrawDepth draw_depth) {
  std::uniform_real_distribution<double> column(-0.5, 0.5);
  BearingScene scene;
  for (int attempt = 0; attempt < options.max_attempts && static_cast<int>(scene.landmarks.size()) < count; ++attempt) {
    const double z = draw_depth();
    const Eigen::Vector2d landmark(column(rng) * camera.width_px / camera.focal_px * z, z);
    BearingTriplet triplet;
    if (!observe(motion, camera, landmark, options.noise_px, rng, &triplet)) continue;
    scene.landmarks.push_back(landmark);
    scene.triplets.push_back(triplet);
  }
  return scene;
}

}  // namespace

BearingScene randomBearingScene(const TrifocalMotion& motion, const LineCamera1d& camera, int count,
                                const BearingSceneOptions& options, std::mt19937& rng) {
  std::uniform_real_distribution<double> depth(options.depth_min, options.depth_max);
  return visibleScene(motion, camera, count, options, rng, [&] { return depth(rng); });
}

BearingScene planeBearingScene(const TrifocalMotion& motion, const LineCamera1d& camera, int count, double depth,
                               const BearingSceneOptions& options, std::mt19937& rng) {
  return visibleScene(motion, camera, count, options, rng, [depth] { return depth; });
}

std::vector<int> corruptTriplets(std::vector<BearingTriplet>& triplets, double fraction, const LineCamera1d& camera,
                                 std::mt19937& rng) {
  std::vector<int> order(triplets.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  const auto wrong = static_cast<std::size_t>(std::lround(fraction * static_cast<double>(triplets.size())));
  order.resize(std::min(wrong, order.size()));
  std::uniform_real_distribution<double> column(0.0, camera.width_px);
  for (const int n : order) {
    triplets[static_cast<std::size_t>(n)].second = camera.bearing(column(rng));
    triplets[static_cast<std::size_t>(n)].third = camera.bearing(column(rng));
  }
  std::sort(order.begin(), order.end());
  return order;
}

}  // namespace homography_teach_repeat
