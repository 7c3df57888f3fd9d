#include "homography_teach_repeat/sim/world_renderer.h"

#include <opencv2/imgproc.hpp>

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace homography_teach_repeat {
namespace {

struct Surroundings {
  cv::Vec3f floor;
  cv::Vec3f ceiling;
  double camera_height;
  double lamp_contrast;
  double lamp_spacing;
};

// What a ray sees: a wall's texture at `along` [m] from its start and `z` [m] up, lit by
// `brightness`, or a flat colour (floor, ceiling, an object's top).
struct SceneSample {
  static constexpr int kFloor = -1, kCeiling = -2, kObjectTop = -3;
  int surface = kFloor;  // the wall's index, or one of the flat surfaces
  double along = 0.0, z = 0.0;
  float brightness = 1.0f;
};

// `hit` is the first wall the ray's horizontal part origin + t·direction meets (or nothing),
// `down` how far it drops per unit of t (a wall point's height is camera_height − down·t).
// Above a room wall is the ceiling; above an object standing in the room (Wall::see_over) the ray
// goes on to what is behind it, and where it meets such an object's side from inside, below its
// top, it came down onto the object's top (drawn flat grey).
SceneSample sampleAlong(const PlanarWorld& world, const Eigen::Vector2d& origin, const Eigen::Vector2d& direction,
                        std::optional<RayHit> hit, double down, const Surroundings& s) {
  SceneSample sample;
  while (hit) {
    const Wall& wall = world.walls[static_cast<std::size_t>(hit->wall)];
    const double z = s.camera_height - down * hit->range;  // height on the wall [m]
    if (z < 0.0) return sample;
    if (z > wall.height) {
      if (!wall.see_over) {
        sample.surface = SceneSample::kCeiling;
        return sample;
      }
      hit = castRay(world, origin, direction, hit->range);  // over it: what is behind
      continue;
    }
    if (wall.see_over) {
      // Sides are listed counter-clockwise (outward normal on the right of start -> end): a ray
      // meeting one from inside has come down onto the top.
      const Eigen::Vector2d edge = wall.end - wall.start;
      if (direction.dot(Eigen::Vector2d(edge.y(), -edge.x())) > 0.0) {
        sample.surface = SceneSample::kObjectTop;
        return sample;
      }
    }
    sample.surface = hit->wall;
    sample.along = hit->along;
    sample.z = z;
    if (s.lamp_contrast > 0.0) {
      sample.brightness = static_cast<float>(1.0 + s.lamp_contrast * std::cos(2.0 * M_PI * hit->along / s.lamp_spacing));
    }
    return sample;
  }
  if (!(down > 0.0)) sample.surface = SceneSample::kCeiling;
  return sample;
}

// Texture coordinates [texels] of a wall point: tiled from the wall's start point and up from the
// floor (image rows downward). `tv` is not wrapped (the sampler tiles), so that it is smooth.
Eigen::Vector2d textureCoordinates(const Wall& wall, const SceneSample& sample) {
  return {sample.along / wall.texture_width * wall.texture.cols, (1.0 - sample.z / wall.texture_height) * wall.texture.rows};
}

// The colour of one sample of the scene, one point of the texture (bilinear). Its `tv` is wrapped
// before sampling as the renderer always did (textureCoordinates' unwrapped one differs in the last
// bits, and one sample per pixel stays byte-identical).
cv::Vec3f pointColour(const PlanarWorld& world, const SceneSample& sample, const Surroundings& s) {
  switch (sample.surface) {
    case SceneSample::kFloor: return s.floor;
    case SceneSample::kCeiling: return s.ceiling;
    case SceneSample::kObjectTop: return cv::Vec3f(128.0f, 128.0f, 128.0f);
    default: break;
  }
  const Wall& wall = world.walls[static_cast<std::size_t>(sample.surface)];
  const double tu = sample.along / wall.texture_width * wall.texture.cols;
  const double tv = (1.0 - std::fmod(sample.z, wall.texture_height) / wall.texture_height) * wall.texture.rows;
  cv::Vec3f colour = sampleTiled(wall.texture, tu - 0.5, tv - 0.5);
  if (s.lamp_contrast > 0.0) colour *= sample.brightness;
  return colour;
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
  if (texture_filtering && supersampling > 1) {
    throw std::invalid_argument("render: texture_filtering and supersampling > 1 are two ways to band-limit: choose one");
  }
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
  level_from_camera_ = levelOpticalToBase().transpose() * opticalToBase();
  pixel_rays_.reserve(static_cast<std::size_t>(camera_.width()) * static_cast<std::size_t>(camera_.height()));
  for (int v = 0; v < camera_.height(); ++v) {
    for (int u = 0; u < camera_.width(); ++u) {
      const Eigen::Vector2d n = camera_.pixelToNormalized(cv::Point2d(u, v));
      pixel_rays_.push_back(level_from_camera_ * Eigen::Vector3d(n.x(), n.y(), 1.0));
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
  // (With texture filtering the lens's blur is in each pixel's filter.)
  if (!fine_ && !options_.texture_filtering && options_.blur_sigma > 0.0) {
    cv::GaussianBlur(image, image, cv::Size(), options_.blur_sigma);
  }
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
  const Eigen::Vector2d origin(camera_pose.x, camera_pose.y);
  const Eigen::Vector2d forward(std::cos(camera_pose.yaw), std::sin(camera_pose.yaw));
  const Eigen::Vector2d right(std::sin(camera_pose.yaw), -std::cos(camera_pose.yaw));
  const Surroundings surroundings{
      cv::Vec3f(world.floor_colour[0], world.floor_colour[1], world.floor_colour[2]),
      cv::Vec3f(world.ceiling_colour[0], world.ceiling_colour[1], world.ceiling_colour[2]), options_.camera_height,
      options_.lamp_contrast, options_.lamp_spacing};
  // The ray of image column u (level camera): forward + x_n right, x_n = (u - cx) / fx; its
  // parameter t is the depth along the optical axis, and a pixel's ray drops y_n = (v - cy) / fy
  // per unit of t.
  auto columnDirection = [&](double u) -> Eigen::Vector2d { return forward + (u - camera_.cx()) / camera_.fx() * right; };
  // What a ray of the level optical frame (right, down, forward) meets (the tilted or distorting camera's).
  auto sampleRay = [&](const Eigen::Vector3d& ray) {
    const Eigen::Vector2d horizontal = ray.z() * forward + ray.x() * right;
    const auto hit = horizontal.squaredNorm() > 1e-18 ? castRay(world, origin, horizontal) : std::nullopt;
    return sampleAlong(world, origin, horizontal, hit, ray.y(), surroundings);
  };
  // What each pixel's ray meets, column by column (index u * height + v).
  // (Kept from call to call in each thread: a fresh 10 MB a frame costs more in page faults than
  // the point samples themselves.)
  thread_local std::vector<SceneSample> samples;
  samples.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  auto at = [&](int u, int v) -> SceneSample& { return samples[static_cast<std::size_t>(u) * height + v]; };
  if (pixel_rays_.empty()) {
    for (int u = 0; u < width; ++u) {
      const Eigen::Vector2d direction = columnDirection(u);
      const auto hit = castRay(world, origin, direction);
      for (int v = 0; v < height; ++v) at(u, v) = sampleAlong(world, origin, direction, hit, (v - camera_.cy()) / camera_.fy(), surroundings);
    }
  } else {
    for (int v = 0; v < height; ++v) {
      for (int u = 0; u < width; ++u) {
        at(u, v) = sampleRay(pixel_rays_[static_cast<std::size_t>(v) * width + u]);
      }
    }
  }
  cv::Mat image(height, width, CV_8UC3);
  auto put = [&](int row, int col, const cv::Vec3f& c) {
    cv::Vec3b& p = image.at<cv::Vec3b>(row, col);
    for (int k = 0; k < 3; ++k) p[k] = cv::saturate_cast<unsigned char>(gain * c[k]);
  };
  if (!options_.texture_filtering) {
    for (int u = 0; u < width; ++u) {
      for (int v = 0; v < height; ++v) put(v, u, pointColour(world, at(u, v), surroundings));
    }
    return image;
  }
  // Band-limited (docs/simulator.md, "What a pixel sees"): each pixel sees its wall's texture
  // through the lens's blur and its own area, a Gaussian of sigma_pixel [px] (the lens's
  // blur_sigma and the pixel's box, variance 1/12) mapped onto the texture by the pixel's footprint
  // (the texture coordinates' derivatives across the image, from the neighbouring pixels on the
  // same wall), from the texture's ripmap.
  const double sigma_pixel = std::sqrt(options_.blur_sigma * options_.blur_sigma + 1.0 / 12.0);
  const double sigma_box = std::sqrt(1.0 / 12.0);
  std::vector<const TextureRipmap*> ripmaps(world.walls.size(), nullptr);
  thread_local std::vector<Eigen::Vector2d> texels;  // texture coordinates of wall samples
  texels.resize(samples.size());
  for (std::size_t i = 0; i < samples.size(); ++i) {
    const int surface = samples[i].surface;
    if (surface < 0) continue;
    const Wall& wall = world.walls[static_cast<std::size_t>(surface)];
    if (!ripmaps[static_cast<std::size_t>(surface)]) ripmaps[static_cast<std::size_t>(surface)] = &ripmaps_->of(wall.texture);
    texels[i] = textureCoordinates(wall, samples[i]);
  }
  auto texel = [&](int u, int v) -> const Eigen::Vector2d& { return texels[static_cast<std::size_t>(u) * height + v]; };
  // The derivative of the texture coordinates along one image axis at (u, v): central where both
  // neighbours are on the same wall, one-sided where one is, none where neither is.
  auto derivative = [&](int u, int v, int du, int dv) -> Eigen::Vector2d {
    const int surface = at(u, v).surface;
    const bool before = u - du >= 0 && v - dv >= 0 && at(u - du, v - dv).surface == surface;
    const bool after = u + du < width && v + dv < height && at(u + du, v + dv).surface == surface;
    if (before && after) return 0.5 * (texel(u + du, v + dv) - texel(u - du, v - dv));
    if (after) return texel(u + du, v + dv) - texel(u, v);
    if (before) return texel(u, v) - texel(u - du, v - dv);
    return Eigen::Vector2d::Zero();
  };
  // The texture at pixel (u, v) blurred by a Gaussian of `sigma` pixels.
  auto filtered = [&](int u, int v, double sigma) -> cv::Vec3f {
    const SceneSample& sample = at(u, v);
    const Eigen::Vector2d across = derivative(u, v, 1, 0), down = derivative(u, v, 0, 1);
    const Eigen::Vector2d& t = texel(u, v);
    cv::Vec3f colour = ripmaps[static_cast<std::size_t>(sample.surface)]->sample(
        t.x() - 0.5, t.y() - 0.5, sigma * std::hypot(across.x(), down.x()), sigma * std::hypot(across.y(), down.y()));
    if (options_.lamp_contrast > 0.0) colour *= sample.brightness;
    return colour;
  };
  // Where two surfaces meet (a wall's top against the ceiling or its foot against the floor, two
  // panels, a corner, an object before a wall) a texture's filter does not reach across, and the
  // edge of one sample per pixel moves in whole pixels: such a pixel is integrated over its area
  // (kEdgeSamples² points of the scene), its neighbours are the texture blurred by their area, and
  // the lens then blurs them: the edge where it is, to 1/kEdgeSamples of a pixel, as the sensor sees
  // it. (The far wall's keyframes of the room spread up to 4.3 times their prediction without it.)
  constexpr int kEdgeSamples = 8;
  cv::Mat edges(height, width, CV_8U, cv::Scalar(0));
  for (int u = 0; u < width; ++u) {
    for (int v = 0; v < height; ++v) {
      const int surface = at(u, v).surface;
      if ((u > 0 && at(u - 1, v).surface != surface) || (u + 1 < width && at(u + 1, v).surface != surface) ||
          (v > 0 && at(u, v - 1).surface != surface) || (v + 1 < height && at(u, v + 1).surface != surface)) {
        edges.at<unsigned char>(v, u) = 1;
      }
    }
  }
  cv::Mat band;  // the edges and the pixels beside them, which the lens's blur of an edge reaches
  cv::dilate(edges, band, cv::Mat());
  // The mean colour over pixel (u, v)'s area: kEdgeSamples² points of the scene. The level camera
  // casts each of its sub-columns once per image column (`column_hits`, cast when first needed).
  std::vector<std::optional<RayHit>> column_hits(kEdgeSamples);
  // The ray through a point inside a pixel of the tilted or distorting camera: bilinear in the
  // pixels' rays (the lens's map is smooth over a pixel; at the image's border extrapolated from
  // the last two). Undistorting each of the 64 points (iterative for plumb_bob) made a band-limited
  // image with a lens 10 times slower than one sample per pixel.
  auto pixelRayAt = [&](double su, double sv) -> Eigen::Vector3d {
    // (A camera one pixel wide or high interpolates its one ray with itself.)
    const int u0 = std::clamp(static_cast<int>(std::floor(su)), 0, std::max(width - 2, 0));
    const int v0 = std::clamp(static_cast<int>(std::floor(sv)), 0, std::max(height - 2, 0));
    const int u1 = std::min(u0 + 1, width - 1), v1 = std::min(v0 + 1, height - 1);
    const double a = su - u0, b = sv - v0;
    auto ray = [&](int u, int v) -> const Eigen::Vector3d& {
      return pixel_rays_[static_cast<std::size_t>(v) * width + static_cast<std::size_t>(u)];
    };
    return (1.0 - b) * ((1.0 - a) * ray(u0, v0) + a * ray(u1, v0)) + b * ((1.0 - a) * ray(u0, v1) + a * ray(u1, v1));
  };
  auto integrated = [&](int u, int v, bool& column_hits_cast) -> cv::Vec3f {
    if (pixel_rays_.empty() && !column_hits_cast) {
      for (int i = 0; i < kEdgeSamples; ++i) {
        column_hits[static_cast<std::size_t>(i)] = castRay(world, origin, columnDirection(u + (i + 0.5) / kEdgeSamples - 0.5));
      }
      column_hits_cast = true;
    }
    cv::Vec3f sum(0.0f, 0.0f, 0.0f);
    for (int i = 0; i < kEdgeSamples; ++i) {
      const double su = u + (i + 0.5) / kEdgeSamples - 0.5;
      const Eigen::Vector2d direction = columnDirection(su);
      for (int j = 0; j < kEdgeSamples; ++j) {
        const double sv = v + (j + 0.5) / kEdgeSamples - 0.5;
        SceneSample point;
        if (pixel_rays_.empty()) {
          point = sampleAlong(world, origin, direction, column_hits[static_cast<std::size_t>(i)],
                              (sv - camera_.cy()) / camera_.fy(), surroundings);
        } else {
          point = sampleRay(pixelRayAt(su, sv));
        }
        sum += pointColour(world, point, surroundings);
      }
    }
    return sum / static_cast<float>(kEdgeSamples * kEdgeSamples);
  };
  for (int u = 0; u < width; ++u) {
    bool column_hits_cast = false;
    for (int v = 0; v < height; ++v) {
      const SceneSample& sample = at(u, v);
      if (edges.at<unsigned char>(v, u)) {
        put(v, u, integrated(u, v, column_hits_cast));
      } else if (sample.surface < 0) {
        put(v, u, pointColour(world, sample, surroundings));
      } else {
        // Beside an edge the lens's blur comes after (below): the pixel's area alone here.
        put(v, u, filtered(u, v, band.at<unsigned char>(v, u) ? sigma_box : sigma_pixel));
      }
    }
  }
  if (options_.blur_sigma > 0.0) {
    cv::Mat blurred;
    cv::GaussianBlur(image, blurred, cv::Size(), options_.blur_sigma);
    blurred.copyTo(image, band);
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
