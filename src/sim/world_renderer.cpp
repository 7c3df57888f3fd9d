#include "homography_teach_repeat/sim/world_renderer.h"

#include <opencv2/imgproc.hpp>

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

}  // namespace

void RenderOptions::validate() const {
  if (!std::isfinite(camera_height) || !(camera_height > 0.0)) {
    throw std::invalid_argument("render: camera_height must be > 0");
  }
  if (!std::isfinite(noise_sigma) || noise_sigma < 0.0) throw std::invalid_argument("render: noise_sigma must be >= 0");
  if (!std::isfinite(blur_sigma) || blur_sigma < 0.0) throw std::invalid_argument("render: blur_sigma must be >= 0");
}

WorldRenderer::WorldRenderer(const PinholeCamera& camera, const RenderOptions& options)
    : camera_(camera), options_(options) {
  options_.validate();
  if (camera_.hasDistortion()) throw std::invalid_argument("render: the simulated camera must have no distortion");
}

cv::Mat WorldRenderer::render(const PlanarWorld& world, const Pose2D& camera_pose, double gain,
                              cv::RNG& rng) const {
  const int width = camera_.width(), height = camera_.height();
  cv::Mat image(height, width, CV_8UC3);
  const Eigen::Vector2d origin(camera_pose.x, camera_pose.y);
  const Eigen::Vector2d forward(std::cos(camera_pose.yaw), std::sin(camera_pose.yaw));
  const Eigen::Vector2d right(std::sin(camera_pose.yaw), -std::cos(camera_pose.yaw));
  const cv::Vec3f floor(world.floor_colour[0], world.floor_colour[1], world.floor_colour[2]);
  const cv::Vec3f ceiling(world.ceiling_colour[0], world.ceiling_colour[1], world.ceiling_colour[2]);
  auto put = [&](int row, int col, const cv::Vec3f& c) {
    cv::Vec3b& p = image.at<cv::Vec3b>(row, col);
    for (int k = 0; k < 3; ++k) p[k] = cv::saturate_cast<unsigned char>(gain * c[k]);
  };
  for (int u = 0; u < width; ++u) {
    // Ray of the column: forward + x_n right, x_n = (u - cx) / fx; its parameter t is the depth
    // along the optical axis.
    const double xn = (u - camera_.cx()) / camera_.fx();
    const auto hit = castRay(world, origin, forward + xn * right);
    for (int v = 0; v < height; ++v) {
      const double yn = (v - camera_.cy()) / camera_.fy();  // down
      if (!hit) {
        put(v, u, yn > 0.0 ? floor : ceiling);
        continue;
      }
      const Wall& wall = world.walls[static_cast<std::size_t>(hit->wall)];
      const double z = options_.camera_height - yn * hit->range;  // height on the wall [m]
      if (z < 0.0) {
        put(v, u, floor);
      } else if (z > wall.height) {
        put(v, u, ceiling);
      } else {
        // Texture tiled from the wall's start point and up from the floor (image rows downward).
        const double tu = hit->along / wall.texture_width * wall.texture.cols;
        const double tv = (1.0 - std::fmod(z, wall.texture_height) / wall.texture_height) * wall.texture.rows;
        put(v, u, sampleTiled(wall.texture, tu - 0.5, tv - 0.5));
      }
    }
  }
  if (options_.blur_sigma > 0.0) cv::GaussianBlur(image, image, cv::Size(), options_.blur_sigma);
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
