#include "homography_teach_repeat/sim/world_renderer.h"

#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

// Bilinear sample of a BGR8 texture tiled in both directions. The integer cell is wrapped with
// integer arithmetic: fmod of a tiny negative coordinate plus the width rounds to the width itself,
// one past the last column (found by AddressSanitizer).
cv::Vec3f sampleTiled(const cv::Mat& texture, double u, double v) {
  const int w = texture.cols, h = texture.rows;
  const double fu = std::floor(u), fv = std::floor(v);
  const float a = static_cast<float>(u - fu), b = static_cast<float>(v - fv);
  const long iu = static_cast<long>(fu), iv = static_cast<long>(fv);
  const int u0 = static_cast<int>(((iu % w) + w) % w), v0 = static_cast<int>(((iv % h) + h) % h);
  const int u1 = (u0 + 1) % w, v1 = (v0 + 1) % h;
  const cv::Vec3b& p00 = texture.at<cv::Vec3b>(v0, u0);
  const cv::Vec3b& p01 = texture.at<cv::Vec3b>(v0, u1);
  const cv::Vec3b& p10 = texture.at<cv::Vec3b>(v1, u0);
  const cv::Vec3b& p11 = texture.at<cv::Vec3b>(v1, u1);
  cv::Vec3f out;
  for (int c = 0; c < 3; ++c) {
    out[c] = (1 - a) * (1 - b) * static_cast<float>(p00[c]) + a * (1 - b) * static_cast<float>(p01[c]) +
             (1 - a) * b * static_cast<float>(p10[c]) + a * b * static_cast<float>(p11[c]);
  }
  return out;
}

struct Surroundings {
  cv::Vec3f floor;
  cv::Vec3f ceiling;
  double camera_height;
  double lamp_contrast;
  double lamp_spacing;
};

// The colour a ray sees: `hit` is the first wall its horizontal part origin + t·direction meets (or
// nothing), `down` how far it drops per unit of t (a wall point's height is camera_height − down·t).
// Above a room wall is the ceiling; above an object standing in the room (Wall::see_over) the ray
// goes on to what is behind it, and where it meets such an object's side from inside, below its
// top, it came down onto the object's top (drawn flat grey).
cv::Vec3f colourAlong(const PlanarWorld& world, const Eigen::Vector2d& origin, const Eigen::Vector2d& direction,
                      std::optional<RayHit> hit, double down, const Surroundings& s) {
  while (hit) {
    const Wall& wall = world.walls[static_cast<std::size_t>(hit->wall)];
    const double z = s.camera_height - down * hit->range;  // height on the wall [m]
    if (z < 0.0) return s.floor;
    if (z > wall.height) {
      if (!wall.see_over) return s.ceiling;
      hit = castRay(world, origin, direction, hit->range);  // over it: what is behind
      continue;
    }
    if (wall.see_over) {
      // Sides are listed counter-clockwise (outward normal on the right of start -> end): a ray
      // meeting one from inside has come down onto the top.
      const Eigen::Vector2d edge = wall.end - wall.start;
      if (direction.dot(Eigen::Vector2d(edge.y(), -edge.x())) > 0.0) return cv::Vec3f(128.0f, 128.0f, 128.0f);
    }
    // Texture tiled from the wall's start point and up from the floor (image rows downward).
    const double tu = hit->along / wall.texture_width * wall.texture.cols;
    const double tv = (1.0 - std::fmod(z, wall.texture_height) / wall.texture_height) * wall.texture.rows;
    cv::Vec3f colour = sampleTiled(wall.texture, tu - 0.5, tv - 0.5);
    if (s.lamp_contrast > 0.0) {
      colour *= static_cast<float>(1.0 + s.lamp_contrast * std::cos(2.0 * M_PI * hit->along / s.lamp_spacing));
    }
    return colour;
  }
  return down > 0.0 ? s.floor : s.ceiling;
}

// The level camera's optical axes in base_link (columns: x right = −y, y down = −z, z forward = x).
Eigen::Matrix3d levelOpticalToBase() {
  Eigen::Matrix3d r;
  r << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  return r;
}

}  // namespace

void RenderOptions::validate() const {
  if (!std::isfinite(camera_height) || !(camera_height > 0.0)) {
    throw std::invalid_argument("render: camera_height must be > 0");
  }
  if (!std::isfinite(noise_sigma) || noise_sigma < 0.0) throw std::invalid_argument("render: noise_sigma must be >= 0");
  if (!std::isfinite(blur_sigma) || blur_sigma < 0.0) throw std::invalid_argument("render: blur_sigma must be >= 0");
  if (!std::isfinite(camera_pitch) || std::abs(camera_pitch) > 0.3) {
    throw std::invalid_argument("render: camera_pitch must be within [-0.3, 0.3] rad");
  }
  if (!std::isfinite(camera_roll) || std::abs(camera_roll) > 0.3) {
    throw std::invalid_argument("render: camera_roll must be within [-0.3, 0.3] rad");
  }
  if (!std::isfinite(exposure_time) || exposure_time < 0.0) throw std::invalid_argument("render: exposure_time must be >= 0");
  if (!std::isfinite(lamp_contrast) || lamp_contrast < 0.0 || lamp_contrast >= 1.0) {
    throw std::invalid_argument("render: lamp_contrast must be in [0, 1)");
  }
  if (!std::isfinite(lamp_spacing) || !(lamp_spacing > 0.0)) throw std::invalid_argument("render: lamp_spacing must be > 0");
  if (supersampling < 1 || supersampling > 8) throw std::invalid_argument("render: supersampling must be in [1, 8]");
}

WorldRenderer::WorldRenderer(const PinholeCamera& camera, const RenderOptions& options)
    : camera_(camera), options_(options) {
  options_.validate();
  if (options_.supersampling > 1) {
    // Pixel (u, v) covers the fine pixels k·u .. k·u + k − 1, whose centre is k·u + (k − 1)/2.
    const int k = options_.supersampling;
    CameraCalibration fine = camera_.calibration();
    fine.width *= k;
    fine.height *= k;
    fine.fx *= k;
    fine.fy *= k;
    fine.cx = k * fine.cx + 0.5 * (k - 1);
    fine.cy = k * fine.cy + 0.5 * (k - 1);
    RenderOptions samples = options_;  // only its samples are used (renderSamples): no blur, no noise
    samples.supersampling = 1;
    fine_ = std::make_shared<const WorldRenderer>(PinholeCamera(fine), samples);
    return;
  }
  if (!camera_.hasDistortion() && options_.camera_pitch == 0.0 && options_.camera_roll == 0.0) return;
  // Each pixel's ray: undistorted through the lens model, then from the tilted camera to the
  // level one (the optical frame of opticalToBase() against that of a level mount).
  const Eigen::Matrix3d level_from_camera = levelOpticalToBase().transpose() * opticalToBase();
  pixel_rays_.reserve(static_cast<std::size_t>(camera_.width()) * static_cast<std::size_t>(camera_.height()));
  for (int v = 0; v < camera_.height(); ++v) {
    for (int u = 0; u < camera_.width(); ++u) {
      const Eigen::Vector2d n = camera_.pixelToNormalized(cv::Point2d(u, v));
      pixel_rays_.push_back(level_from_camera * Eigen::Vector3d(n.x(), n.y(), 1.0));
    }
  }
}

Eigen::Matrix3d WorldRenderer::opticalToBase() const {
  // The level mount's optical axes turned by REP-103 roll about x, then pitch about y (fixed axes).
  const Eigen::Matrix3d tilt = (Eigen::AngleAxisd(options_.camera_pitch, Eigen::Vector3d::UnitY()) *
                                Eigen::AngleAxisd(options_.camera_roll, Eigen::Vector3d::UnitX()))
                                   .toRotationMatrix();
  return tilt * levelOpticalToBase();
}

cv::Mat WorldRenderer::render(const PlanarWorld& world, const Pose2D& camera_pose, double gain,
                              cv::RNG& rng, double yaw_rate) const {
  cv::Mat image;
  if (fine_) {
    // The lens blurs the scene before the sensor samples it; each pixel integrates over its area.
    cv::Mat fine = fine_->renderSamples(world, camera_pose, gain);
    if (options_.blur_sigma > 0.0) cv::GaussianBlur(fine, fine, cv::Size(), options_.blur_sigma * options_.supersampling);
    cv::resize(fine, image, cv::Size(camera_.width(), camera_.height()), 0.0, 0.0, cv::INTER_AREA);
  } else {
    image = renderSamples(world, camera_pose, gain);
  }
  const double blur_length = std::abs(yaw_rate) * options_.exposure_time * camera_.fx();  // [px]
  if (blur_length > 1.0) {
    // The image sweeps horizontally by blur_length during the exposure, centred on the stamp's
    // pose: a box of that length along rows, centred on the pixel (an odd kernel whose end taps
    // hold the fraction of a pixel the box covers). cv::blur's even kernels are anchored half a
    // pixel off centre: at 0.3 rad/s and 8 ms that shifted every image by 0.5 px (0.06° of
    // heading, as much as a fix's σ).
    const int half = static_cast<int>(std::ceil(0.5 * blur_length - 0.5));
    cv::Mat kernel(1, 2 * half + 1, CV_32F);
    for (int o = -half; o <= half; ++o) {
      const double overlap = std::min(o + 0.5, 0.5 * blur_length) - std::max(o - 0.5, -0.5 * blur_length);
      kernel.at<float>(0, o + half) = static_cast<float>(std::max(0.0, overlap) / blur_length);
    }
    cv::filter2D(image, image, -1, kernel, cv::Point(-1, -1), 0.0, cv::BORDER_REFLECT);
  }
  if (!fine_ && options_.blur_sigma > 0.0) cv::GaussianBlur(image, image, cv::Size(), options_.blur_sigma);
  if (options_.noise_sigma > 0.0) {
    cv::Mat noise(image.size(), CV_16SC3);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, options_.noise_sigma);
    cv::Mat noisy;
    image.convertTo(noisy, CV_16SC3);
    noisy += noise;
    noisy.convertTo(image, CV_8UC3);
  }
  return image;
}

cv::Mat WorldRenderer::renderSamples(const PlanarWorld& world, const Pose2D& camera_pose, double gain) const {
  const int width = camera_.width(), height = camera_.height();
  cv::Mat image(height, width, CV_8UC3);
  const Eigen::Vector2d origin(camera_pose.x, camera_pose.y);
  const Eigen::Vector2d forward(std::cos(camera_pose.yaw), std::sin(camera_pose.yaw));
  const Eigen::Vector2d right(std::sin(camera_pose.yaw), -std::cos(camera_pose.yaw));
  const Surroundings surroundings{
      cv::Vec3f(world.floor_colour[0], world.floor_colour[1], world.floor_colour[2]),
      cv::Vec3f(world.ceiling_colour[0], world.ceiling_colour[1], world.ceiling_colour[2]), options_.camera_height,
      options_.lamp_contrast, options_.lamp_spacing};
  auto put = [&](int row, int col, const cv::Vec3f& c) {
    cv::Vec3b& p = image.at<cv::Vec3b>(row, col);
    for (int k = 0; k < 3; ++k) p[k] = cv::saturate_cast<unsigned char>(gain * c[k]);
  };
  if (pixel_rays_.empty()) {
    for (int u = 0; u < width; ++u) {
      // Ray of the column: forward + x_n right, x_n = (u - cx) / fx; its parameter t is the depth
      // along the optical axis, and a pixel's ray drops y_n = (v - cy) / fy per unit of t.
      const double xn = (u - camera_.cx()) / camera_.fx();
      const Eigen::Vector2d direction = forward + xn * right;
      const auto hit = castRay(world, origin, direction);
      for (int v = 0; v < height; ++v) {
        put(v, u, colourAlong(world, origin, direction, hit, (v - camera_.cy()) / camera_.fy(), surroundings));
      }
    }
  } else {
    std::size_t i = 0;
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u, ++i) {
        const Eigen::Vector3d& ray = pixel_rays_[i];  // right, down, forward
        const Eigen::Vector2d horizontal = ray.z() * forward + ray.x() * right;
        const auto hit = horizontal.squaredNorm() > 1e-18 ? castRay(world, origin, horizontal) : std::nullopt;
        put(v, u, colourAlong(world, origin, horizontal, hit, ray.y(), surroundings));
      }
    }
  }
  return image;
}

std::vector<float> castScan(const PlanarWorld& world, const Pose2D& pose, double angle_min,
                            double angle_max, int count, double range_max) {
  std::vector<float> ranges(static_cast<std::size_t>(std::max(count, 0)), std::numeric_limits<float>::infinity());
  const Eigen::Vector2d origin(pose.x, pose.y);
  for (int i = 0; i < count; ++i) {
    const double angle = pose.yaw + angle_min + (count > 1 ? (angle_max - angle_min) * i / (count - 1) : 0.0);
    const auto hit = castRay(world, origin, Eigen::Vector2d(std::cos(angle), std::sin(angle)));
    if (hit && hit->range <= range_max) ranges[static_cast<std::size_t>(i)] = static_cast<float>(hit->range);
  }
  return ranges;
}

}  // namespace homography_teach_repeat
